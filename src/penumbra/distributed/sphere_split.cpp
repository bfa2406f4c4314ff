#include "penumbra/distributed/sphere_split.h"

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/registry/technique_catalog.h"

namespace penumbra {

bool splits_spheres(const Scene& scene) { return scene.volumes.empty() && scene.has_particles(); }

void check_splittable(const Scene& scene) {
  if (scene.volumes.empty() && !scene.has_particles())
    throw Error("the scene must hold a volume (split into slabs over the ranks) or spheres (split by space); planes alone are not split");
}

namespace {

// What stops the spheres from being split: a technique that would see only a rank's own spheres.
std::string technique_problem(const Scene& scene) {
  for (const ShadowAssignment& a : shadow_assignments(scene))
    if ((a.casters & kind_bit(ObjectKind::Spheres)) && a.technique != "issm" && a.technique != "cssm")
      return "shadows: the spheres' technique is '" + a.technique + "', but spheres split over MPI ranks cast shadows by issm or "
             "cssm (their maps combine over the ranks; set shadows.spheres to issm, cssm or none)";
  if (scene.ambient.technique != "none" && scene.ambient.technique != "particle_ao" && (ambient_occluders(scene) & kind_bit(ObjectKind::Spheres)))
    return "ambient.technique: '" + scene.ambient.technique + "', but spheres split over MPI ranks occlude by particle_ao "
           "(its densities add over the ranks; expected particle_ao or none)";
  return "";
}

// The spheres of every object whose entry keep() accepts, each object keeping its order.
template <class Keep>
Scene with_spheres(const Scene& scene, Keep&& keep, std::size_t& count) {
  Scene out = scene;
  count = 0;
  for (std::size_t o = 0; o < scene.particles.size(); ++o) {
    const ParticleSet* whole = scene.particles[o].set.get();
    auto set = std::make_shared<ParticleSet>();
    for (std::size_t i = 0; whole && i < whole->size(); ++i)
      if (keep(o, i, whole->spheres[i])) {
        set->spheres.push_back(whole->spheres[i]);
        set->colors.push_back(whole->colors[i]);
      }
    count += set->size();
    out.particles[o].set = std::move(set);
  }
  return out;
}

}  // namespace

void check_spheres_split(const Scene& scene, int ranks) {
  if (const std::string problem = technique_problem(scene); !problem.empty()) throw Error(problem);
  std::size_t count = 0;
  for (const ParticleObject& p : scene.particles) count += p.visible && p.set ? p.set->size() : 0;
  if (static_cast<std::size_t>(ranks) > count)
    throw Error(std::to_string(ranks) + " ranks for " + std::to_string(count) + " spheres (expected 1 to " + std::to_string(count) +
                " ranks: each holds at least one sphere)");
}

std::string why_spheres_whole(const Scene& scene) {
  if (const std::string problem = technique_problem(scene); !problem.empty()) return problem;
  bool casting = false;
  for (const ParticleObject& p : scene.particles) casting = casting || (p.visible && p.casts_shadows);
  if (casting && needs_extinction_sat(scene)) return "the extinction SAT takes the casting spheres whole";
  return "";
}

SphereShare spheres_in_slab(const Scene& scene, const SampleSlab& slab) {
  SphereShare share{{}, 0, slab};
  share.scene = with_spheres(scene, [&](std::size_t, std::size_t, const Sphere& s) {
    return s.center.z + s.radius >= slab.z_lo && s.center.z - s.radius < slab.z_hi;
  }, share.spheres);
  return share;
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
  SphereShare share{{}, 0, {}};
  if (!mine.empty()) share.slab = {mine.front().z, mine.back().z};
  std::vector<std::vector<bool>> kept(scene.particles.size());
  for (std::size_t o = 0; o < scene.particles.size(); ++o) kept[o].assign(scene.particles[o].set ? scene.particles[o].set->size() : 0, false);
  for (const Entry& e : mine) kept[e.object][e.index] = true;
  share.scene = with_spheres(scene, [&](std::size_t o, std::size_t i, const Sphere&) { return kept[o][i]; }, share.spheres);
  return share;
}

}  // namespace penumbra
