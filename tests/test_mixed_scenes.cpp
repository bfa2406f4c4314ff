// One scene of every kind (issue "One scene"): for every pair of caster kind and receiver kind, toggling
// the caster's casts_shadows changes the receiver, only by darkening it, and not at all when the
// receiver does not receive shadows; every technique on a mixed scene beats the unshadowed frame against
// ray_traced; CSSM's mean over seeds tints a shadow cast by a red slab on spheres red, as ray_traced
// does; two overlapping volumes render as one volume holding both; 1 and 2 threads give the same bytes.
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "penumbra/core/image_io.h"
#include "penumbra/accel/extinction_sat.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/particles/particle_ambient_occlusion.h"
#include "penumbra/geometry/sphere_bvh.h"
#include "penumbra/scene/camera.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "image_check.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;
using nlohmann::json;

namespace {

constexpr int kSize = 48;

// An .xyz file of carbon atoms at the given positions.
std::string write_xyz(const ScratchDir& dir, const std::string& name, const std::vector<Vec3>& atoms) {
  const std::string path = dir.file(name);
  std::ofstream out(path);
  out << atoms.size() << "\nmixed-scene test\n";
  for (const Vec3& a : atoms) out << "C " << a.x << " " << a.y << " " << a.z << "\n";
  return path;
}

// A procedural volume whose unit box is centred at `centre`.
json volume_at(const json& procedural, const Vec3& centre, const json& tf, bool visible = true) {
  json v = {{"procedural", procedural}, {"origin", {centre.x - 0.5, centre.y - 0.5, centre.z - 0.5}}, {"visible", visible}};
  if (visible) v["transfer_function"] = tf;
  return v;
}

// The scene objects of one kind, as a caster (above, y ≈ 0.6) or a receiver (below, y ≈ −0.4).
void add_object(json& j, ObjectKind kind, bool caster, const ScratchDir& dir) {
  const float y = caster ? 0.6f : -0.4f;
  switch (kind) {
    case ObjectKind::Volume:
      j["volumes"].push_back(caster ? volume_at({{"name", "sphere"}, {"size", 24}, {"radius", 0.3}}, {0, y, 0}, step_tf(0.9, 0.9, 0.2, 0.2))
                                    : volume_at({{"name", "slab"}, {"size", 24}, {"thickness", 0.3}}, {0, y, 0}, step_tf(0.3, 0.8, 0.8, 0.8)));
      break;
    case ObjectKind::Spheres: {
      std::vector<Vec3> atoms;
      if (caster) atoms = {{0, y, 0}};
      else
        for (int i = -3; i <= 3; ++i)
          for (int k = -3; k <= 3; ++k) atoms.push_back({0.13f * static_cast<float>(i), y, 0.13f * static_cast<float>(k)});
      j["particles"].push_back({{"file", write_xyz(dir, caster ? "caster.xyz" : "receiver.xyz", atoms)}, {"radius", caster ? 0.3 : 0.06}});
      break;
    }
    case ObjectKind::Isosurface: {
      const std::size_t index = j["volumes"].size();
      j["volumes"].push_back(caster ? volume_at({{"name", "sphere"}, {"size", 24}, {"radius", 0.3}}, {0, y, 0}, nullptr, false)
                                    : volume_at({{"name", "slab"}, {"size", 24}, {"thickness", 0.3}}, {0, y, 0}, nullptr, false));
      j["isosurfaces"].push_back({{"volume", index}, {"value", 0.5}, {"method", "raycast"}});
      break;
    }
    case ObjectKind::Plane:
      j["planes"].push_back({{"point", {0.0, y, 0.0}}, {"normal", {0.0, 1.0, 0.0}}, {"size", caster ? 0.6 : 2.0}});
      break;
  }
}

// The section of the scene file that holds objects of a kind, and the index of the last one.
std::string last_object(const json& j, ObjectKind kind) {
  switch (kind) {
    case ObjectKind::Volume: return "volumes." + std::to_string(j["volumes"].size() - 1);
    case ObjectKind::Spheres: return "particles." + std::to_string(j["particles"].size() - 1);
    case ObjectKind::Isosurface: return "isosurfaces." + std::to_string(j["isosurfaces"].size() - 1);
    case ObjectKind::Plane: return "planes." + std::to_string(j["planes"].size() - 1);
  }
  return "";
}

json pair_scene(ObjectKind caster, ObjectKind receiver, const ScratchDir& dir, std::string& caster_path,
                std::string& receiver_path) {
  json j;
  j["volumes"] = json::array();
  j["particles"] = json::array();
  j["isosurfaces"] = json::array();
  j["planes"] = json::array();
  add_object(j, receiver, false, dir);
  receiver_path = last_object(j, receiver);
  add_object(j, caster, true, dir);
  caster_path = last_object(j, caster);
  for (const char* section : {"volumes", "particles", "isosurfaces", "planes"})
    if (j[section].empty()) j.erase(section);
  j["lights"] = json::array({{{"type", "directional"}, {"direction", {0.05, -1.0, 0.03}}}});
  j["camera"] = {{"width", kSize}, {"height", kSize}, {"eye", {1.6, 1.2, 2.2}}, {"target", {0.0, -0.2, 0.0}}, {"fov_deg", 40}};
  j["shadows"] = {{"technique", "ray_traced"}};
  return j;
}

Image render_json(const json& j) { return Renderer(build_scene(j, "")).render().image; }

double psnr(const Image& a, const Image& b) { return compare_images(a, b).psnr; }

json with_flag(json j, const std::string& object, const std::string& flag, bool value) {
  apply_override(j, object + "." + flag, value ? "true" : "false");
  return j;
}

const ObjectKind kKinds[] = {ObjectKind::Volume, ObjectKind::Spheres, ObjectKind::Isosurface, ObjectKind::Plane};

// A pair scene rendered with the caster casting and not casting.
struct PairFrames {
  json scene;
  std::string caster, receiver;  // their paths in the scene file ("volumes.1", ...)
  Image lit, shadowed;
};

PairFrames render_pair(ObjectKind caster, ObjectKind receiver, const ScratchDir& dir) {
  PairFrames f;
  f.scene = pair_scene(caster, receiver, dir, f.caster, f.receiver);
  f.lit = render_json(with_flag(f.scene, f.caster, "casts_shadows", false));
  f.shadowed = render_json(f.scene);
  return f;
}

}  // namespace

