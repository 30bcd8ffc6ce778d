#include "cdff/serve/contour.hpp"

#include <cmath>
#include <map>
#include <numbers>

#include <opencv2/calib3d.hpp>

#include "cdff/egse/model.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::serve {

namespace {

constexpr double kWeldTolerance = 1e-4;  // m
constexpr double kNearZ = 0.01;          // m in front of the camera

}  // namespace

Result<MeshOutline> MeshOutline::of(const TriangleMesh& mesh) {
  CDFF_RETURN_IF_ERROR(mesh.validate("model mesh"));
  MeshOutline out;
  std::vector<Eigen::Vector3f> welded;
  const std::vector<std::uint32_t> index = egse::weldVertices(mesh, kWeldTolerance, &welded);
  for (const Eigen::Vector3f& v : welded) out.vertices_.push_back(v.cast<double>());
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t> edge_of;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const std::array<std::uint32_t, 3> w = {index[tri[0]], index[tri[1]], index[tri[2]]};
    const Eigen::Vector3d& p0 = out.vertices_[w[0]];
    const Eigen::Vector3d n = (out.vertices_[w[1]] - p0).cross(out.vertices_[w[2]] - p0);
    out.normals_.push_back(n.norm() > 0 ? n.normalized() : Eigen::Vector3d::Zero());
    out.centres_.push_back((p0 + out.vertices_[w[1]] + out.vertices_[w[2]]) / 3);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = w[k], b = w[(k + 1) % 3];
      if (a == b) continue;  // a degenerate triangle's collapsed side
      const auto key = std::minmax(a, b);
      auto [it, added] = edge_of.try_emplace({key.first, key.second}, out.edges_.size());
      if (added) {
        out.edges_.push_back({key.first, key.second, static_cast<std::int32_t>(t), -1});
      } else if (out.edges_[it->second].right < 0) {
        out.edges_[it->second].right = static_cast<std::int32_t>(t);
      }
    }
  }
  return out;
}

Result<std::vector<std::array<float, 4>>> MeshOutline::project(const Transform& camera_T_model,
                                                               const CameraModel& camera,
                                                               double crease_deg) const {
  CDFF_RETURN_IF_ERROR(camera.validate().withContext("the image's camera model"));
  // The camera's centre in the model frame: a triangle faces it when it is on the normal's side.
  const Eigen::Isometry3d model_T_camera = camera_T_model.isometry().inverse();
  const Eigen::Vector3d eye = model_T_camera.translation();
  const double cos_crease = std::cos(crease_deg * std::numbers::pi / 180);
  const auto facing = [&](std::int32_t t) {
    return t >= 0 && normals_[t].dot(eye - centres_[t]) > 0;
  };
  const Eigen::Isometry3d c_T_m = camera_T_model.isometry();
  std::vector<cv::Point3d> ends;
  for (const Edge& e : edges_) {
    const bool l = facing(e.left), r = facing(e.right);
    const bool silhouette = e.right < 0 ? l : l != r;
    const bool crease = l && r && normals_[e.left].dot(normals_[e.right]) < cos_crease;
    if (!silhouette && !crease) continue;
    const Eigen::Vector3d a = c_T_m * vertices_[e.a], b = c_T_m * vertices_[e.b];
    if (a.z() < kNearZ || b.z() < kNearZ) continue;
    ends.emplace_back(a.x(), a.y(), a.z());
    ends.emplace_back(b.x(), b.y(), b.z());
  }
  std::vector<std::array<float, 4>> out;
  if (ends.empty()) return out;
  std::vector<cv::Point2d> pixels;
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  if (camera.distortion_model == DistortionModel::kEquidistant) {
    cv::fisheye::projectPoints(ends, pixels, zero, zero, cameraMatrix(camera),
                               distortionCoefficients(camera));
  } else {
    cv::projectPoints(ends, zero, zero, cameraMatrix(camera),
                      camera.hasDistortion() ? distortionCoefficients(camera) : cv::Mat(), pixels);
  }
  out.reserve(pixels.size() / 2);
  for (std::size_t i = 0; i + 1 < pixels.size(); i += 2)
    out.push_back({static_cast<float>(pixels[i].x), static_cast<float>(pixels[i].y),
                   static_cast<float>(pixels[i + 1].x), static_cast<float>(pixels[i + 1].y)});
  return out;
}

nlohmann::json contourJson(const std::vector<std::array<float, 4>>& segments) {
  std::vector<float> flat;
  flat.reserve(segments.size() * 4);
  for (const auto& s : segments) flat.insert(flat.end(), s.begin(), s.end());
  return {{"count", segments.size()}, {"segments", flat}};
}

}  // namespace cdff::serve
