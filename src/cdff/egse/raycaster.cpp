// The only translation unit that includes Embree.
#include "cdff/egse/raycaster.hpp"

#include <embree3/rtcore.h>

#include <cmath>
#include <vector>

namespace cdff::egse {

struct RayCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<Eigen::Vector3f> face_normals;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

RayCaster::~RayCaster() = default;

Result<std::unique_ptr<RayCaster>> RayCaster::create(const TargetModel& model) {
  CDFF_RETURN_IF_ERROR(model.validate());
  std::unique_ptr<RayCaster> caster(new RayCaster());
  caster->impl_ = std::make_unique<Impl>();
  Impl& impl = *caster->impl_;
  // One thread: the build is then deterministic and leaves the other cores to the renderer.
  impl.device = rtcNewDevice("threads=1,set_affinity=0");
  if (!impl.device)
    return Status(StatusCode::kInternal, fmt::format("embree: rtcNewDevice failed (error {})",
                                                     static_cast<int>(rtcGetDeviceError(nullptr))));
  impl.scene = rtcNewScene(impl.device);
  rtcSetSceneBuildQuality(impl.scene, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geometry = rtcNewGeometry(impl.device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0,
                                                               RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                               model.mesh.vertices.size()));
  auto* indices = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                              3 * sizeof(unsigned), model.mesh.triangles.size()));
  if (!vertices || !indices) {
    rtcReleaseGeometry(geometry);
    return Status(StatusCode::kInternal, "embree: cannot allocate the geometry buffers");
  }
  for (std::size_t i = 0; i < model.mesh.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) vertices[3 * i + k] = model.mesh.vertices[i][k];
  for (std::size_t t = 0; t < model.mesh.triangles.size(); ++t) {
    const auto& tri = model.mesh.triangles[t];
    for (int k = 0; k < 3; ++k) indices[3 * t + k] = tri[k];
    const Eigen::Vector3f n = (model.mesh.vertices[tri[1]] - model.mesh.vertices[tri[0]])
                                  .cross(model.mesh.vertices[tri[2]] - model.mesh.vertices[tri[0]]);
    impl.face_normals.push_back(n.norm() > 0 ? n.normalized() : Eigen::Vector3f::UnitZ());
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(impl.scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(impl.scene);
  const RTCError error = rtcGetDeviceError(impl.device);
  if (error != RTC_ERROR_NONE)
    return Status(StatusCode::kInternal, fmt::format("embree: building the scene failed (error {})",
                                                     static_cast<int>(error)));
  return caster;
}

namespace {

void fill(RTCRayHit& rh, const Ray& ray) {
  rh.ray.org_x = ray.origin.x();
  rh.ray.org_y = ray.origin.y();
  rh.ray.org_z = ray.origin.z();
  rh.ray.dir_x = ray.direction.x();
  rh.ray.dir_y = ray.direction.y();
  rh.ray.dir_z = ray.direction.z();
  rh.ray.tnear = ray.t_min;
  rh.ray.tfar = ray.t_max;
  rh.ray.time = 0;
  rh.ray.mask = 0xffffffffu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

RayHit toHit(const RTCRayHit& rh, const Ray& ray, const std::vector<Eigen::Vector3f>& normals) {
  RayHit hit;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
  hit.hit = true;
  hit.distance = rh.ray.tfar;
  hit.triangle = rh.hit.primID;
  hit.normal = normals[rh.hit.primID];
  if (hit.normal.dot(ray.direction) > 0) hit.normal = -hit.normal;
  return hit;
}

}  // namespace

RayHit RayCaster::intersect(const Ray& ray) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  fill(rh, ray);
  rtcIntersect1(impl_->scene, &context, &rh);
  return toHit(rh, ray, impl_->face_normals);
}

void RayCaster::intersect(std::span<const Ray> rays, std::span<RayHit> hits) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  constexpr std::size_t kBatch = 256;
  RTCRayHit batch[kBatch];
  for (std::size_t start = 0; start < rays.size(); start += kBatch) {
    const std::size_t n = std::min(kBatch, rays.size() - start);
    for (std::size_t i = 0; i < n; ++i) fill(batch[i], rays[start + i]);
    rtcIntersect1M(impl_->scene, &context, batch, static_cast<unsigned>(n), sizeof(RTCRayHit));
    for (std::size_t i = 0; i < n; ++i)
      hits[start + i] = toHit(batch[i], rays[start + i], impl_->face_normals);
  }
}

bool RayCaster::occluded(const Ray& ray) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r;
  r.org_x = ray.origin.x();
  r.org_y = ray.origin.y();
  r.org_z = ray.origin.z();
  r.dir_x = ray.direction.x();
  r.dir_y = ray.direction.y();
  r.dir_z = ray.direction.z();
  r.tnear = ray.t_min;
  r.tfar = ray.t_max;
  r.time = 0;
  r.mask = 0xffffffffu;
  r.id = 0;
  r.flags = 0;
  rtcOccluded1(impl_->scene, &context, &r);
  return r.tfar < 0;  // Embree sets tfar to -inf on a hit
}

}  // namespace cdff::egse