// For every (caster kind, receiver kind): the caster's shadow darkens the receiver where it falls and
// changes nothing else; with receives_shadows off the receiver does not change at all.
TEST(MixedScene, EveryCasterKindShadowsEveryReceiverKind) {
  for (ObjectKind caster : kKinds)
    for (ObjectKind receiver : kKinds) {
      SCOPED_TRACE(to_string(caster) + " on " + to_string(receiver));
      ScratchDir dir;
      const PairFrames f = render_pair(caster, receiver, dir);
      const json& base = f.scene;
      const std::string &cp = f.caster, &rp = f.receiver;
      const Image &lit = f.lit, &shadowed = f.shadowed;
      FailureImages keep;
      keep.add(to_string(caster) + "_on_" + to_string(receiver), shadowed, lit);
      std::size_t darker = 0, brighter = 0;
      for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
          const Rgb a = lit.at(x, y), b = shadowed.at(x, y);
          const float da = a.r + a.g + a.b, db = b.r + b.g + b.b;
          darker += db < da - 1e-4f;
          brighter += db > da + 1e-4f;
        }
      EXPECT_GT(darker, 10u) << "the caster's shadow does not show on the receiver";
      EXPECT_EQ(brighter, 0u) << "a shadow made something brighter";
      // the receiver opted out: toggling the caster changes nothing
      // (the caster too, so that its own self-shadowing plays no part)
      const json deaf = with_flag(with_flag(base, rp, "receives_shadows", false), cp, "receives_shadows", false);
      EXPECT_EQ(render_json(deaf).pixels(), render_json(with_flag(deaf, cp, "casts_shadows", false)).pixels());
    }
}

