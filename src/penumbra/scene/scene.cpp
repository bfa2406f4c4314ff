#include "penumbra/scene/scene.h"

#include "penumbra/core/error.h"

namespace penumbra {

std::string to_string(LightType type) {
  switch (type) {
    case LightType::Directional: return "directional";
    case LightType::Point: return "point";
    case LightType::Spot: return "spot";
  }
  return "?";
}

std::string to_string(ObjectKind kind) {
  switch (kind) {
    case ObjectKind::Volume: return "volumes";
    case ObjectKind::Spheres: return "spheres";
    case ObjectKind::Isosurface: return "isosurfaces";
    case ObjectKind::Plane: return "planes";
  }
  return "?";
}

ObjectKind object_kind_from_string(const std::string& name) {
  for (int i = 0; i < kObjectKinds; ++i)
    if (to_string(static_cast<ObjectKind>(i)) == name) return static_cast<ObjectKind>(i);
  throw Error("unknown kind of object '" + name + "' (expected volumes, spheres, isosurfaces or planes)");
}

std::string to_string(IsosurfaceMethod method) {
  switch (method) {
    case IsosurfaceMethod::Points: return "points";
    case IsosurfaceMethod::Raycast: return "raycast";
    case IsosurfaceMethod::Mesh: return "mesh";
  }
  return "?";
}

IsosurfaceMethod isosurface_method_from_string(const std::string& name) {
  if (name == "points") return IsosurfaceMethod::Points;
  if (name == "raycast") return IsosurfaceMethod::Raycast;
  if (name == "mesh") return IsosurfaceMethod::Mesh;
  throw Error("unknown isosurface method '" + name + "' (expected points, raycast or mesh)");
}

std::string to_string(SphereRasterizer r) { return r == SphereRasterizer::Splat ? "splat" : "embree"; }

SphereRasterizer sphere_rasterizer_from_string(const std::string& s) {
  if (s == "splat") return SphereRasterizer::Splat;
  if (s == "embree") return SphereRasterizer::Embree;
  throw Error("unknown sphere renderer '" + s + "' (expected splat or embree)");
}

Box3 Plane::bounds() const {
  Box3 b;
  if (slice) return slice->volume->bounds();  // (the plane's part inside the box lies within it)
  if (size <= 0) return b;
  const Frame f = Frame::from_w(normal);
  for (int i = 0; i < 4; ++i)
    b.extend(point + f.u * ((i & 1) ? 0.5f * size : -0.5f * size) + f.v * ((i & 2) ? 0.5f * size : -0.5f * size));
  return b;
}

Box3 Scene::caster_bounds() const {
  Box3 b;
  for (const auto& v : volumes)
    if (v.visible) b.extend(v.volume->bounds());
  for (const auto& i : isosurfaces) b.extend(volumes[i.volume].volume->bounds());
  for (const auto& p : particles)
    if (p.visible) b.extend(p.topology_bounds.empty() ? p.set->bounds() : p.topology_bounds);
  // Planes join only when there is no volume: a light frustum fitted to the volumes already covers
  // every receiver the volumes can shadow (their shadow lies inside the frustum), and a large floor
  // would spread the shadow map's texels thin.
  if (b.empty())
    for (const auto& p : planes) b.extend(p.bounds());
  return b;
}

std::size_t Scene::frame_count() const {
  std::size_t n = 0;
  for (const auto& p : particles)
    if (p.frames > 0) n = n == 0 ? p.frames : std::min(n, p.frames);
  for (const auto& v : volumes)
    if (v.frames > 0) n = n == 0 ? v.frames : std::min(n, v.frames);
  return n;
}

const ClipPlanes& Scene::clip_planes_for(bool clip) const {
  static const ClipPlanes kNone;
  return clip ? clip_planes : kNone;
}

const VolumeObject* Scene::visible_volume() const {
  for (const auto& v : volumes)
    if (v.visible) return &v;
  return nullptr;
}

Box3 PyramidSource::bounds(const Volume& held) const {
  Box3 b = held.bounds();
  const Level& finest = levels.front();
  const Vec3 last{static_cast<float>(finest.dims[0] - 1), static_cast<float>(finest.dims[1] - 1), static_cast<float>(finest.dims[2] - 1)};
  b.extend(finest.origin);
  b.extend(finest.origin + finest.spacing * last);
  return b;
}

}  // namespace penumbra
