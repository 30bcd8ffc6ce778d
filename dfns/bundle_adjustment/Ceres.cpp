// BundleAdjustment/Ceres: poses and points refined together with Ceres Solver (description in
// BundleAdjustment.yaml).
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <ceres/ceres.h>
#include <ceres/covariance.h>
#include <ceres/sphere_manifold.h>
#include <fmt/format.h>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "BundleAdjustment.gen.hpp"
#include "cdff/types/geometry.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn {
namespace {

struct Observation {
  int camera = 0;
  int point = 0;
  Eigen::Vector2d ray;  // the undistorted pixel in normalised coordinates
};

/// The reprojection residual (px) of one observation over the pose's rotation (world_q_camera,
/// Eigen's x y z w), its centre block and the point, with its analytic Jacobians. The centre
/// block is the camera centre in the world frame, or, when `on_sphere`, the unit direction d of
/// the centre from `origin` (the first camera's centre): centre = origin + radius d. The point in
/// the camera, p = q* (x - centre) q, is written for q = (w, u) as v - 2 w (u x v) + 2 u x (u x v)
/// with v = x - centre (Eigen's rotation by a unit quaternion), whose derivatives in w and u are
/// the ambient Jacobian Ceres maps through the quaternion manifold.
class Reprojection final : public ceres::SizedCostFunction<2, 4, 3, 3> {
 public:
  Reprojection(const Eigen::Vector2d& ray, double fx, double fy, bool on_sphere,
               const Eigen::Vector3d& origin, double radius)
      : ray_(ray), fx_(fx), fy_(fy), on_sphere_(on_sphere), origin_(origin), radius_(radius) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Eigen::Vector3d> u(parameters[0]);
    const double w = parameters[0][3];
    const Eigen::Map<const Eigen::Vector3d> block(parameters[1]), point(parameters[2]);
    const Eigen::Vector3d centre =
        on_sphere_ ? Eigen::Vector3d(origin_ + radius_ * block) : Eigen::Vector3d(block);
    const Eigen::Vector3d v = point - centre;
    const Eigen::Vector3d uv = u.cross(v);
    const Eigen::Vector3d p = v - 2 * w * uv + 2 * u.cross(uv);
    const double iz = 1.0 / p.z();
    residuals[0] = fx_ * (p.x() * iz - ray_.x());
    residuals[1] = fy_ * (p.y() * iz - ray_.y());
    if (!jacobians) return true;
    Eigen::Matrix<double, 2, 3> dr_dp;
    dr_dp << fx_ * iz, 0, -fx_ * p.x() * iz * iz, 0, fy_ * iz, -fy_ * p.y() * iz * iz;
    const Eigen::Matrix3d su = skew(u);
    const Eigen::Matrix3d dp_dv = Eigen::Matrix3d::Identity() - 2 * w * su + 2 * su * su;
    if (jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 2, 4, Eigen::RowMajor>> j(jacobians[0]);
      const Eigen::Matrix3d dp_du =
          2 * w * skew(v) +
          2 * (u.dot(v) * Eigen::Matrix3d::Identity() + u * v.transpose() - 2 * v * u.transpose());
      j.leftCols<3>() = dr_dp * dp_du;
      j.col(3) = dr_dp * (-2 * uv);
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[1]);
      j = -(on_sphere_ ? radius_ : 1.0) * dr_dp * dp_dv;
    }
    if (jacobians[2]) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[2]);
      j = dr_dp * dp_dv;
    }
    return true;
  }

 private:
  Eigen::Vector2d ray_;
  double fx_, fy_;
  bool on_sphere_;
  Eigen::Vector3d origin_;
  double radius_;
};

/// The poses and points being refined, in the blocks Ceres works on.
struct State {
  std::vector<Eigen::Quaterniond> rotation;  // world_q_camera
  std::vector<Eigen::Vector3d> centre;       // the camera centres in the world frame
  std::vector<Eigen::Vector3d> points;
  bool on_sphere = false;  // the second centre is origin + radius * direction
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();
  double radius = 0;