namespace {

// Where exact shadow rays say a caster of the pair scenes shadows a receiver, from the analytic shapes
// (independent of the renderer): per pixel, Shadowed when the receiver point the pixel shows lies in
// the caster's shadow by a margin, Lit when it lies outside by a margin, Unknown on the margin, where
// the pixel shows the caster, or where the receiver faces away from the light.
enum class Expect { Shadowed, Lit, Unknown };

constexpr float kMargin = 0.06f;  // about one and a half voxels of the 24³ procedural volumes
const Vec3 kToLight = normalize(Vec3{-0.05f, 1.0f, -0.03f});

// How far inside (negative) or outside (positive) the caster's shadow the ray p + t·kToLight passes.
float shadow_clearance(ObjectKind caster, const Vec3& p) {
  const Vec3 c{0, 0.6f, 0};
  if (caster == ObjectKind::Plane) {  // the square of side 0.6 at y = 0.6
    const float t = (0.6f - p.y) / kToLight.y;
    if (t <= 0) return 1;
    const Vec3 h = p + kToLight * t;
    return std::max(std::abs(h.x), std::abs(h.z)) - 0.3f;
  }
  const Vec3 oc = c - p;  // a ball of radius 0.3
  const float t = dot(oc, kToLight);
  if (t <= 0) return 1;
  return length(oc - kToLight * t) - 0.3f;
}

// Whether the primary ray reaches the caster's shape (grown by the margin) before distance tmax.
bool shows_caster(ObjectKind caster, const Ray& r, float tmax) {
  if (caster == ObjectKind::Plane) {
    if (std::abs(r.direction.y) < 1e-6f) return false;
    const float t = (0.6f - r.origin.y) / r.direction.y;
    const Vec3 h = r.at(t);
    return t > 0 && t < tmax && std::max(std::abs(h.x), std::abs(h.z)) < 0.3f + kMargin;
  }
  const Sphere ball{{0, 0.6f, 0}, 0.3f + kMargin};
  return intersect_sphere(r, ball, 0, tmax) < kInfinity;
}

Expect classify(float clearance) {
  if (clearance < -kMargin) return Expect::Shadowed;
  if (clearance > kMargin) return Expect::Lit;
  return Expect::Unknown;
}

// The receiver point (and normal) the primary ray meets first, for the receivers of pair_scene; false
// where it meets none. Volume receivers: the ray's entry into the slab.
bool receiver_hit(ObjectKind receiver, const Ray& r, Vec3& p, Vec3& n, float& t) {
  t = kInfinity;
  auto slab_top = [&](float y, float half) {  // the plane y, within |x|, |z| <= half
    if (std::abs(r.direction.y) < 1e-6f) return false;
    const float tp = (y - r.origin.y) / r.direction.y;
    const Vec3 h = r.at(tp);
    if (!(tp > 0) || std::abs(h.x) > half || std::abs(h.z) > half) return false;
    t = tp;
    p = h;
    n = {0, 1, 0};
    return true;
  };
  switch (receiver) {
    case ObjectKind::Plane: return slab_top(-0.4f, 1.0f);
    case ObjectKind::Isosurface:
    case ObjectKind::Volume: return slab_top(-0.25f, 0.5f - kMargin);
    case ObjectKind::Spheres:
      for (int i = -3; i <= 3; ++i)
        for (int k = -3; k <= 3; ++k) {
          const Sphere s{{0.13f * static_cast<float>(i), -0.4f, 0.13f * static_cast<float>(k)}, 0.06f};
          const float ts = intersect_sphere(r, s, 0, t);
          if (ts < t) {
            t = ts;
            p = r.at(ts);
            n = normalize(p - s.center);
          }
        }
      return t < kInfinity;
  }
  return false;
}

}  // namespace

