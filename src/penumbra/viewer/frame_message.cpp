#include "penumbra/viewer/frame_message.h"

#include <unistd.h>

#include <fstream>

#include "penumbra/render/view_refinement.h"
#include "penumbra/viewer/jpeg.h"

namespace penumbra {

namespace {

constexpr int kPreviewJpegQuality = 75;
constexpr int kFullJpegQuality = 92;

}  // namespace

double resident_mb() {
  std::ifstream statm("/proc/self/statm");
  double pages_total = 0, pages_resident = 0;
  statm >> pages_total >> pages_resident;
  return pages_resident * static_cast<double>(::sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

FrameMessage frame_message(const EngineFrame& f, Quality quality, const Scene& scene, double ms, int max_samples) {
  FrameMessage m;
  m.jpeg = encode_jpeg(f.image, quality == Quality::Preview ? kPreviewJpegQuality : kFullJpegQuality);
  nlohmann::json rebuilt = nlohmann::json::array();
  for (const auto& r : f.rebuilt) rebuilt.push_back({{"structure", r.structure}, {"cause", r.cause}});
  m.meta = {{"type", "frame"},        {"quality", quality == Quality::Preview ? "preview" : "full"},
            {"samples", f.samples},   {"width", f.image.width()},
            {"height", f.image.height()}, {"ms", ms},
            {"view_width", scene.camera.width}, {"view_height", scene.camera.height},
            {"divisor", f.divisor},   {"rebuilt", rebuilt},
            {"edits", f.edits},       {"memory_mb", resident_mb()},
            {"time", scene.time},     {"max_samples", max_samples},
            // each pyramid drawn from a finer box where the camera looks (render/view_refinement.h)
            {"refinement", refinement_json(f.frame.refinement)}};
  return m;
}

}  // namespace penumbra