  Eigen::Vector3d centreOf(int i) const {
    return on_sphere && i == 1 ? Eigen::Vector3d(centre[0] + radius * direction) : centre[i];
  }
  /// The residual (px) of observation o, and whether its point is in front of the camera.
  bool residual(const Observation& o, double fx, double fy, Eigen::Vector2d& r) const {
    const Eigen::Vector3d p =
        rotation[o.camera].conjugate() * (points[o.point] - centreOf(o.camera));
    r = {fx * (p.x() / p.z() - o.ray.x()), fy * (p.y() / p.z() - o.ray.y())};
    return p.z() > 0;
  }
};

enum class Label { kInlier, kOutlier, kBehind, kUnverified };

const char* labelName(Label l) {
  switch (l) {
    case Label::kInlier:
      return "inlier";
    case Label::kOutlier:
      return "outlier";
    case Label::kBehind:
      return "behind_camera";
    case Label::kUnverified:
      return "unverified";
  }
  return "?";
}

/// Reads the observations (indices checked) and their pixels.
Result<std::vector<Observation>> readObservations(const nlohmann::json& j, int poses, int points,
                                                  std::vector<Eigen::Vector2d>& pixels) {
  if (!j.is_array() || j.empty())
    return invalidInput(
        "input 'observations' is {}; expected a non-empty array of {{\"camera\": i, "
        "\"point\": j, \"pixel\": [u, v]}}",
        j.is_array() ? "an empty array" : std::string("a ") + j.type_name());
  std::vector<Observation> out(j.size());
  pixels.resize(j.size());
  for (std::size_t k = 0; k < j.size(); ++k) {
    const nlohmann::json& e = j[k];
    if (!e.is_object() || !e.contains("camera") || !e.contains("point") || !e.contains("pixel"))
      return invalidInput(
          "input 'observations' entry {} is {}; expected an object with the keys camera, "
          "point and pixel",
          k, e.dump());
    const nlohmann::json &camera = e["camera"], &point = e["point"], &pixel = e["pixel"];
    if (!camera.is_number_integer() || camera.get<long long>() < 0 ||
        camera.get<long long>() >= poses)
      return invalidInput(
          "input 'observations' entry {}: camera = {} is out of range; expected a pose index "
          "in [0, {}] ({} poses)",
          k, camera.dump(), poses - 1, poses);
    if (!point.is_number_integer() || point.get<long long>() < 0 ||
        point.get<long long>() >= points)
      return invalidInput(
          "input 'observations' entry {}: point = {} is out of range; expected a point index "
          "in [0, {}] ({} points)",
          k, point.dump(), points - 1, points);
    if (!pixel.is_array() || pixel.size() != 2 || !pixel[0].is_number() || !pixel[1].is_number())
      return invalidInput("input 'observations' entry {}: pixel = {}; expected [u, v] in px", k,
                          pixel.dump());
    pixels[k] = {pixel[0].get<double>(), pixel[1].get<double>()};
    if (!pixels[k].allFinite())
      return invalidInput("input 'observations' entry {}: pixel = ({}, {}); expected finite px", k,
                          pixels[k].x(), pixels[k].y());
    out[k].camera = camera.get<int>();
    out[k].point = point.get<int>();
  }
  return out;
}

/// The poses as rotations and centres, each checked: finite, a rotation matrix.
Status readPoses(const PoseArray& poses, State& s) {
  if (poses.poses.empty())
    return invalidInput("input 'poses' is empty; expected at least 2 camera poses");
  if (poses.poses.size() < 2)
    return invalidInput(
        "input 'poses' has 1 pose; expected at least 2 (a point's depth needs two views)");
  for (std::size_t i = 0; i < poses.poses.size(); ++i) {
    const Eigen::Isometry3d& pose = poses.poses[i];
    if (!pose.matrix().allFinite())
      return invalidInput("input 'poses' pose {} has a non-finite entry; expected a finite pose",
                          i);
    const Eigen::Matrix3d r = pose.linear();
    const double orthogonality = (r.transpose() * r - Eigen::Matrix3d::Identity()).norm();
    if (!(orthogonality < 1e-6) || !(r.determinant() > 0))
      return invalidInput(
          "input 'poses' pose {} has a rotation part with |R^T R - I| = {} and det {}; "
          "expected a rotation matrix (1e-6)",
          i, orthogonality, r.determinant());
    s.rotation.emplace_back(Eigen::Quaterniond(r).normalized());
    s.centre.push_back(pose.translation());
  }
  return Status::ok();
}