// The pixel masks: toggling the caster changes exactly the pixels whose receiver point exact shadow
// rays put in its shadow (by a margin of a voxel and a half), and none of those they put outside.
TEST(MixedScene, ShadowsFallExactlyWhereShadowRaysSay) {
  for (ObjectKind caster : kKinds)
    for (ObjectKind receiver : kKinds) {
      SCOPED_TRACE(to_string(caster) + " on " + to_string(receiver));
      ScratchDir dir;
      const PairFrames f = render_pair(caster, receiver, dir);
      const Scene scene = build_scene(f.scene, "");
      const Image &lit = f.lit, &shadowed = f.shadowed;
      const PrimaryRays rays(scene.camera);
      std::size_t expected_shadowed = 0, missed = 0, extra = 0;
      Image mask(kSize, kSize, Rgb(0.0f));  // red: missed, blue: extra, grey: agreed shadow
      for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
          const Ray ray = rays.ray(x, y);
          Vec3 p, n;
          float t;
          Expect e = Expect::Lit;  // background: nothing to shadow
          if (receiver == ObjectKind::Volume) {
            // every sample along the ray inside the slab may be shadowed: lit only if all are clear,
            // shadowed if the entry (where the slab's opacity shows) is
            const Box3 slab{{-0.5f, -0.55f, -0.5f}, {0.5f, -0.25f, 0.5f}};
            float t0, t1;
            t = kInfinity;
            if (slab.clip(ray, t0, t1)) {
              t = t0;
              float nearest = kInfinity;
              for (int k = 0; k <= 32; ++k)
                nearest = std::min(nearest, shadow_clearance(caster, ray.at(t0 + (t1 - t0) * static_cast<float>(k) / 32.0f)));
              const float entry = shadow_clearance(caster, ray.at(t0 + 0.02f));
              e = nearest > kMargin ? Expect::Lit : entry < -kMargin ? Expect::Shadowed : Expect::Unknown;
            }
          } else if (receiver_hit(receiver, ray, p, n, t)) {
            e = classify(shadow_clearance(caster, p));
            if (dot(n, kToLight) <= 0.05f) e = Expect::Unknown;
          }
          if (shows_caster(caster, ray, t)) e = Expect::Unknown;
          const Rgb a = lit.at(x, y), b = shadowed.at(x, y);
          const bool changed = std::abs(a.r - b.r) + std::abs(a.g - b.g) + std::abs(a.b - b.b) > 1e-6f;
          if (e == Expect::Shadowed) {
            ++expected_shadowed;
            if (!changed) {
              ++missed;
              mask.at(x, y) = Rgb(1, 0, 0);
            } else {
              mask.at(x, y) = Rgb(0.5f);
            }
          } else if (e == Expect::Lit && changed) {
            ++extra;
            mask.at(x, y) = Rgb(0, 0, 1);
          }
        }
      FailureImages keep;
      keep.add("mask_" + to_string(caster) + "_on_" + to_string(receiver), mask, Image{});
      keep.add("frames_" + to_string(caster) + "_on_" + to_string(receiver), shadowed, lit);
      EXPECT_GT(expected_shadowed, 20u) << "the test scene has no shadow to check";
      EXPECT_EQ(missed, 0u) << "pixels in the caster's shadow that did not change";
      EXPECT_EQ(extra, 0u) << "pixels outside the caster's shadow that changed";
    }
}

