// A rendered frame as the viewer's page receives it (docs/viewer.md, the "frame" message): the JPEG
// and the JSON that describes it. The server sends both over its WebSocket; the notebook widget
// (python/penumbra/widget.py) over the kernel's comm.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "penumbra/engine/engine.h"

namespace penumbra {

struct FrameMessage {
  nlohmann::json meta;  // {"type": "frame", "quality", "samples", "width", "height", "ms", ...}; no "id"
  std::string jpeg;
};

// `quality` is the frame's (a preview is encoded with fewer bytes); `ms` the time it took to render;
// `max_samples` how many full samples the sender accumulates while idle (the page's progress bar).
FrameMessage frame_message(const EngineFrame& frame, Quality quality, const Scene& scene, double ms, int max_samples);

// This process's resident memory in MB (/proc/self/statm), reported with each frame.
double resident_mb();

}  // namespace penumbra