/// How many distinct poses see each point through the observations in `use`.
std::vector<int> viewsPerPoint(const std::vector<Observation>& obs, const std::vector<char>& use,
                               int points) {
  std::vector<std::vector<int>> seen(points);
  for (std::size_t k = 0; k < obs.size(); ++k) {
    if (!use[k]) continue;
    std::vector<int>& poses = seen[obs[k].point];
    if (std::find(poses.begin(), poses.end(), obs[k].camera) == poses.end())
      poses.push_back(obs[k].camera);
  }
  std::vector<int> count(points);
  for (int j = 0; j < points; ++j) count[j] = static_cast<int>(seen[j].size());
  return count;
}

/// The distinct points each pose sees through the observations in `use`.
std::vector<int> pointsPerPose(const std::vector<Observation>& obs, const std::vector<char>& use,
                               int poses) {
  std::vector<std::vector<int>> seen(poses);
  for (std::size_t k = 0; k < obs.size(); ++k)
    if (use[k]) seen[obs[k].camera].push_back(obs[k].point);
  std::vector<int> count(poses);
  for (int i = 0; i < poses; ++i) {
    std::sort(seen[i].begin(), seen[i].end());
    count[i] = static_cast<int>(std::unique(seen[i].begin(), seen[i].end()) - seen[i].begin());
  }
  return count;
}

/// The observations (inliers and outliers) of points seen through inliers from fewer than 2
/// poses become unverified: such a point is free along a ray or undetermined, so its
/// observations neither constrain the poses nor can be checked (holding the point instead would
/// make it a wrong known point).
void markUnverified(const std::vector<Observation>& obs, int points, std::vector<Label>& labels) {
  std::vector<char> inlier(obs.size());
  for (std::size_t k = 0; k < obs.size(); ++k) inlier[k] = labels[k] == Label::kInlier;
  const std::vector<int> views = viewsPerPoint(obs, inlier, points);
  for (std::size_t k = 0; k < obs.size(); ++k)
    if (labels[k] != Label::kBehind && views[obs[k].point] < 2) labels[k] = Label::kUnverified;
}

/// The median of the residuals' norms (px) of the observations in `use`.
double medianResidual(const State& s, const std::vector<Observation>& obs,
                      const std::vector<char>& use, double fx, double fy) {
  std::vector<double> norms;
  for (std::size_t k = 0; k < obs.size(); ++k) {
    Eigen::Vector2d r;
    if (use[k] && s.residual(obs[k], fx, fy, r)) norms.push_back(r.norm());
  }
  if (norms.empty()) return 0;
  std::nth_element(norms.begin(), norms.begin() + norms.size() / 2, norms.end());
  return norms[norms.size() / 2];
}

/// One least-squares problem over the observations in `use`; kept for the covariance.
struct Solve {
  std::unique_ptr<ceres::Problem> problem;
  ceres::Solver::Summary summary;
  int residuals = 0;   // observations in the problem
  int parameters = 0;  // free parameters (tangent dimensions)
};

}  // namespace

class BundleAdjustmentCeres final : public BundleAdjustmentCeresBase {
 protected:
  Status onProcess() override {
    State s;
    std::vector<Observation> obs;
    CDFF_RETURN_IF_ERROR(readInputs(s, obs));
    CDFF_RETURN_IF_ERROR(checkProblem(s, obs));
    std::vector<Label> labels;
    Solve solve;
    CDFF_RETURN_IF_ERROR(adjust(s, obs, labels, solve));
    return writeOutputs(s, obs, labels, solve);
  }