// Every shadow technique that takes these kinds, on a scene of all four, against ray_traced: each
// beats the unshadowed frame by a clear margin.
TEST(MixedScene, EveryTechniqueBeatsTheUnshadowedFrame) {
  ScratchDir dir;
  json j;
  j["volumes"] = json::array();
  j["particles"] = json::array();
  j["isosurfaces"] = json::array();
  j["planes"] = json::array();
  add_object(j, ObjectKind::Plane, false, dir);
  add_object(j, ObjectKind::Spheres, true, dir);
  add_object(j, ObjectKind::Volume, false, dir);
  j["isosurfaces"] = json::array();
  j["volumes"].push_back(volume_at({{"name", "sphere"}, {"size", 24}, {"radius", 0.2}}, {0.45f, 0.2f, 0.3f}, nullptr, false));
  j["isosurfaces"].push_back({{"volume", 1}, {"value", 0.5}, {"method", "raycast"}});
  j["lights"] = json::array({{{"type", "directional"}, {"direction", {-0.3, -1.0, -0.2}}}});
  j["camera"] = {{"width", 64}, {"height", 64}, {"eye", {1.6, 1.2, 2.2}}, {"target", {0.0, -0.2, 0.0}}, {"fov_deg", 40}};
  j["shadows"] = {{"technique", "ray_traced"}, {"resolution", 256}};
  const Image reference = render_json(j);
  json none = j;
  none["shadows"]["technique"] = "none";
  const double floor = psnr(render_json(none), reference);
  for (const char* t : {"shadow_map", "deep_shadow_map", "cssm"}) {
    SCOPED_TRACE(t);
    json tj = j;
    tj["shadows"]["technique"] = t;
    const Image img = render_json(tj);
    FailureImages keep;
    keep.add(t, img, reference);
    EXPECT_GT(psnr(img, reference), floor + 5) << "none: " << floor;
  }
  // spheres by ISSM, the rest by their defaults
  json issm = j;
  issm["shadows"] = {{"technique", "issm"}, {"resolution", 256}};
  EXPECT_GT(psnr(render_json(issm), reference), floor + 5);
}

// A translucent red slab over white spheres: the shadow on the spheres is red (green and blue are
// absorbed), in ray_traced and in CSSM's mean over seeds.
TEST(MixedScene, ARedSlabCastsARedShadowOnSpheres) {
  ScratchDir dir;
  json j;
  j["volumes"] = json::array({volume_at({{"name", "slab"}, {"size", 24}, {"thickness", 0.2}}, {0, 0.6f, 0}, step_tf(0.3, 1.0, 0.0, 0.0))});
  std::vector<Vec3> atoms;
  for (int i = -3; i <= 3; ++i)
    for (int k = -3; k <= 3; ++k) atoms.push_back({0.13f * static_cast<float>(i), -0.4f, 0.13f * static_cast<float>(k)});
  j["particles"] = json::array({{{"file", write_xyz(dir, "row.xyz", atoms)}, {"radius", 0.06}, {"color_by", "uniform"}, {"color", {1.0, 1.0, 1.0}}}});
  j["lights"] = json::array({{{"type", "directional"}, {"direction", {0.0, -1.0, 0.0}}}});
  j["camera"] = {{"width", kSize}, {"height", kSize}, {"eye", {0.0, 0.3, 1.6}}, {"target", {0.0, -0.4, 0.0}}, {"fov_deg", 40}};
  j["shading"] = {{"ambient", 0.0}, {"specular", 0.0}};
  j["background"] = {0.0, 0.0, 0.0};
  j["shadows"] = {{"technique", "ray_traced"}, {"resolution", 128}};
  const Image exact = render_json(j);
  double r = 0, g = 0, b = 0;
  for (const Rgb& c : exact.pixels()) {
    r += c.r;
    g += c.g;
    b += c.b;
  }
  ASSERT_GT(r, 1.0);
  EXPECT_GT(r, 3 * g) << "the shadow through a red slab is not red";
  EXPECT_GT(r, 3 * b);
  // CSSM: the mean over seeds approaches the exact colour (per channel, the image sums within 10 %)
  const int seeds = 8;
  double cr = 0, cg = 0;
  for (int s = 1; s <= seeds; ++s) {
    json c = j;
    c["shadows"] = {{"technique", "cssm"}, {"resolution", 128}, {"seed", s}};
    const Image im = render_json(c);
    for (const Rgb& p : im.pixels()) {
      ASSERT_TRUE(p.max_component() >= 0 && p.max_component() < 10) << "seed " << s << ": " << p.r << " " << p.g << " " << p.b;
      cr += p.r / seeds;
      cg += p.g / seeds;
    }
  }
  EXPECT_NEAR(cr, r, 0.1 * r);
  EXPECT_NEAR(cg, g, 0.1 * r);
}

