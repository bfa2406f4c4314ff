#include "penumbra/geometry/sphere_bvh.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <string>
#include <memory>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"
#include "penumbra/geometry/cut_sphere.h"

namespace penumbra {
namespace {

RTCRay to_rtc(const Ray& ray, float tmin, float tmax) {
  RTCRay r{};
  r.org_x = ray.origin.x;
  r.org_y = ray.origin.y;
  r.org_z = ray.origin.z;
  r.dir_x = ray.direction.x;
  r.dir_y = ray.direction.y;
  r.dir_z = ray.direction.z;
  r.tnear = tmin;
  r.tfar = tmax;
  r.mask = 0xFFFFFFFFu;
  r.flags = 0;
  return r;
}

// Spheres the clip planes cut or remove are not Embree's whole spheres: its hits on them are refused
// here, and the cut ones are a user geometry of their own (below).
void refuse_clipped(const RTCFilterFunctionNArguments* args) {
  const auto& set = *static_cast<const ParticleSet*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i)
    if (args->valid[i] != 0 && set.clip_of(RTCHitN_primID(args->hit, args->N, i)) != kSphereWhole) args->valid[i] = 0;
}

// The cut spheres, intersected exactly (geometry/cut_sphere.h); primitive k is sphere cut_ids[k].
struct CutSpheres {
  const ParticleSet* set;
  std::vector<std::uint32_t> ids;
};

void cut_sphere_bounds(const RTCBoundsFunctionArguments* args) {
  const auto& cut = *static_cast<const CutSpheres*>(args->geometryUserPtr);
  const Sphere& s = cut.set->spheres[cut.ids[args->primID]];
  *args->bounds_o = RTCBounds{s.center.x - s.radius, s.center.y - s.radius, s.center.z - s.radius, 0,
                              s.center.x + s.radius, s.center.y + s.radius, s.center.z + s.radius, 0};
}

void cut_sphere_intersect(const RTCIntersectFunctionNArguments* args) {
  if (args->N != 1 || !args->valid[0]) return;  // the BVH issues single rays only
  const auto& cut = *static_cast<const CutSpheres*>(args->geometryUserPtr);
  auto* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
  const std::uint32_t id = cut.ids[args->primID];
  const Ray ray{{rh->ray.org_x, rh->ray.org_y, rh->ray.org_z}, {rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z}};
  const float t = intersect_particle(*cut.set, id, ray, rh->ray.tnear, rh->ray.tfar);
  if (t == kInfinity) return;
  const Vec3 n = particle_normal(*cut.set, id, ray.at(t));
  rh->ray.tfar = t;
  rh->hit.Ng_x = n.x;
  rh->hit.Ng_y = n.y;
  rh->hit.Ng_z = n.z;
  rh->hit.u = rh->hit.v = 0;
  rh->hit.primID = id;  // the sphere's index in the set, as the whole spheres report theirs
  rh->hit.geomID = args->geomID;
  rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

void cut_sphere_occluded(const RTCOccludedFunctionNArguments* args) {
  if (args->N != 1 || !args->valid[0]) return;
  const auto& cut = *static_cast<const CutSpheres*>(args->geometryUserPtr);
  auto* r = reinterpret_cast<RTCRay*>(args->ray);
  const Ray ray{{r->org_x, r->org_y, r->org_z}, {r->dir_x, r->dir_y, r->dir_z}};
  if (intersect_particle(*cut.set, cut.ids[args->primID], ray, r->tnear, r->tfar) < kInfinity) r->tfar = -kInfinity;
}

// Embree's memory monitor: adds what the device allocates and frees.
bool count_memory(void* counter, ssize_t bytes, bool /*post*/) {
  *static_cast<std::atomic<std::int64_t>*>(counter) += bytes;
  return true;
}

}  // namespace

SphereBvh::SphereBvh(const ParticleSet& particles) {
  Timer timer;
  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) throw Error("Embree: cannot create a device (error " + std::to_string(rtcGetDeviceError(nullptr)) + ")");
  device_ = device;
  rtcSetDeviceMemoryMonitorFunction(device, count_memory, allocated_.get());
  RTCScene scene = rtcNewScene(device);
  scene_ = scene;
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
  if (particles.size() > 0) {
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, particles.spheres.data(), 0,
                               sizeof(Sphere), particles.size());
    if (!particles.clip_state.empty()) {
      rtcSetGeometryUserData(geom, const_cast<ParticleSet*>(&particles));
      rtcSetGeometryIntersectFilterFunction(geom, refuse_clipped);
      rtcSetGeometryOccludedFilterFunction(geom, refuse_clipped);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
  }
  auto cut = std::make_unique<CutSpheres>(CutSpheres{&particles, {}});
  for (std::size_t i = 0; i < particles.clip_state.size(); ++i)
    if (particles.clip_state[i] != kSphereWhole && particles.clip_state[i] != kSphereRemoved) cut->ids.push_back(static_cast<std::uint32_t>(i));
  if (!cut->ids.empty()) {
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(geom, static_cast<unsigned>(cut->ids.size()));
    rtcSetGeometryUserData(geom, cut.get());
    rtcSetGeometryBoundsFunction(geom, cut_sphere_bounds, nullptr);
    rtcSetGeometryIntersectFunction(geom, cut_sphere_intersect);
    rtcSetGeometryOccludedFunction(geom, cut_sphere_occluded);
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
    cut_spheres_ = std::shared_ptr<void>(cut.release(), [](void* p) { delete static_cast<CutSpheres*>(p); });
  }
  rtcCommitScene(scene);
  if (const RTCError e = rtcGetDeviceError(device); e != RTC_ERROR_NONE)
    throw Error("Embree: building the sphere BVH failed (error " + std::to_string(static_cast<int>(e)) + ")");
  build_ms_ = timer.elapsed_ms();
}

SphereBvh::~SphereBvh() {
  if (scene_) rtcReleaseScene(static_cast<RTCScene>(scene_));
  if (device_) rtcReleaseDevice(static_cast<RTCDevice>(device_));
}

std::size_t SphereBvh::memory_bytes() const {
  return static_cast<std::size_t>(std::max<std::int64_t>(0, allocated_->load()));
}

SphereHit SphereBvh::first_hit(const Ray& ray, float tmin, float tmax) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh{};
  rh.ray = to_rtc(ray, tmin, tmax);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(static_cast<RTCScene>(scene_), &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return {};
  return {rh.ray.tfar, rh.hit.primID};
}

bool SphereBvh::occluded(const Ray& ray, float tmin, float tmax) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r = to_rtc(ray, tmin, tmax);
  rtcOccluded1(static_cast<RTCScene>(scene_), &context, &r);
  return r.tfar < 0;  // Embree sets tfar to -inf on a hit
}

}  // namespace penumbra
