// The only translation unit of this area that includes PCL's registration headers (slow to
// compile): keep it that way.
#include <cmath>
#include <limits>

#include <pcl/console/print.h>
#include <pcl/registration/correspondence_rejection_median_distance.h>
#include <pcl/registration/correspondence_rejection_surface_normal.h>
#include <pcl/registration/icp.h>
#include <pcl/search/kdtree.h>

#include "Registration3D.gen.hpp"
#include "cdff/registration/model_index.hpp"
#include "cdff/registration/quality.hpp"
#include "cdff/types/pcl.hpp"
#include "registration_ports.hpp"

namespace cdff::dfn {

class Registration3DPclIcpPointToPlane final : public Registration3DPclIcpPointToPlaneBase {
 public:
  Registration3DPclIcpPointToPlane() {
    // PCL prints "not enough correspondences" to stderr; this DFI reports it as a warning.
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  }

 protected:
  Status onConfigure() override {
    icp_.setMaxCorrespondenceDistance(params_.max_correspondence_distance);
    icp_.setMaximumIterations(params_.max_iterations);
    // PCL compares the squared translation and the cosine of the rotation angle of each step.
    icp_.setTransformationEpsilon(params_.translation_epsilon * params_.translation_epsilon);
    icp_.setTransformationRotationEpsilon(std::cos(params_.rotation_epsilon));
    // Fewer pairs (after the rejectors) end the iterations, as the DFN documents, before a
    // least-squares step on a handful of pairs turns the pose into NaN.
    icp_.setMinCorrespondences(params_.min_correspondences);
    // PCL's rejectors, applied in this order to each iteration's correspondences.
    icp_.clearCorrespondenceRejectors();
    if (params_.back_face_rejection) {
      // The scan's "normals" are the directions towards the sensor (set per call): a pair is
      // kept when the model normal has a positive cosine with it, i.e. faces the sensor.
      auto facing = std::make_shared<pcl::registration::CorrespondenceRejectorSurfaceNormal>();
      facing->setThreshold(0.0);
      icp_.addCorrespondenceRejector(facing);
    }
    if (params_.median_rejection_factor > 0) {
      // PCL's pair distances are squared distances, and so is the median it compares them to.
      auto median = std::make_shared<pcl::registration::CorrespondenceRejectorMedianDistance>();
      median->setMedianFactor(params_.median_rejection_factor * params_.median_rejection_factor);
      icp_.addCorrespondenceRejector(median);
    }
    return Status::ok();
  }

