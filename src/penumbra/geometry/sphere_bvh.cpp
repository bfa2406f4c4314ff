#include "penumbra/geometry/sphere_bvh.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"

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
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
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