 private:
  /// The poses, points and observations (undistorted to normalised coordinates), checked.
  Status readInputs(State& s, std::vector<Observation>& obs) {
    const PoseArray& in_poses = *in.poses;
    const PointCloud& in_points = *in.points;
    const CameraModel& camera = *in.camera;
    CDFF_RETURN_IF_ERROR(readPoses(in_poses, s));
    CDFF_RETURN_IF_ERROR(in_points.validate("input 'points'"));
    if (!in_poses.frame_id.empty() && !in_points.frame_id.empty() &&
        in_poses.frame_id != in_points.frame_id)
      return invalidInput(
          "input 'points' is in frame '{}' and input 'poses' in '{}'; expected one world frame",
          in_points.frame_id, in_poses.frame_id);
    if (Status st = camera.validate(); !st.isOk())
      return invalidInput("input 'camera': {}", st.message());
    for (const Point4f& q : in_points.points) s.points.emplace_back(q.x, q.y, q.z);
    const int n_poses = static_cast<int>(s.rotation.size());
    const int n_points = static_cast<int>(s.points.size());
    if (n_points < 3)
      return invalidInput(
          "input 'points' has {} points; expected at least 3 (a pose needs 3 points)", n_points);
    if (params_.fixed_poses > n_poses)
      return invalidInput(
          "parameter fixed_poses = {} holds more poses than the {} of input 'poses'; expected "
          "at most {}",
          params_.fixed_poses, n_poses, n_poses);
    std::vector<Eigen::Vector2d> pixels;
    Result<std::vector<Observation>> read =
        readObservations(*in.observations, n_poses, n_points, pixels);
    if (!read) return read.status();
    obs = std::move(read).value();
    auto rays = normalizedCoordinates(camera, pixels, "input 'observations'");
    if (!rays) return rays.status();
    for (std::size_t k = 0; k < obs.size(); ++k) obs[k].ray = rays.value()[k];
    return Status::ok();
  }

  /// Every pose seen in and a free one determined by 3 points, the gauge's scale (the first two
  /// centres' distance when only the first pose is held), more residuals than unknowns.
  Status checkProblem(State& s, const std::vector<Observation>& obs) {
    const int n_poses = static_cast<int>(s.rotation.size());
    const int n_points = static_cast<int>(s.points.size());
    const std::vector<char> all(obs.size(), 1);
    const std::vector<int> per_pose = pointsPerPose(obs, all, n_poses);
    for (int i = 0; i < n_poses; ++i) {
      if (per_pose[i] == 0)
        return invalidInput(
            "input 'observations' has no observation from pose {}; expected every pose to see "
            "points",
            i);
      if (i >= params_.fixed_poses && per_pose[i] < 3)
        return invalidInput(
            "input 'observations': pose {} sees {} points; expected at least 3 for a free pose", i,
            per_pose[i]);
    }
    held_ = params_.fixed_poses;
    s.on_sphere = held_ == 1;
    double extent = 0;
    for (const Eigen::Vector3d& x : s.points) extent = std::max(extent, (x - s.centre[0]).norm());
    double held_baseline = 0;
    for (int i = 1; i < held_; ++i)
      held_baseline = std::max(held_baseline, (s.centre[i] - s.centre[0]).norm());
    if (held_ >= 2 && !(held_baseline > 1e-9 * extent))
      return invalidInput(
          "input 'poses': the {} held camera centres (fixed_poses) are at one place; expected a "
          "baseline between them, which holds the scale",
          held_);
    if (s.on_sphere) {
      const Eigen::Vector3d d = s.centre[1] - s.centre[0];
      s.radius = d.norm();
      if (!(s.radius > 1e-9 * extent))
        return invalidInput(
            "input 'poses': the first two camera centres are {} m apart; expected a baseline "
            "between them, which holds the scale with fixed_poses = 1 (or fixed_poses >= 2)",
            s.radius);
      s.direction = d / s.radius;
    }
    const std::vector<int> views = viewsPerPoint(obs, all, n_points);
    int unknowns = 6 * (n_poses - held_) - (s.on_sphere ? 1 : 0);
    for (int v : views) unknowns += v >= 2 ? 3 : 0;
    if (2 * static_cast<int>(obs.size()) <= unknowns)
      return invalidInput(
          "input 'observations' has {} observations ({} residuals) for {} unknowns; expected "
          "more residuals than unknowns",
          obs.size(), 2 * obs.size(), unknowns);
    return Status::ok();
  }

  /// Each observation's label at the current state: behind the camera, beyond the threshold,
  /// unverified (markUnverified) or an inlier.
  std::vector<Label> classify(const State& s, const std::vector<Observation>& obs) const {
    const CameraModel& camera = *in.camera;
    std::vector<Label> labels(obs.size());
    for (std::size_t k = 0; k < obs.size(); ++k) {
      Eigen::Vector2d r;
      labels[k] = !s.residual(obs[k], camera.fx, camera.fy, r) ? Label::kBehind
                  : r.norm() > params_.outlier_threshold       ? Label::kOutlier
                                                               : Label::kInlier;
    }
    markUnverified(obs, static_cast<int>(s.points.size()), labels);
    return labels;
  }