// Two volumes on the same grid, with supports more than two voxels apart, render exactly as one volume
// holding both (the same positions sampled, each volume's sample where it is not zero).
TEST(MixedScene, TwoOverlappingVolumesRenderAsOneHoldingBoth) {
  const int n = 24;
  auto make = [&](bool left, bool right) {
    auto v = std::make_shared<Volume>(ScalarType::Float32, std::array<int, 3>{n, n, n}, Vec3{1.0f / (n - 1), 1.0f / (n - 1), 1.0f / (n - 1)},
                                      Vec3{-0.5f, -0.5f, -0.5f});
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const bool in_left = x >= 3 && x <= 9 && y >= 5 && y <= 18 && z >= 5 && z <= 18;
          const bool in_right = x >= 14 && x <= 20 && y >= 3 && y <= 12 && z >= 6 && z <= 17;
          v->set_value(v->index(x, y, z), (left && in_left) || (right && in_right) ? 1.0f : 0.0f);
        }
    v->recompute_range();
    return v;
  };
  const json tf = step_tf(0.4, 0.9, 0.5, 0.3);
  auto scene_of = [&](std::vector<std::shared_ptr<Volume>> volumes) {
    json j = volume_scene({{"name", "sphere"}, {"size", 8}}, tf);
    j["camera"] = {{"width", kSize}, {"height", kSize}, {"direction", {0.3, 0.4, 1.0}}};
    j["shadows"] = {{"technique", "ray_traced"}};
    Scene s = build_scene(j, "");
    VolumeObject o = s.volumes.front();
    s.volumes.clear();
    for (auto& v : volumes) {
      o.volume = v;
      s.volumes.push_back(o);
    }
    return s;
  };
  const Image merged = Renderer(scene_of({make(true, true)})).render().image;
  const Image two = Renderer(scene_of({make(true, false), make(false, true)})).render().image;
  FailureImages keep;
  keep.add("two_volumes", two, merged);
  double max_diff = 0;
  for (std::size_t i = 0; i < merged.pixels().size(); ++i) {
    const Rgb d = merged.pixels()[i] - two.pixels()[i];
    max_diff = std::max({max_diff, double(std::abs(d.r)), double(std::abs(d.g)), double(std::abs(d.b))});
  }
  EXPECT_LT(max_diff, 1e-5);
  // and each volume alone differs (the test sees both)
  EXPECT_NE(Renderer(scene_of({make(true, false)})).render().image.pixels(), merged.pixels());
}

