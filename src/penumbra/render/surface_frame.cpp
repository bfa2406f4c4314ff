#include "penumbra/render/surface_frame.h"

#include <algorithm>
#include <array>

#include "penumbra/core/cancel.h"
#include "penumbra/core/parallel.h"
#include "penumbra/geometry/cut_sphere.h"
#include "penumbra/render/surface_shading.h"

namespace penumbra {
namespace {

constexpr std::size_t kPointBatch = 64;  // points whose shadow and ambient queries are issued together
constexpr std::uint32_t kNoPoint = 0xffffffffu;

// The point where `ray` meets plane `index` of the scene at distance t, with its colour and flag, as
// both the opaque and the translucent layer list it.
void plane_point(const Scene& scene, std::uint32_t index, const Ray& ray, float t, SurfacePoint& sp, Rgb& albedo, bool& receives) {
  const Plane& plane = scene.planes[index];
  sp.position = ray.at(t);
  sp.normal = plane.facing_normal(ray.direction);
  sp.kind = ObjectKind::Plane;
  sp.object = index;
  albedo = plane.color_at(sp.position);
  receives = plane.receives_shadows;
}

}  // namespace

void visible_surfaces(const SurfaceInputs& in, VisibleSurfaces& vs) {
  const Camera& cam = *in.camera;
  const Scene& scene = *in.scene;
  const int w = cam.width, h = cam.height;
  const auto pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  // per pixel the nearest isosurface point (isosurface, point)
  struct Nearest {
    std::uint32_t surface = kNoPoint, point = kNoPoint;
  };
  std::vector<Nearest> iso_at;
  if (!in.isosurface_points.empty()) {
    iso_at.resize(pixels);
    for (std::size_t s = 0; s < in.isosurface_points.size(); ++s) {
      const IsoPoints& pts = in.isosurface_points[s];
      for (std::size_t i = 0; i < pts.size(); ++i) {
        Nearest& n = iso_at[pts[i].pixel];
        if (n.point == kNoPoint || pts[i].distance < in.isosurface_points[n.surface][n.point].distance)
          n = {static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(i)};
      }
    }
  }
  // Pass 1: each pixel's nearest surface — its distance and what it is (plane index, isosurface or
  // sphere) — and the number of surface pixels per row. Pass 2 lists them in pixel order at each row's
  // offset, so the list is the same for any thread count; the buffers keep their capacity across frames.
  enum : std::uint32_t { kPlane = 0u << 30, kIso = 1u << 30, kSphere = 2u << 30, kNothing = 3u << 30, kKind = 3u << 30 };
  vs.distance.assign(pixels, kInfinity);
  std::vector<std::uint32_t>& what = vs.what;
  what.assign(pixels, kNothing);
  std::vector<std::size_t> row_start(static_cast<std::size_t>(h) + 1, 0);
  const PrimaryRays rays(cam);
  parallel_for(static_cast<std::size_t>(h), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y) {
      std::size_t count = 0;
      for (int x = 0; x < w; ++x) {
        const std::size_t i = y * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
        const bool sphere = in.hits && in.hits->id[i] != kNoSphere;
        const Nearest iso = iso_at.empty() ? Nearest{} : iso_at[i];
        if (!sphere && iso.point == kNoPoint && scene.planes.empty()) continue;  // background
        float t = sphere ? in.hits->t[i] : kInfinity;
        std::uint32_t kind = sphere ? kSphere : kNothing;
        if (iso.point != kNoPoint && in.isosurface_points[iso.surface][iso.point].distance < t) {
          t = in.isosurface_points[iso.surface][iso.point].distance;
          kind = kIso;
        }
        if (!scene.planes.empty()) {
          const Plane* plane = nearest_plane(scene.planes, rays.ray(x, static_cast<int>(y)), t);
          if (plane) kind = kPlane | static_cast<std::uint32_t>(plane - scene.planes.data());
        }
        if (kind == kNothing) continue;
        vs.distance[i] = t;
        what[i] = kind;
        ++count;
      }
      row_start[y + 1] = count;
    }
  });
  for (std::size_t y = 0; y < static_cast<std::size_t>(h); ++y) row_start[y + 1] += row_start[y];
  const std::size_t n = row_start.back();
  vs.points.resize(n);
  vs.pixel.resize(n);
  vs.albedo.resize(n);
  vs.receives.resize(n);
  parallel_for(static_cast<std::size_t>(h), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y) {
      std::size_t k = row_start[y];
      for (int x = 0; x < w; ++x) {
        const std::size_t i = y * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
        if (what[i] == kNothing) continue;
        const float t = vs.distance[i];
        SurfacePoint sp;
        Rgb albedo;
        bool receives = true;
        switch (what[i] & kKind) {
          case kPlane:
            plane_point(scene, what[i] & ~kKind, rays.ray(x, static_cast<int>(y)), t, sp, albedo, receives);
            break;
          case kIso: {
            const Nearest iso = iso_at[i];
            const IsoPoint& p = in.isosurface_points[iso.surface][iso.point];
            sp.position = p.position;
            sp.normal = p.normal;
            sp.kind = ObjectKind::Isosurface;
            sp.object = iso.surface;
            sp.error = p.error;
            const IsosurfaceObject& o = scene.isosurfaces[iso.surface];
            albedo = o.color;
            receives = o.receives_shadows;
            break;
          }
          default: {  // a sphere
            const std::uint32_t id = in.hits->id[i];
            const Sphere& s = in.particles->spheres[id];
            const Vec3 pos = rays.ray(x, static_cast<int>(y)).at(t);
            sp.normal = particle_normal(*in.particles, id, pos);  // a cut sphere's cap: its plane's normal
            // on the surface to the last bit that matters (a cap point stays where the ray met it)
            sp.position = in.particles->clip_of(id) == kSphereWhole ? s.center + sp.normal * s.radius : pos;
            sp.kind = ObjectKind::Spheres;
            sp.self = id;
            const auto segment = std::upper_bound(in.particle_offsets.begin(), in.particle_offsets.end(), id) - in.particle_offsets.begin() - 1;
            sp.object = in.particle_objects[static_cast<std::size_t>(segment)];
            albedo = unpack_rgb8(in.particles->colors[id]);
            receives = scene.particles[sp.object].receives_shadows;
          }
        }
        vs.points[k] = sp;
        vs.pixel[k] = static_cast<std::uint32_t>(i);
        vs.albedo[k] = albedo;
        vs.receives[k] = receives ? 1 : 0;
        ++k;
      }
    }
  });
}

