// The only translation unit that includes Embree.
#include "cdff/egse/raycaster.hpp"

#include <embree3/rtcore.h>

#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "cdff/types/triangle.hpp"

namespace cdff::egse {

struct RayCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<Eigen::Vector3f> face_normals;
  std::vector<Eigen::Vector3f> vertices;  // the model's, for the exact closest points
  std::vector<std::array<std::uint32_t, 3>> triangles;
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
  impl.vertices.assign(model.mesh.vertices.begin(), model.mesh.vertices.end());
  impl.triangles.assign(model.mesh.triangles.begin(), model.mesh.triangles.end());
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

namespace {

struct PointQueryState {
  const std::vector<Eigen::Vector3f>& vertices;
  const std::vector<std::array<std::uint32_t, 3>>& triangles;
  const std::vector<Eigen::Vector3f>& face_normals;
  Eigen::Vector3d query;
  SurfacePoint best;
};

}  // namespace

SurfacePoint RayCaster::closestPoint(const Eigen::Vector3d& query, double max_distance) const {
  PointQueryState state{impl_->vertices, impl_->triangles, impl_->face_normals, query, {}};
  state.best.distance = max_distance;
  RTCPointQuery q;
  q.x = static_cast<float>(query.x());
  q.y = static_cast<float>(query.y());
  q.z = static_cast<float>(query.z());
  q.time = 0;
  q.radius = static_cast<float>(max_distance);
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  auto visit = [](RTCPointQueryFunctionArguments* args) -> bool {
    auto& s = *static_cast<PointQueryState*>(args->userPtr);
    const auto& t = s.triangles[args->primID];
    const Eigen::Vector3d p =
        closestPointOnTriangle(s.query, s.vertices[t[0]].cast<double>(),
                               s.vertices[t[1]].cast<double>(), s.vertices[t[2]].cast<double>());
    const double d = (p - s.query).norm();
    if (d > s.best.distance) return false;
    s.best = {true, p, d, args->primID, s.face_normals[args->primID].cast<double>()};
    // Shrinks the search to the best distance so far (padded for the BVH's float bounds).
    args->query->radius = static_cast<float>(d) * (1.0f + 1e-6f) + 1e-7f;
    return true;
  };
  rtcPointQuery(impl_->scene, &q, &context, visit, &state);
  return state.best;
}

}  // namespace cdff::egse