// Twelve overlapping copies of one volume, each of opacity a = 1 − (1 − A)^(1/12), render as that volume
// of opacity A, exactly: every copy's sample counts at every lattice position (the eye ray caster once
// kept eight and dropped the rest, while the light march kept all). The shadows are exact (ray_traced)
// through a black shadow transfer function, whose pass probabilities 1 − a multiply to 1 − A. The
// transfer functions give every value the same opacity (a cube of translucent matter).
TEST(MixedScene, TwelveOverlappingVolumesRenderAsOneOfTheirCombinedOpacity) {
  constexpr int kCopies = 12;
  const double opacity = 0.6;
  auto scene_of = [&](int copies) {
    const double a = 1 - std::pow(1 - opacity, 1.0 / copies);
    // one opacity for every value: a ramp (a step between two table entries) would not compose exactly
    auto flat_tf = [&](double r, double g, double b) { return json{{"points", {{0.0, r, g, b, a}, {1.0, r, g, b, a}}}}; };
    json j = volume_scene({{"name", "sphere"}, {"size", 16}}, flat_tf(0.9, 0.5, 0.3));
    j["volumes"][0]["shadow_transfer_function"] = flat_tf(0, 0, 0);
    j["planes"] = json::array({{{"point", {0, -0.6, 0}}, {"normal", {0, 1, 0}}, {"size", 3}}});
    j["camera"] = {{"width", kSize}, {"height", kSize}, {"eye", {0.4, 1.2, 2.0}}, {"target", {0, -0.2, 0}}};
    j["lights"][0]["direction"] = {0.3, -1.0, 0.2};
    j["shadows"] = {{"technique", "ray_traced"}};
    const json one = j["volumes"][0];
    j["volumes"] = json::array();
    for (int i = 0; i < copies; ++i) j["volumes"].push_back(one);
    return build_scene(j, "");
  };
  const Image reference = Renderer(scene_of(1)).render().image;
  const Image twelve = Renderer(scene_of(kCopies)).render().image;
  FailureImages keep;
  keep.add("twelve_volumes", twelve, reference);
  const ImageDifference d = compare_images(twelve, reference);
  EXPECT_LT(d.max_abs, 1e-5) << "PSNR " << d.psnr << " dB";
  // the volume shows (a dropped copy would be seen)
  EXPECT_GT(compare_images(reference, Image(kSize, kSize, Rgb(0.1f, 0.1f, 0.12f))).max_abs, 0.2);
}

// 1 and 2 threads give byte-identical frames of a mixed scene with a stochastic technique.
TEST(MixedScene, OneAndTwoThreadsAreByteIdentical) {
  ScratchDir dir;
  std::string cp, rp;
  json j = pair_scene(ObjectKind::Spheres, ObjectKind::Volume, dir, cp, rp);
  add_object(j, ObjectKind::Plane, false, dir);
  j["shadows"] = {{"technique", "cssm"}, {"resolution", 128}};
  Image one, two;
  {
    ThreadLimit l(1);
    one = render_json(j);
  }
  {
    ThreadLimit l(2);
    two = render_json(j);
  }
  EXPECT_EQ(one.pixels(), two.pixels());
}

// Ambient occlusion across kinds, approximately: spheres enter the extinction SAT (sat_shells,
// sampled_ao, sat_cone) with τ_s = kOpaqueDepth / (2r) over the cells they fill, and the volumes'
// opacity enters particle_ao's density grid.
TEST(MixedScene, SpheresEnterTheExtinctionSat) {
  const Volume empty(ScalarType::Float32, {33, 33, 33}, {1.0f / 32, 1.0f / 32, 1.0f / 32}, {-0.5f, -0.5f, -0.5f});
  TransferFunction none;  // nothing in the volume absorbs
  ParticleSet set;
  const float r = 0.2f;
  set.spheres = {{{0.05f, -0.1f, 0.0f}, r}};
  set.colors = {pack_rgba8(Rgb(1.0f))};
  const ExtinctionSat without(empty, none, Compositing::Alpha, 1.0f / 32, 64, false);
  const ExtinctionSat with(empty, none, Compositing::Alpha, 1.0f / 32, 64, false, &set);
  const CellBox all{{0, 0, 0}, with.dims()};
  EXPECT_EQ(without.sum(all), 0.0);
  // Σ τ · V_cell = τ_s · (4/3)πr³, to the ramp's discretisation (a few per cent at 12.8 cells a radius)
  const double expected = kOpaqueDepth / (2 * r) * 4.0 / 3.0 * 3.14159265358979 * r * r * r;
  EXPECT_NEAR(with.sum(all) * with.cell_volume(), expected, 0.03 * expected);
  // and it sits where the sphere is: nothing in the upper half of the box
  const int mid = static_cast<int>(with.to_cell({0, -0.1f + r, 0}).y) + 2;
  EXPECT_EQ(with.sum(CellBox{{0, mid, 0}, with.dims()}), 0.0);
}