  Status onProcess() override {
    const PointCloud& model = *in.model;
    if (!index_.holds(model)) {
      CDFF_RETURN_IF_ERROR(index_.update(model));
      Result<pcl::PointCloud<pcl::PointNormal>::Ptr> target = toPclWithNormals(model);
      if (!target) return target.status();
      target_ = std::move(target).value();
      tree_ = std::make_shared<pcl::search::KdTree<pcl::PointNormal>>();
      tree_->setInputCloud(target_);
      icp_.setInputTarget(target_);
      icp_.setSearchMethodTarget(tree_, true);  // built once, here
    }
    // Without a new scan the call only prepares the model (see the DFN's `source`).
    if (!in.source.isFresh()) return Status::ok();
    const PointCloud& source = *in.source;
    Result<Eigen::Isometry3d> guess =
        registration3d::checkInputs(source, model, in.sensor.get(), in.initial_guess.get());
    if (!guess) return guess.status();
    registration3d::selectSource(source, 0, points_);
    icp_.setInputSource(scanCloud());
    // PCL estimates model_T_source (it moves the source onto the target).
    const Eigen::Matrix4f model_T_source = guess->inverse().matrix().cast<float>();
    icp_.align(aligned_, model_T_source);
    using Criteria = pcl::registration::DefaultConvergenceCriteria<float>;
    const auto state = icp_.getConvergeCriteria()->getConvergenceState();
    const bool converged = state == Criteria::CONVERGENCE_CRITERIA_TRANSFORM ||
                           state == Criteria::CONVERGENCE_CRITERIA_ABS_MSE ||
                           state == Criteria::CONVERGENCE_CRITERIA_REL_MSE;
    Eigen::Isometry3d pose = *guess;
    const Eigen::Matrix4d result = icp_.getFinalTransformation().cast<double>();
    if (state == Criteria::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES || !result.allFinite()) {
      warn(fmt::format(
          "PCL ICP kept fewer than min_correspondences = {} correspondences within {:.3g} m "
          "among {} source points{}: no overlap with the model",
          params_.min_correspondences, params_.max_correspondence_distance, points_.size(),
          rejecting() ? " after its rejectors" : ""));
    } else {
      Eigen::Isometry3d m_T_s = Eigen::Isometry3d::Identity();
      // Re-orthonormalise: PCL composes single-precision steps.
      m_T_s.linear() = Eigen::Quaterniond(Eigen::Matrix3d(result.topLeftCorner<3, 3>()))
                           .normalized()
                           .toRotationMatrix();
      m_T_s.translation() = result.topRightCorner<3, 1>();
      pose = m_T_s.inverse();
    }
    const registration::Quality quality = registration::evaluate(
        points_, index_, pose, params_.inlier_distance, params_.covariance_inflation);
    const bool enough = quality.inliers >= static_cast<std::size_t>(params_.min_correspondences);
    if (!enough && state != Criteria::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES)
      warn(fmt::format(
          "only {} source points of {} within inlier_distance {:.3g} m of the model "
          "at the final pose; expected at least min_correspondences = {}",
          quality.inliers, points_.size(), params_.inlier_distance, params_.min_correspondences));
    registration3d::publish(out, source, model, pose, quality, converged && enough,
                            icp_.nr_iterations_);
    out.ambiguous.set(false);
    out.visibility.set(std::numeric_limits<double>::quiet_NaN());  // FastIcp's check only
    return Status::ok();
  }

 private:
  bool rejecting() const {
    return params_.back_face_rejection || params_.median_rejection_factor > 0;
  }

  // The scan as PCL's source cloud. The point-to-plane error uses the model's normals only; the
  // scan's carry the direction towards the sensor for back_face_rejection (zero without it).
  pcl::PointCloud<pcl::PointNormal>::Ptr scanCloud() const {
    auto scan = std::make_shared<pcl::PointCloud<pcl::PointNormal>>();
    scan->resize(points_.size());
    const Eigen::Vector3f eye(static_cast<float>(params_.viewpoint[0]),
                              static_cast<float>(params_.viewpoint[1]),
                              static_cast<float>(params_.viewpoint[2]));
    for (std::size_t i = 0; i < points_.size(); ++i) {
      pcl::PointNormal& p = (*scan)[i];
      p.getVector3fMap() = points_[i];
      p.getNormalVector3fMap() = params_.back_face_rejection
                                     ? Eigen::Vector3f((eye - points_[i]).normalized())
                                     : Eigen::Vector3f::Zero();
    }
    return scan;
  }

  // nr_iterations_ and min_number_correspondences_ are protected in PCL; this subclass exposes
  // them.
  struct Icp : pcl::IterativeClosestPointWithNormals<pcl::PointNormal, pcl::PointNormal, float> {
    using pcl::IterativeClosestPointWithNormals<pcl::PointNormal, pcl::PointNormal,
                                                float>::nr_iterations_;
    void setMinCorrespondences(int n) { min_number_correspondences_ = static_cast<unsigned>(n); }
  };

  Icp icp_;
  registration::ModelIndex index_;  // for the shared quality measures
  pcl::PointCloud<pcl::PointNormal>::Ptr target_;
  pcl::search::KdTree<pcl::PointNormal>::Ptr tree_;
  pcl::PointCloud<pcl::PointNormal> aligned_;
  std::vector<Eigen::Vector3f> points_;
};

CDFF_REGISTER_DFI(Registration3DPclIcpPointToPlane);

}  // namespace cdff::dfn
