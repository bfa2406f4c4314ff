// The scene file's slices (docs/scene-file.md): a plane through a volume, cut to its box and coloured by
// the volume's trilinear values through a colour map; it receives the shadows of everything and casts
// none unless asked (an opaque one). A slice is drawn as a plane (Scene::planes from first_slice on); a
// translucent one (opacity below 1) over what lies behind it.
#include "penumbra/scene_io/scene_sections.h"

namespace penumbra::scene_sections {

Plane read_slice(const nlohmann::json& j, const std::string& path, const std::vector<VolumeObject>& volumes,
                 const std::string& base_dir) {
  JsonReader r(j, path);
  if (volumes.empty()) r.fail("volume", "the scene has no volumes (a slice shows one of 'volumes')");
  const auto index = static_cast<std::size_t>(r.integer("volume", 0, 0, INT32_MAX));
  if (index >= volumes.size())
    r.fail("volume", "index " + std::to_string(index) + " but the scene has " + std::to_string(volumes.size()) + " volume(s)");
  const VolumeObject& v = volumes[index];
  const float lo = v.volume->min_value(), hi = v.volume->max_value();
  auto colors = std::make_shared<SliceColors>();
  colors->volume = v.volume;
  colors->volume_index = index;
  if (r.has("color_map") && r.has("window"))
    r.fail("window", "give 'color_map' (a transfer function's colours) or 'window' (grey from lo to hi), not both");
  if (r.has("color_map")) {
    colors->color_map = with_context(r.key_path("color_map"), [&] { return parse_transfer_function(r.raw("color_map"), lo, hi, base_dir); });
  } else {
    const nlohmann::json& w = r.has("window") ? r.raw("window") : nlohmann::json::array({lo, hi});
    if (!w.is_array() || w.size() != 2 || !w[0].is_number() || !w[1].is_number() || !(w[0].get<double>() < w[1].get<double>()))
      r.fail("window", "expected [lo, hi] in the data's units with lo < hi (the data holds " + num(lo) + " to " + num(hi) + ")");
    const float a = w[0].get<float>(), b = w[1].get<float>();
    colors->color_map = TransferFunction(std::vector<TransferPoint>{{a, {0, 0, 0}, 1}, {b, {1, 1, 1}, 1}});
  }
  Plane p;
  p.opacity = r.number("opacity", 1, 0, 1);
  if (p.opacity < 1 && r.has("casts_shadows") && r.boolean("casts_shadows", false))
    r.fail("casts_shadows", "a translucent slice ('opacity' below 1) casts no shadow: give 'opacity': 1 for a slice that casts");
  p.point = r.vec3("point", v.volume->bounds().center());
  p.normal = normalize(r.vec3("normal", {0, 0, 1}));
  if (length(p.normal) == 0) r.fail("normal", "must not be the zero vector");
  p.casts_shadows = false;  // a slice only receives unless asked
  p.slice = std::move(colors);
  read_shadow_flags(r, p);
  r.finish();
  return p;
}

}  // namespace penumbra::scene_sections