  /// The robust solves on every usable observation, the loss's scale from the residuals' median
  /// down to loss_scale (a quarter each time), then least squares on the inliers until the
  /// classification settles (at most 3 rounds). Observations behind the camera at the start and
  /// those of points seen from one pose are left out of the robust solves.
  Status adjust(State& s, const std::vector<Observation>& obs, std::vector<Label>& labels,
                Solve& solve) {
    const Parameters& p = params_;
    const CameraModel& camera = *in.camera;
    labels = classify(s, obs);
    std::vector<char> use(obs.size());
    for (std::size_t k = 0; k < obs.size(); ++k) use[k] = labels[k] != Label::kBehind;
    std::vector<Label> start(obs.size());
    for (std::size_t k = 0; k < obs.size(); ++k)
      start[k] = use[k] ? Label::kInlier : Label::kBehind;
    markUnverified(obs, static_cast<int>(s.points.size()), start);
    for (std::size_t k = 0; k < obs.size(); ++k) use[k] = start[k] == Label::kInlier;
    for (double scale = std::max(p.loss_scale, medianResidual(s, obs, use, camera.fx, camera.fy));;
         scale = std::max(p.loss_scale, 0.25 * scale)) {
      Result<Solve> solved = solveOnce(s, obs, use, camera, scale);
      if (!solved) return solved.status();
      if (scale <= p.loss_scale) break;
    }
    labels = classify(s, obs);
    for (int round = 0; round < 3; ++round) {
      for (std::size_t k = 0; k < obs.size(); ++k) use[k] = labels[k] == Label::kInlier;
      Result<Solve> solved = solveOnce(s, obs, use, camera, 0.0);
      if (!solved) return solved.status();
      solve = std::move(solved).value();
      std::vector<Label> next = classify(s, obs);
      const bool settled = next == labels;
      labels = std::move(next);
      if (settled) break;
    }
    for (std::size_t k = 0; k < obs.size(); ++k) use[k] = labels[k] == Label::kInlier;
    const std::vector<int> inlier_points =
        pointsPerPose(obs, use, static_cast<int>(s.rotation.size()));
    for (std::size_t i = held_; i < inlier_points.size(); ++i)
      if (inlier_points[i] < 3)
        return numericalFailure(
            "BundleAdjustment: pose {} keeps {} inlier points after the refinement (outlier "
            "threshold {} px); expected at least 3",
            i, inlier_points[i], p.outlier_threshold);
    return Status::ok();
  }

  /// The outputs (and the warnings that give the counts).
  Status writeOutputs(State& s, const std::vector<Observation>& obs,
                      const std::vector<Label>& labels, Solve& solve) {
    const CameraModel& camera = *in.camera;
    const int n_poses = static_cast<int>(s.rotation.size());
    const int n_points = static_cast<int>(s.points.size());
    nlohmann::json covariance;
    if (params_.compute_covariance) {
      Result<nlohmann::json> cov = poseCovariance(s, solve, n_poses);
      if (!cov) return cov.status();
      covariance = std::move(cov).value();
    }
    nlohmann::json status = nlohmann::json::array();
    std::vector<char> use(obs.size());
    double sum2 = 0;
    std::array<int, 4> count{};  // per label
    for (std::size_t k = 0; k < obs.size(); ++k) {
      status.push_back(labelName(labels[k]));
      ++count[static_cast<int>(labels[k])];
      use[k] = labels[k] == Label::kInlier;
      Eigen::Vector2d r;
      if (use[k] && s.residual(obs[k], camera.fx, camera.fy, r)) sum2 += r.squaredNorm();
    }
    const std::vector<int> views = viewsPerPoint(obs, use, n_points);
    nlohmann::json point_status = nlohmann::json::array();
    int undetermined = 0;
    for (int j = 0; j < n_points; ++j) {
      point_status.push_back(views[j] >= 2 ? "ok" : "undetermined");
      undetermined += views[j] < 2;
    }
    const int inliers = count[static_cast<int>(Label::kInlier)];
    if (inliers < static_cast<int>(obs.size()))
      warn(fmt::format(
          "BundleAdjustment: of {} observations, {} are outliers, {} behind the camera, {} "
          "unverified; {} of {} points undetermined",
          obs.size(), count[static_cast<int>(Label::kOutlier)],
          count[static_cast<int>(Label::kBehind)], count[static_cast<int>(Label::kUnverified)],
          undetermined, n_points));
    if (solve.summary.termination_type == ceres::NO_CONVERGENCE)
      warn(fmt::format("BundleAdjustment: no convergence in max_iterations = {} ({})",
                       params_.max_iterations, solve.summary.message));
    PoseArray poses;
    poses.stamp = in.poses->stamp;
    poses.frame_id = in.poses->frame_id;
    for (int i = 0; i < n_poses; ++i) {
      Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
      pose.linear() = s.rotation[i].normalized().toRotationMatrix();
      pose.translation() = s.centreOf(i);
      poses.poses.push_back(i < held_ ? in.poses->poses[i] : pose);
    }
    std::vector<Eigen::Vector3f> points;
    for (const Eigen::Vector3d& x : s.points) points.push_back(x.cast<float>());
    out.poses.set(std::move(poses));
    out.points.set(PointCloud::fromXyz(points, in.points->frame_id, in.points->stamp));
    out.status.set(std::move(status));
    out.point_status.set(std::move(point_status));
    out.inlier_count.set(inliers);
    out.rms_error.set(inliers > 0 ? std::sqrt(sum2 / (2.0 * inliers)) : 0.0);
    if (params_.compute_covariance) out.pose_covariance.set(std::move(covariance));
    return Status::ok();
  }

