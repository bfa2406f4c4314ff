#include "penumbra/viewer/viewer_state.h"

#include <cmath>

#include "penumbra/data/transfer_function.h"
#include "penumbra/data/transfer_function_choice.h"
#include "penumbra/data/volume_stats.h"
#include "penumbra/registry/technique_catalog.h"

namespace penumbra {
namespace {

constexpr int kHistogramBins = 64;

nlohmann::json vec3(const Vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); }

nlohmann::json rgb(std::uint32_t packed) {
  const Rgb c = unpack_rgb8(packed);
  return nlohmann::json::array({c.r, c.g, c.b});
}

// A particle set's colour key (data/color_key.h), colours as linear RGB as the transfer functions'.
nlohmann::json color_key_message(const ColorKey& key) {
  nlohmann::json m = {{"by", key.by}};
  nlohmann::json entries = nlohmann::json::array();
  for (const auto& e : key.entries) entries.push_back({{"label", e.label}, {"color", rgb(e.color)}, {"count", e.count}});
  m["entries"] = entries;
  if (!key.ramp.empty()) {
    nlohmann::json ramp = nlohmann::json::array();
    for (const std::uint32_t c : key.ramp) ramp.push_back(rgb(c));
    m["quantity"] = key.quantity;
    m["lo"] = key.lo;
    m["hi"] = key.hi;
    m["ramp"] = ramp;
  }
  return m;
}

// The techniques, the keys each reads, and every key's declaration (type, default, range or choices,
// unit, meaning: lighting/technique_info.h), so that the page can offer fields for them.
nlohmann::json technique_lists() {
  nlohmann::json keys = nlohmann::json::object();
  for (const TechniqueInfo* t : technique_catalog()) {
    nlohmann::json k = nlohmann::json::array();
    for (const ParamSpec& p : t->params) k.push_back(p.key);
    keys[t->name] = k;
  }
  nlohmann::json params = nlohmann::json::object();
  for (const TechniqueFamily family : {TechniqueFamily::Shadow, TechniqueFamily::Ambient}) {
    nlohmann::json section = nlohmann::json::object();
    for (const ParamSpec* p : family_params(family)) {
      nlohmann::json d = {{"type", p->type_text()}, {"unit", p->unit}, {"meaning", p->meaning}, {"allowed", p->allowed_text()}};
      if (p->type == ParamType::Choice) {
        d["default"] = p->default_choice;
        d["choices"] = p->choices;
      } else {
        d["default"] = p->default_number;
        d["min"] = p->min;
        d["max"] = p->max;
      }
      section[p->key] = d;
    }
    params[to_string(family)] = section;
  }
  return {{"techniques", {{"shadows", technique_names(TechniqueFamily::Shadow)}, {"ambient", technique_names(TechniqueFamily::Ambient)}}},
          {"technique_keys", keys},
          {"technique_parameters", params}};
}

}  // namespace

nlohmann::json ViewerState::message(const Engine& engine) {
  const Scene& scene = engine.scene();
  nlohmann::json m = technique_lists();
  m["type"] = "state";
  m["document"] = engine.document();
  m["camera"] = {{"eye", vec3(scene.camera.eye)}, {"target", vec3(scene.camera.target)}, {"up", vec3(scene.camera.up)},
                 {"fov_deg", scene.camera.fov_deg}, {"width", scene.camera.width}, {"height", scene.camera.height}};
  // trajectories and volume series: the frame shown, how many there are, its time where the file says
  m["time"] = {{"frame", scene.time}, {"frames", scene.frame_count()}};
  for (const auto& p : scene.particles)
    if (p.frames > 0) m["time"]["time_ps"] = p.time_ps;
  // per particle set: the spheres drawn and, with particles[].select, the atoms the selection kept
  m["particles"] = nlohmann::json::array();
  // and what its colours mean (the legend), and its periodic cell where the file stores one
  for (const auto& p : scene.particles) {
    nlohmann::json entry = {{"spheres", p.set && p.visible ? p.set->size() : 0},
                            {"selected", p.selected_atoms ? nlohmann::json(*p.selected_atoms) : nlohmann::json(nullptr)},
                            {"visible", p.visible}};
    if (p.set) {
      entry["color_key"] = color_key_message(p.set->color_key);
      if (p.set->box)
        entry["box"] = {{"origin", vec3(p.set->box->origin)}, {"a", vec3(p.set->box->a)}, {"b", vec3(p.set->box->b)}, {"c", vec3(p.set->box->c)}};
    }
    m["particles"].push_back(entry);
  }
  const Box3 box = scene.caster_bounds();
  m["light_target"] = vec3(box.empty() ? scene.camera.target : box.center());
  m["radius"] = box.empty() ? 1.0f : 0.5f * length(box.hi - box.lo);
  if (!box.empty()) m["bounds"] = {{"lo", vec3(box.lo)}, {"hi", vec3(box.hi)}};  // where cuts and slices are placed
  m["transfer_function_presets"] = transfer_function_preset_names();  // names volumes.I.transfer_function takes
  m["histograms"] = nlohmann::json::array();
  m["transfer_functions"] = nlohmann::json::array();
  for (std::size_t i = 0; i < scene.volumes.size(); ++i) {
    const VolumeObject& v = scene.volumes[i];
    auto& h = histograms_[v.volume.get()];
    if (h.is_null()) {
      const VolumeHistogram hist = compute_histogram(*v.volume, kHistogramBins);
      h = {{"lo", hist.lo}, {"hi", hist.hi}, {"counts", hist.counts}};
      // the values' unit, for the page's legend and axis: Hounsfield units for a CT, none known otherwise
      if (is_hounsfield_ct(v.volume->type(), hist.lo, hist.hi)) h["unit"] = "HU";
    }
    nlohmann::json entry = h;
    entry["volume"] = i;
    m["histograms"].push_back(entry);
    if (!v.visible) continue;
    nlohmann::json points = nlohmann::json::array();
    for (const TransferPoint& p : v.transfer_function.points()) points.push_back({p.value, p.color.r, p.color.g, p.color.b, p.alpha});
    m["transfer_functions"].push_back({{"volume", i}, {"points", points}});
  }
  // forget the histograms of data no longer in the scene
  std::erase_if(histograms_, [&](const auto& e) {
    for (const auto& v : scene.volumes)
      if (v.volume.get() == e.first) return false;
    return true;
  });
  return m;
}

}  // namespace penumbra
