#include "penumbra/viewer/probe.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/scene/camera.h"

namespace penumbra {

nlohmann::json probe_message(const Scene& scene, float x, float y) {
  const Ray ray = scene.camera.primary_ray(x, y);
  nlohmann::json m = {{"type", "probe"}, {"pixel", {x, y}}, {"hit", false}};
  float nearest = kInfinity;
  for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
    const VolumeObject& v = scene.volumes[i];
    if (!v.visible) continue;
    float t0 = 0, t1 = 0;
    if (!v.volume->bounds().clip(ray, t0, t1, 0, nearest)) continue;
    if (v.clip && !scene.clip_planes.empty() && !scene.clip_planes.keep(ray, t0, t1)) continue;
    const float step = v.step_world();
    for (float t = t0; t <= t1; t += step) {
      const Vec3 p = ray.at(t);
      const float value = v.volume->sample(p);
      if (v.transfer_function.evaluate(value).a > kProbeAlpha) {
        nearest = t;
        m["hit"] = true;
        m["volume"] = i;
        m["value"] = value;
        m["position"] = {p.x, p.y, p.z};
        break;
      }
    }
  }
  return m;
}

std::pair<float, float> probe_pixel(const nlohmann::json& message) {
  const auto it = message.find("pixel");
  const auto ok = [](const nlohmann::json& c) { return c.is_number() && std::abs(c.get<double>()) <= 1e6; };
  if (it == message.end() || !it->is_array() || it->size() != 2 || !ok((*it)[0]) || !ok((*it)[1]))
    throw Error("probe: expected \"pixel\": [x, y], the view's pixel (numbers within ±1e6)");
  return {(*it)[0].get<float>(), (*it)[1].get<float>()};
}

}  // namespace penumbra
