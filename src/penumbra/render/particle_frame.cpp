#include "penumbra/render/particle_frame.h"

#include <array>
#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/render/surface_shading.h"

namespace penumbra {
namespace {

constexpr std::size_t kBatch = 64;  // points whose shadow and ambient queries are issued together

}  // namespace

VisibleSurfaces visible_surfaces(const ParticleFrameInputs& in) {
  const Camera& cam = *in.camera;
  const int w = cam.width, h = cam.height;
  const auto pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  VisibleSurfaces vs;
  vs.distance.assign(pixels, kInfinity);
  // per row: the points in pixel order, so the list is the same for any thread count
  std::vector<std::vector<SurfacePoint>> row_points(static_cast<std::size_t>(h));
  std::vector<std::vector<std::uint32_t>> row_pixels(static_cast<std::size_t>(h));
  std::vector<std::vector<Rgb>> row_albedo(static_cast<std::size_t>(h));
  const bool no_planes = in.scene->planes.empty();
  const PrimaryRays rays(cam);
  parallel_for(static_cast<std::size_t>(h), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y) {
      for (int x = 0; x < w; ++x) {
        const std::size_t i = y * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
        if (no_planes && in.hits->id[i] == kNoSphere) continue;  // background
        const Vec3 dir = rays.direction(x, static_cast<int>(y));
        const Ray ray{cam.eye, dir};
        float t = in.hits->t[i];
        const Plane* plane = nearest_plane(in.scene->planes, ray, t);
        if (t == kInfinity) continue;
        vs.distance[i] = t;
        const Vec3 pos = ray.at(t);
        SurfacePoint sp;
        sp.position = pos;
        Rgb albedo;
        if (plane) {
          sp.normal = plane->facing_normal(dir);
          albedo = plane->color;
        } else {
          const std::uint32_t id = in.hits->id[i];
          const Sphere& s = in.particles->spheres[id];
          sp.normal = normalize(pos - s.center);
          sp.position = s.center + sp.normal * s.radius;  // on the surface to the last bit that matters
          sp.self = id;
          albedo = unpack_rgb8(in.particles->colors[id]);
        }
        row_points[y].push_back(sp);
        row_pixels[y].push_back(static_cast<std::uint32_t>(i));
        row_albedo[y].push_back(albedo);
      }
    }
  });
  for (std::size_t y = 0; y < static_cast<std::size_t>(h); ++y) {
    vs.points.insert(vs.points.end(), row_points[y].begin(), row_points[y].end());
    vs.pixel.insert(vs.pixel.end(), row_pixels[y].begin(), row_pixels[y].end());
    vs.albedo.insert(vs.albedo.end(), row_albedo[y].begin(), row_albedo[y].end());
  }
  return vs;
}

Image shade_particle_frame(const ParticleFrameInputs& in, const VisibleSurfaces& vs) {
  const Camera& cam = *in.camera;
  const ShadingParams& k = in.scene->shading;
  Image image(cam.width, cam.height, in.scene->background);
  const SurfaceShading shading(k);
  parallel_for(vs.points.size(), [&](std::size_t begin, std::size_t end) {
    std::array<float, kBatch> fraction;
    std::array<float, kBatch> ao;
    for (std::size_t b0 = begin; b0 < end; b0 += kBatch) {
      const std::size_t n = std::min(kBatch, end - b0);
      const auto pts = std::span<const SurfacePoint>(vs.points.data() + b0, n);
      std::array<Rgb, kBatch> lit;
      if (in.ambient) in.ambient->ambient(pts, std::span<float>(ao.data(), n));
      else std::fill(ao.begin(), ao.begin() + static_cast<std::ptrdiff_t>(n), 1.0f);
      for (std::size_t i = 0; i < n; ++i) lit[i] = vs.albedo[b0 + i] * (k.ambient * ao[i]);
      for (std::size_t l = 0; l < in.lights.size(); ++l) {
        in.shadows[l]->light_fraction(pts, std::span<float>(fraction.data(), n));
        const Light& light = in.lights[l];
        for (std::size_t i = 0; i < n; ++i) {
          if (fraction[i] <= 0) continue;  // fully shadowed: ambient only
          const SurfacePoint& p = pts[i];
          lit[i] += shading.direct(light, p.position, p.normal, cam.eye, vs.albedo[b0 + i], p.self != kNoSphere, ao[i]) *
                    fraction[i];
        }
      }
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint32_t px = vs.pixel[b0 + i];
        image.at(static_cast<int>(px % static_cast<std::uint32_t>(cam.width)),
                       static_cast<int>(px / static_cast<std::uint32_t>(cam.width))) = lit[i];
      }
    }
  }, 1024);
  return image;
}

int choose_issm_rings(ImplicitSphereShadowMap& map, std::span<const SurfacePoint> points, int max_rings,
                      double max_changed) {
  std::vector<float> previous(points.size()), current(points.size());
  auto evaluate = [&](std::vector<float>& out) {
    parallel_for(points.size(), [&](std::size_t b, std::size_t e) {
      map.light_fraction(points.subspan(b, e - b), std::span<float>(out.data() + b, e - b));
    }, 4096);
  };
  map.set_rings(0);
  evaluate(previous);
  for (int t = 1; t <= max_rings; ++t) {
    map.set_rings(t);
    evaluate(current);
    std::size_t changed = 0;
    for (std::size_t i = 0; i < points.size(); ++i) changed += std::abs(current[i] - previous[i]) > 1.0f / 255.0f;
    if (static_cast<double>(changed) <= max_changed * static_cast<double>(points.size())) {
      map.set_rings(t - 1);  // t − 1 rings already gave this image
      return t - 1;
    }
    previous.swap(current);
  }
  return max_rings;
}

}  // namespace penumbra