TEST(MixedScene, ParticleAoSeesTheVolumes) {
  MediumHolder slab(volume_scene({{"name", "slab"}, {"size", 24}, {"thickness", 0.2}}, step_tf(0.9)));
  AmbientSettings s;
  s.params.set("max_distance", 0.5f);
  ParticleAmbientOcclusion ao(s.params);
  ao.build(*slab.medium);
  // a point just above the slab, facing it, is occluded; one far from it is not
  SurfacePoint near, far;
  near.position = {0, 0.15f, 0};
  near.normal = {0, -1, 0};
  far.position = {0, 0.15f, 0};
  far.normal = {0, 1, 0};
  const std::vector<SurfacePoint> pts{near, far};
  std::vector<Rgb> out(2);
  ao.ambient(std::span<const SurfacePoint>(pts), std::span<Rgb>(out));
  EXPECT_LT(out[0].r, 0.5f) << "facing the slab";
  EXPECT_GT(out[1].r, out[0].r + 0.3f) << "facing away from it";
  // the same slab fully transparent occludes nothing
  MediumHolder clear(volume_scene({{"name", "slab"}, {"size", 24}, {"thickness", 0.2}}, step_tf(0.0)));
  ParticleAmbientOcclusion none(s.params);
  none.build(*clear.medium);
  none.ambient(std::span<const SurfacePoint>(pts), std::span<Rgb>(out));
  EXPECT_EQ(out[0].r, 1.0f);
  EXPECT_EQ(out[1].r, 1.0f);
}

// Volume samples read the ambient factor from a lattice on the base level's cell corners, filled as
// samples need it and kept across frames (it does not depend on the camera). Interpolated, it stays
// within a few hundredths of the uncached value, and it is the same whichever order (or thread) fills
// the corners.
TEST(MixedScene, ParticleAoOfVolumeSamplesIsCachedOnALatticeIndependentOfOrder) {
  MediumHolder slab(volume_scene({{"name", "slab"}, {"size", 24}, {"thickness", 0.2}}, step_tf(0.6)));
  AmbientSettings s;
  s.params.set("max_distance", 0.5f);
  const RandomStream rng(7, 0);
  std::vector<Vec3> points(400);
  for (std::size_t i = 0; i < points.size(); ++i) points[i] = {rng(3 * i) - 0.5f, rng(3 * i + 1) * 0.8f - 0.4f, rng(3 * i + 2) - 0.5f};
  ParticleAmbientOcclusion forward(s.params), backward(s.params);
  forward.build(*slab.medium);
  backward.build(*slab.medium);
  std::vector<Rgb> a(points.size()), b(points.size());
  forward.ambient(std::span<const Vec3>(points), std::span<Rgb>(a));
  std::vector<Vec3> reversed(points.rbegin(), points.rend());
  std::vector<Rgb> rb(points.size());
  parallel_for(reversed.size(), [&](std::size_t i0, std::size_t i1) {
    backward.ambient(std::span<const Vec3>(reversed).subspan(i0, i1 - i0), std::span<Rgb>(rb).subspan(i0, i1 - i0));
  });
  double worst = 0, sum = 0;
  int occluded = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(a[i].r, rb[points.size() - 1 - i].r) << "point " << i;
    const float direct = forward.volume_point_ambient(points[i]);
    worst = std::max(worst, static_cast<double>(std::abs(a[i].r - direct)));
    sum += std::abs(a[i].r - direct);
    occluded += direct < 0.9f;
  }
  EXPECT_GT(occluded, 40) << "the slab must occlude some of the points for the comparison to mean something";
  EXPECT_LT(worst, 0.06) << "interpolation error of the lattice";
  EXPECT_LT(sum / static_cast<double>(points.size()), 0.01);
  // a second query of the same points (the next frame) reads the filled corners: the same values
  std::vector<Rgb> again(points.size());
  forward.ambient(std::span<const Vec3>(points), std::span<Rgb>(again));
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(again[i].r, a[i].r);
}
