#include "penumbra/render/isosurface_frame.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/isosurface/iso_registry.h"
#include "penumbra/isosurface/light_pass.h"
#include "penumbra/isosurface/view_projection.h"
#include "penumbra/render/surface_shading.h"

namespace penumbra {

namespace {

constexpr std::uint32_t kNoPoint = 0xffffffffu;

}  // namespace

PreparedIsosurface::PreparedIsosurface(std::shared_ptr<const GridTree> t, const IsosurfaceObject& o)
    : object(&o), tree(std::move(t)), raycaster(*tree, o.value) {}

IsoPoints isosurface_eye_points(const Camera& camera, PreparedIsosurface& iso, IsosurfaceFrameStats& stats) {
  const IsosurfaceObject& o = *iso.object;
  switch (o.method) {
    case IsosurfaceMethod::Points: {
      ExtractionOptions options;
      options.collapse = o.collapse;
      Extraction e = extract_points(*iso.tree, o.value, ViewProjection::from_camera(camera), options);
      stats.extract_ms = e.stats.ms;
      stats.extraction = e.stats;
      return std::move(e.points);
    }
    case IsosurfaceMethod::Raycast: {
      Timer t;
      IsoPoints points = iso.raycaster.render(camera);
      stats.extract_ms = t.elapsed_ms();
      return points;
    }
    case IsosurfaceMethod::Mesh: {
      if (!iso.mesh) {
        Timer t;
        iso.mesh = std::make_unique<TriangleMesh>(marching_cubes(*iso.tree, o.value));
        stats.mesh_ms = t.elapsed_ms();
      }
      stats.triangles = iso.mesh->triangles();
      Timer t;
      IsoPoints points = rasterize_mesh(*iso.mesh, camera);
      stats.extract_ms = t.elapsed_ms();
      return points;
    }
  }
  return {};
}

SurfaceLayer render_isosurface_frame(const Scene& scene, const Camera& camera, std::span<PreparedIsosurface* const> isos,
                                     std::span<const Light> lights,
                                     std::vector<std::unique_ptr<IsoShadowTechnique>>& shadows,
                                     IsosurfaceFrameStats& stats) {
  const int w = camera.width, h = camera.height;
  const auto pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  // Each isosurface's eye pass; per pixel the nearest of their points.
  std::vector<IsoPoints> eye(isos.size());
  for (std::size_t s = 0; s < isos.size(); ++s) {
    IsosurfaceFrameStats one;
    eye[s] = isosurface_eye_points(camera, *isos[s], one);
    stats.add(one);
    stats.points += eye[s].size();
  }
  Timer shade;
  struct Nearest {
    std::uint32_t surface = kNoPoint, point = kNoPoint;
  };
  std::vector<Nearest> at_pixel(pixels);
  for (std::size_t s = 0; s < isos.size(); ++s)
    for (std::size_t i = 0; i < eye[s].size(); ++i) {
      Nearest& n = at_pixel[eye[s][i].pixel];
      if (n.point == kNoPoint || eye[s][i].distance < eye[n.surface][n.point].distance)
        n = {static_cast<std::uint32_t>(s), static_cast<std::uint32_t>(i)};
    }

  // Each pixel's nearest surface: an isosurface point or a nearer plane; listed in pixel order.
  SurfaceLayer layer;
  layer.distance.assign(pixels, kInfinity);
  std::vector<IsoPoints> row_points(static_cast<std::size_t>(h));
  std::vector<std::vector<Rgb>> row_albedo(static_cast<std::size_t>(h));
  std::vector<std::vector<std::uint8_t>> row_is_iso(static_cast<std::size_t>(h));
  const PrimaryRays rays(camera);
  parallel_for(static_cast<std::size_t>(h), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y)
      for (int x = 0; x < w; ++x) {
        const std::size_t i = y * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
        const Nearest k = at_pixel[i];
        float t = k.point == kNoPoint ? kInfinity : eye[k.surface][k.point].distance;
        const Plane* plane = nullptr;
        if (!scene.planes.empty()) {
          const Ray ray = rays.ray(x, static_cast<int>(y));
          plane = nearest_plane(scene.planes, ray, t);
          if (plane) {
            row_points[y].push_back(IsoPoint{ray.at(t), plane->facing_normal(ray.direction), t, static_cast<std::uint32_t>(i)});
            row_albedo[y].push_back(plane->color);
            row_is_iso[y].push_back(0);
          }
        }
        if (!plane && k.point != kNoPoint) {
          row_points[y].push_back(eye[k.surface][k.point]);
          row_albedo[y].push_back(isos[k.surface]->object->color);
          row_is_iso[y].push_back(1);
        }
        layer.distance[i] = t;
      }
  });
  std::vector<Rgb> albedo;
  std::vector<std::uint8_t> is_iso;
  for (std::size_t y = 0; y < static_cast<std::size_t>(h); ++y) {
    layer.receivers.insert(layer.receivers.end(), row_points[y].begin(), row_points[y].end());
    albedo.insert(albedo.end(), row_albedo[y].begin(), row_albedo[y].end());
    is_iso.insert(is_iso.end(), row_is_iso[y].begin(), row_is_iso[y].end());
  }
  stats.shade_ms += shade.elapsed_ms();

  // Shadows, built for these receivers (paper 002 §4: the light pass answers only for the eye points).
  // With several isosurfaces every one casts: each light gets one technique per isosurface, and a
  // receiver's light fraction is the product of theirs (lit only where no isosurface is in front).
  Timer shadow_timer;
  shadows.clear();
  std::vector<std::vector<float>> fraction(lights.size(), std::vector<float>(layer.receivers.size(), 1.0f));
  std::vector<float> one(layer.receivers.size());
  for (std::size_t l = 0; l < lights.size(); ++l)
    for (PreparedIsosurface* iso : isos) {
      auto technique = make_isosurface_shadow_technique(scene.shadows);
      technique->build(IsoShadowInputs{iso->tree.get(), iso->object->value, layer.receivers}, lights[l]);
      parallel_for(layer.receivers.size(), [&](std::size_t b, std::size_t e) {
        technique->light_fraction(std::span<const IsoPoint>(layer.receivers).subspan(b, e - b),
                                  std::span<float>(one).subspan(b, e - b));
        for (std::size_t i = b; i < e; ++i) fraction[l][i] *= one[i];
      }, 1024);
      if (const auto* pass = dynamic_cast<const LightPass*>(technique.get())) {
        stats.light_points += pass->light_points().points.size();
        stats.holes += pass->hole_count();
      }
      shadows.push_back(std::move(technique));
    }
  stats.shadow_ms = shadow_timer.elapsed_ms();

  // Blinn–Phong; isosurface points get a specular highlight, planes are Lambertian.
  shade.reset();
  const ShadingParams& k = scene.shading;
  layer.image = Image(w, h, scene.background);
  const SurfaceShading shading(k);
  parallel_for(layer.receivers.size(), [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const IsoPoint& p = layer.receivers[i];
      Rgb lit = albedo[i] * k.ambient;
      for (std::size_t l = 0; l < lights.size(); ++l)
        if (fraction[l][i] > 0)
          lit += shading.direct(lights[l], p.position, p.normal, camera.eye, albedo[i], is_iso[i] != 0) * fraction[l][i];
      layer.image.at(static_cast<int>(p.pixel % static_cast<std::uint32_t>(w)),
                     static_cast<int>(p.pixel / static_cast<std::uint32_t>(w))) = lit;
    }
  }, 1024);
  stats.shade_ms += shade.elapsed_ms();
  if (eye.size() == 1) layer.eye_points = std::move(eye.front());
  else
    for (const IsoPoints& e : eye) layer.eye_points.insert(layer.eye_points.end(), e.begin(), e.end());
  return layer;
}

}  // namespace penumbra
