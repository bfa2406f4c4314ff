// The scene file's camera, lights and planes (docs/scene-file.md).
#include "penumbra/scene_io/scene_sections.h"

#include <cmath>

namespace penumbra::scene_sections {

Camera read_camera(const nlohmann::json& j, const Box3& bounds) {
  JsonReader r(j, "camera");
  Camera c;
  c.fov_deg = r.number("fov_deg", c.fov_deg, 1, 170);
  c.width = static_cast<int>(r.integer("width", c.width, 1, 16384));
  c.height = static_cast<int>(r.integer("height", c.height, 1, 16384));
  c.up = r.vec3("up", c.up);
  if (length(c.up) == 0) r.fail("up", "must not be the zero vector");
  // Without an eye, frame the scene: look at the bounds' centre from `direction`, far enough back that
  // the bounding sphere fills the view, as ParaView's "reset camera" does.
  const Vec3 centre = bounds.empty() ? Vec3{0, 0, 0} : bounds.center();
  c.target = r.vec3("target", centre);
  const Vec3 dir = normalize(r.vec3("direction", {1.0f, 0.55f, 1.3f}));
  if (length(dir) == 0) r.fail("direction", "must not be the zero vector");
  const float radius = bounds.empty() ? 1.0f : bounds.radius();
  // zoom > 1 moves the framed camera closer (the bounds' sphere is loose for elongated data)
  const float zoom = r.number("zoom", 1, 0.01f, 100);
  const float dist = r.number("distance", radius / std::sin(radians(c.fov_deg) * 0.5f) * 1.05f / zoom, 1e-6f);
  c.eye = r.vec3("eye", c.target + dir * dist);
  if (length(c.eye - c.target) == 0) r.fail("eye", "must differ from target");
  r.finish();
  return c;
}

Light read_light(const nlohmann::json& j, const std::string& path, const Box3& bounds) {
  JsonReader r(j, path);
  Light l;
  const std::string type = r.string("type", "directional");
  if (type == "directional") l.type = LightType::Directional;
  else if (type == "point") l.type = LightType::Point;
  else if (type == "spot") l.type = LightType::Spot;
  else r.fail("type", "unknown light type '" + type + "' (expected directional, point or spot)");
  l.color = r.color("color", l.color);
  l.intensity = r.number("intensity", l.intensity, 0, 1e6f);
  const Vec3 centre = bounds.empty() ? Vec3{0, 0, 0} : bounds.center();
  if (l.type == LightType::Directional) {
    l.direction = normalize(r.vec3("direction", {-0.4f, -1.0f, -0.3f}));
    if (length(l.direction) == 0) r.fail("direction", "must not be the zero vector");
  } else {
    if (!r.has("position")) r.fail("position", "missing (a " + type + " light needs a position)");
    l.position = r.vec3("position", {});
    if (l.type == LightType::Spot) {
      l.direction = normalize(r.vec3("direction", centre - l.position));
      if (length(l.direction) == 0) r.fail("direction", "must not be the zero vector");
      l.angle_deg = r.number("angle_deg", l.angle_deg, 0.1f, 89.0f);
      l.softness = r.number("softness", l.softness, 0, 1);
    }
  }
  r.finish();
  return l;
}

Plane read_plane(const nlohmann::json& j, const std::string& path) {
  JsonReader r(j, path);
  Plane p;
  p.point = r.vec3("point", p.point);
  p.normal = normalize(r.vec3("normal", p.normal));
  if (length(p.normal) == 0) r.fail("normal", "must not be the zero vector");
  p.color = r.color("color", p.color);
  p.size = r.number("size", p.size, 0);
  read_shadow_flags(r, p);
  r.finish();
  return p;
}

// clip_planes: each {"point", "normal"} removes the half-space the normal points into.
ClipPlanes read_clip_planes(const nlohmann::json& j, const std::string& path) {
  if (!j.is_array()) throw Error(path + ": expected an array of {\"point\": [x, y, z], \"normal\": [x, y, z]}");
  if (j.size() > ClipPlanes::kMaxPlanes)
    throw Error(path + ": " + std::to_string(j.size()) + " planes; at most " + std::to_string(ClipPlanes::kMaxPlanes) +
                " (enough to cut out a box)");
  std::vector<ClipPlane> planes;
  for (std::size_t i = 0; i < j.size(); ++i) {
    JsonReader r(j[i], path + "." + std::to_string(i));
    if (!r.has("point")) r.fail("point", "missing: a point on the plane");
    if (!r.has("normal")) r.fail("normal", "missing: the direction of the half-space the plane removes");
    ClipPlane c{r.vec3("point", {}), r.vec3("normal", {})};
    if (!(length(c.normal) > 0)) r.fail("normal", "must not be the zero vector");
    c.normal = normalize(c.normal);
    r.finish();
    planes.push_back(c);
  }
  return ClipPlanes(std::move(planes));
}

}  // namespace penumbra::scene_sections