  /// One Levenberg-Marquardt solve of the observations in `use`, updating `s`: with the robust
  /// loss at `scale` px, or plain least squares when `scale` is 0.
  Result<Solve> solveOnce(State& s, const std::vector<Observation>& obs,
                          const std::vector<char>& use, const CameraModel& camera, double scale) {
    const Parameters& p = params_;
    const int n_poses = static_cast<int>(s.rotation.size());
    const int n_points = static_cast<int>(s.points.size());
    Solve out;
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    out.problem = std::make_unique<ceres::Problem>(problem_options);
    ceres::Problem& problem = *out.problem;
    ceres::LossFunction* loss = nullptr;
    if (scale > 0) {
      loss_.reset(p.loss == "cauchy"
                      ? static_cast<ceres::LossFunction*>(new ceres::CauchyLoss(scale))
                      : new ceres::HuberLoss(scale));
      loss = loss_.get();
    }
    std::vector<char> pose_used(n_poses, 0), point_used(n_points, 0);
    for (std::size_t k = 0; k < obs.size(); ++k) {
      if (!use[k]) continue;
      const Observation& o = obs[k];
      const bool sphere = s.on_sphere && o.camera == 1;
      double* centre = sphere ? s.direction.data() : s.centre[o.camera].data();
      auto* cost = new Reprojection(o.ray, camera.fx, camera.fy, sphere, s.centre[0],
                                    sphere ? s.radius : 0.0);
      problem.AddResidualBlock(cost, loss, s.rotation[o.camera].coeffs().data(), centre,
                               s.points[o.point].data());
      pose_used[o.camera] = point_used[o.point] = 1;
      ++out.residuals;
    }
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    int free_poses = 0;
    for (int i = 0; i < n_poses; ++i) {
      if (!pose_used[i]) continue;
      double* q = s.rotation[i].coeffs().data();
      double* c = s.on_sphere && i == 1 ? s.direction.data() : s.centre[i].data();
      problem.SetManifold(q, &quaternion_);
      if (s.on_sphere && i == 1) problem.SetManifold(c, &sphere_);
      if (i < held_) {
        problem.SetParameterBlockConstant(q);
        problem.SetParameterBlockConstant(c);
      } else {
        ++free_poses;
        out.parameters += s.on_sphere && i == 1 ? 5 : 6;
      }
      ordering->AddElementToGroup(q, 1);
      ordering->AddElementToGroup(c, 1);
    }
    for (int j = 0; j < n_points; ++j) {
      if (!point_used[j]) continue;
      out.parameters += 3;  // every point in the problem is seen from 2 poses (markSingleViews)
      ordering->AddElementToGroup(s.points[j].data(), 0);
    }
    ceres::Solver::Options options;
    options.linear_solver_type =
        free_poses <= p.max_dense_poses ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
    options.linear_solver_ordering = ordering;
    options.max_num_iterations = p.max_iterations;
    options.num_threads = p.threads;
    options.logging_type = ceres::SILENT;
    options.minimizer_progress_to_stdout = false;
    ceres::Solve(options, &problem, &out.summary);
    if (!out.summary.IsSolutionUsable())
      return numericalFailure("BundleAdjustment: Ceres failed on {} observations: {}",
                              out.residuals, out.summary.message);
    for (Eigen::Quaterniond& q : s.rotation) q.normalize();
    return out;
  }

