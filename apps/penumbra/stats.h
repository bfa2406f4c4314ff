// The `--stats` JSON of a render (DESIGN.md): technique, size, timings, memory, counts, threads, seed,
// and for sequences one entry per frame with what it rebuilt.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

#include "penumbra/render/renderer.h"

namespace penumbra::cli {

nlohmann::json frame_stats(const FrameResult& frame);
nlohmann::json render_stats(const Scene& scene, const Renderer& renderer, const FrameResult& first, int threads);
void write_json_file(const std::string& path, const nlohmann::json& j);  // via a temporary file + rename

}  // namespace penumbra::cli
