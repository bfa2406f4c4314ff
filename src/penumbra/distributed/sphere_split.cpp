#include "penumbra/distributed/sphere_split.h"

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/scene/technique_catalog.h"

namespace penumbra {

bool splits_spheres(const Scene& scene) { return scene.volumes.empty() && scene.has_particles(); }

void check_splittable(const Scene& scene) {
  if (scene.volumes.empty() && !scene.has_particles())
    throw Error("the scene must hold a volume (split into slabs over the ranks) or spheres (split by space); planes alone are not split");
}

void check_spheres_split(const Scene& scene, int ranks) {
  for (const ShadowAssignment& a : shadow_assignments(scene))
    if ((a.casters & kind_bit(ObjectKind::Spheres)) && a.technique != "issm")
      throw Error("shadows: the spheres' technique is '" + a.technique + "', but spheres split over MPI ranks cast shadows by issm "
                  "(the implicit sphere shadow map combines over the ranks; set shadows.spheres to issm or none)");
  if (scene.ambient.technique != "none" && scene.ambient.technique != "particle_ao" && (ambient_occluders(scene) & kind_bit(ObjectKind::Spheres)))
    throw Error("ambient.technique: '" + scene.ambient.technique + "', but spheres split over MPI ranks occlude by particle_ao "
                "(its densities add over the ranks; expected particle_ao or none)");
  std::size_t count = 0;
  for (const ParticleObject& p : scene.particles) count += p.set ? p.set->size() : 0;
  if (static_cast<std::size_t>(ranks) > count)
    throw Error(std::to_string(ranks) + " ranks for " + std::to_string(count) + " spheres (expected 1 to " + std::to_string(count) +
                " ranks: each holds at least one sphere)");
}

SphereShare sphere_share(const Scene& scene, int ranks, int rank) {
  struct Entry {
    float z;
    std::uint32_t object, index;
  };
  std::vector<Entry> all;
  for (std::size_t o = 0; o < scene.particles.size(); ++o) {
    const ParticleSet* set = scene.particles[o].set.get();
    for (std::size_t i = 0; set && i < set->size(); ++i)
      all.push_back({set->spheres[i].center.z, static_cast<std::uint32_t>(o), static_cast<std::uint32_t>(i)});
  }
  // z, then the object and index: the same order on every rank
  std::sort(all.begin(), all.end(), [](const Entry& a, const Entry& b) {
    return a.z != b.z ? a.z < b.z : a.object != b.object ? a.object < b.object : a.index < b.index;
  });
  const auto first = [&](int r) { return all.size() * static_cast<std::size_t>(r) / static_cast<std::size_t>(ranks); };
  std::vector<Entry> mine(all.begin() + static_cast<std::ptrdiff_t>(first(rank)), all.begin() + static_cast<std::ptrdiff_t>(first(rank + 1)));
  SphereShare share{scene, mine.size(), {}};
  if (!mine.empty()) share.slab = {mine.front().z, mine.back().z};
  std::sort(mine.begin(), mine.end(), [](const Entry& a, const Entry& b) { return a.object != b.object ? a.object < b.object : a.index < b.index; });
  for (std::size_t o = 0; o < scene.particles.size(); ++o) {
    auto set = std::make_shared<ParticleSet>();
    for (const Entry& e : mine)
      if (e.object == o) {
        set->spheres.push_back(scene.particles[o].set->spheres[e.index]);
        set->colors.push_back(scene.particles[o].set->colors[e.index]);
      }
    share.scene.particles[o].set = std::move(set);
  }
  return share;
}

}  // namespace penumbra