  /// sigma^2 (J^T J)^-1 of each free pose, [dt, dtheta] in the world frame, from Ceres'
  /// Covariance over the tangent spaces: the quaternion manifold's delta is half the rotation
  /// vector applied on the left (dtheta = 2 delta, in the world frame for world_q_camera), the
  /// sphere's maps to the centre through radius times its Plus Jacobian.
  Result<nlohmann::json> poseCovariance(State& s, Solve& solve, int n_poses) {
    const int dof = 2 * solve.residuals - solve.parameters;
    if (dof <= 0)
      return numericalFailure(
          "BundleAdjustment: {} inlier residuals for {} parameters: no covariance",
          2 * solve.residuals, solve.parameters);
    const double sigma2 = 2.0 * solve.summary.final_cost / dof;
    ceres::Covariance::Options options;
    options.algorithm_type = ceres::SPARSE_QR;
    options.num_threads = params_.threads;
    ceres::Covariance covariance(options);
    std::vector<std::pair<const double*, const double*>> blocks;
    for (int i = held_; i < n_poses; ++i) {
      const double* q = s.rotation[i].coeffs().data();
      const double* c = s.on_sphere && i == 1 ? s.direction.data() : s.centre[i].data();
      if (!solve.problem->HasParameterBlock(q)) continue;
      blocks.emplace_back(q, q);
      blocks.emplace_back(c, c);
      blocks.emplace_back(c, q);
    }
    if (!covariance.Compute(blocks, solve.problem.get()))
      return numericalFailure(
          "BundleAdjustment: Ceres' Covariance failed (the poses are not determined by the "
          "inliers: J^T J singular)");
    nlohmann::json out = nlohmann::json::array();
    for (int i = 0; i < n_poses; ++i) {
      Matrix6d cov = Matrix6d::Zero();
      const double* q = s.rotation[i].coeffs().data();
      if (i >= held_ && solve.problem->HasParameterBlock(q)) {
        const bool sphere = s.on_sphere && i == 1;
        const double* c = sphere ? s.direction.data() : s.centre[i].data();
        const int tc = sphere ? 2 : 3;
        Eigen::Matrix<double, 3, 3, Eigen::RowMajor> cqq;
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> ccc(tc, tc),
            ccq(tc, 3);
        covariance.GetCovarianceBlockInTangentSpace(q, q, cqq.data());
        covariance.GetCovarianceBlockInTangentSpace(c, c, ccc.data());
        covariance.GetCovarianceBlockInTangentSpace(c, q, ccq.data());
        Eigen::MatrixXd tangent(tc + 3, tc + 3);
        tangent << ccc, ccq, ccq.transpose(), cqq;
        Eigen::MatrixXd a = Eigen::MatrixXd::Zero(6, tc + 3);
        if (sphere) {
          Eigen::Matrix<double, 3, 2, Eigen::RowMajor> plus;
          sphere_.PlusJacobian(c, plus.data());
          a.topLeftCorner(3, 2) = s.radius * plus;
        } else {
          a.topLeftCorner(3, 3).setIdentity();
        }
        a.bottomRightCorner(3, 3) = 2.0 * Eigen::Matrix3d::Identity();
        cov = sigma2 * a * tangent * a.transpose();
        cov = (0.5 * (cov + cov.transpose())).eval();
      }
      nlohmann::json rows = nlohmann::json::array();
      for (int r = 0; r < 6; ++r) {
        nlohmann::json row = nlohmann::json::array();
        for (int col = 0; col < 6; ++col) row.push_back(cov(r, col));
        rows.push_back(std::move(row));
      }
      out.push_back(std::move(rows));
    }
    return out;
  }

  int held_ = 1;
  std::unique_ptr<ceres::LossFunction> loss_;
  ceres::EigenQuaternionManifold quaternion_;
  ceres::SphereManifold<3> sphere_;
};

CDFF_REGISTER_DFI(BundleAdjustmentCeres);

}  // namespace cdff::dfn