bool has_translucent_planes(const Scene& scene) {
  return std::any_of(scene.planes.begin(), scene.planes.end(), [](const Plane& p) { return p.opacity < 1; });
}

void translucent_surfaces(const Scene& scene, const Camera& cam, const std::vector<float>& opaque_distance, VisibleSurfaces& vs,
                          std::vector<float>& opacity) {
  const int w = cam.width, h = cam.height;
  const auto pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  vs.points.clear();
  vs.pixel.clear();
  vs.albedo.clear();
  vs.receives.clear();
  vs.distance.clear();
  vs.what.clear();
  opacity.clear();
  if (!has_translucent_planes(scene)) return;  // no per-pixel buffers: nothing is read of them
  vs.distance.assign(pixels, kInfinity);
  vs.what.assign(pixels, 0);
  opacity.assign(pixels, 0.0f);
  const PrimaryRays rays(cam);
  std::vector<std::size_t> row_start(static_cast<std::size_t>(h) + 1, 0);
  parallel_for(static_cast<std::size_t>(h), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = y * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
        float t = opaque_distance[i];
        const Plane* plane = nearest_plane(scene.planes, rays.ray(x, static_cast<int>(y)), t, true);
        if (!plane) continue;
        vs.distance[i] = t;
        vs.what[i] = static_cast<std::uint32_t>(plane - scene.planes.data());
        opacity[i] = plane->opacity;
        ++row_start[y + 1];
      }
  });
  for (std::size_t y = 0; y < static_cast<std::size_t>(h); ++y) row_start[y + 1] += row_start[y];
  const std::size_t n = row_start.back();
  vs.points.resize(n);
  vs.pixel.resize(n);
  vs.albedo.resize(n);
  vs.receives.resize(n);
  parallel_for(static_cast<std::size_t>(h), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y) {
      std::size_t k = row_start[y];
      for (int x = 0; x < w; ++x) {
        const std::size_t i = y * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
        if (vs.distance[i] == kInfinity) continue;
        SurfacePoint sp;
        Rgb albedo;
        bool receives = true;
        plane_point(scene, vs.what[i], rays.ray(x, static_cast<int>(y)), vs.distance[i], sp, albedo, receives);
        vs.points[k] = sp;
        vs.pixel[k] = static_cast<std::uint32_t>(i);
        vs.albedo[k] = albedo;
        vs.receives[k] = receives ? 1 : 0;
        ++k;
      }
    }
  });
}

Image shade_surfaces(const Scene& scene, const Camera& cam, const VisibleSurfaces& vs, std::span<const Light> lights,
                     std::span<const LightShadows* const> shadows, const AmbientTechnique* ambient) {
  const ShadingParams& k = scene.shading;
  Image image(cam.width, cam.height, scene.background);
  const SurfaceShading shading(k);
  parallel_for(vs.points.size(), [&](std::size_t begin, std::size_t end) {
    std::array<Rgb, kPointBatch> T, ao, lit;
    for (std::size_t b0 = begin; b0 < end; b0 += kPointBatch) {
      if (cancel_requested()) return;  // shadow rays can make a chunk long: stop between batches
      const std::size_t n = std::min(kPointBatch, end - b0);
      const auto pts = std::span<const SurfacePoint>(vs.points.data() + b0, n);
      if (ambient) ambient->ambient(pts, std::span<Rgb>(ao.data(), n));
      else std::fill(ao.begin(), ao.begin() + static_cast<std::ptrdiff_t>(n), Rgb(1.0f));
      for (std::size_t i = 0; i < n; ++i) lit[i] = vs.albedo[b0 + i] * ao[i] * k.ambient;
      for (std::size_t l = 0; l < lights.size(); ++l) {
        shadows[l]->transmittance(pts, std::span<Rgb>(T.data(), n));
        for (std::size_t i = 0; i < n; ++i) {
          const Rgb t = vs.receives[b0 + i] ? T[i] : Rgb(1.0f);
          if (t.max_component() <= 0) continue;  // fully shadowed: ambient only
          const SurfacePoint& p = pts[i];
          const float diffuse_scale = (ao[i].r + ao[i].g + ao[i].b) / 3.0f;
          lit[i] += shading.direct(lights[l], p.position, p.normal, cam.eye, vs.albedo[b0 + i], p.kind != ObjectKind::Plane, diffuse_scale) * t;
        }
      }
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t px = vs.pixel[b0 + i];
        image.at(static_cast<int>(px % static_cast<std::uint32_t>(cam.width)), static_cast<int>(px / static_cast<std::uint32_t>(cam.width))) = lit[i];
      }
    }
  }, 1024);
  return image;
}

}  // namespace penumbra
