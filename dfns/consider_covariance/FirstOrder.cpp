#include <cmath>
#include <optional>

#include "ConsiderCovariance.gen.hpp"

namespace cdff::dfn {

class ConsiderCovarianceFirstOrder final : public ConsiderCovarianceFirstOrderBase {
 protected:
  Status onConfigure() override {
    if (params_.frame.empty())
      return invalidParameter("parameter 'frame' is empty; expected the sensor's frame");
    extrinsic_.reset();
    model_rms_radius_.reset();
    model_points_ = nullptr;
    systematic_.reset();
    return Status::ok();
  }

  Status onProcess() override {
    // Inputs are read when fresh, and also when kept while the instance slept (a DFPC keeps
    // but does not freshen the values an asleep instance receives, e.g. a latched mounting).
    if (in.extrinsic.hasValue() && (in.extrinsic.isFresh() || !extrinsic_) &&
        in.extrinsic->child_frame == params_.frame) {
      CDFF_RETURN_IF_ERROR(in.extrinsic->validate().withContext("input 'extrinsic'"));
      extrinsic_ = *in.extrinsic;
    }
    if (in.model.hasValue() && (in.model.isFresh() || !model_rms_radius_))
      CDFF_RETURN_IF_ERROR(readModel(*in.model));
    if (in.systematic.hasValue() && (in.systematic.isFresh() || !systematic_)) {
      CDFF_RETURN_IF_ERROR(in.systematic->validate().withContext("input 'systematic'"));
      systematic_ = *in.systematic;
    }
    if (!in.state.isFresh()) return Status::ok();
    CDFF_RETURN_IF_ERROR(in.state->validate().withContext("input 'state'"));
    if (!extrinsic_)
      return invalidInput(
          "no extrinsic with child frame '{}' yet; expected the sensor's calibration (e.g. "
          "/chaser/tf/{}) before the first state",
          params_.frame, params_.frame);
    if (in.state->pose.parent_frame != extrinsic_->parent_frame)
      return invalidInput(
          "input 'state' is {}_T_{}; expected a state in frame '{}', the parent "
          "of the extrinsic {}_T_{}",
          in.state->pose.parent_frame, in.state->pose.child_frame, extrinsic_->parent_frame,
          extrinsic_->parent_frame, extrinsic_->child_frame);
    if (params_.model_scale_sigma > 0 && !model_rms_radius_)
      return invalidInput(
          "model_scale_sigma is {} but no model arrived on input 'model'; expected the target's "
          "model point cloud (its extent is the lever arm of a scale error)",
          params_.model_scale_sigma);
    RigidBodyState out_state = *in.state;
    out_state.covariance.topLeftCorner<6, 6>() += considerCovariance(in.state->pose.translation);
    CDFF_RETURN_IF_ERROR(addSystematic(out_state));
    out.state.set(std::move(out_state));
    return Status::ok();
  }

 private:
  // The model node re-sends the same shared buffer every period: its extent is computed once.
  Status readModel(const PointCloud& model) {
    if (model_rms_radius_ && model.points.data() == model_points_) return Status::ok();
    if (model.empty())
      return invalidInput("input 'model' has no points; expected the target's model point cloud");
    CDFF_RETURN_IF_ERROR(model.validate("input 'model'"));
    model_rms_radius_ = std::sqrt(model.xyzMatrix().cast<double>().colwise().squaredNorm().mean());
    model_points_ = model.points.data();
    return Status::ok();
  }

  // The latest `systematic` covariance, when it applies to the state's time and frame.
  Status addSystematic(RigidBodyState& state) {
    if (!systematic_) return Status::ok();
    if (systematic_->pose.parent_frame != state.pose.parent_frame)
      return invalidInput(
          "input 'systematic' is {}_T_{}; expected a covariance in frame '{}', the state's "
          "parent",
          systematic_->pose.parent_frame, systematic_->pose.child_frame, state.pose.parent_frame);
    const double age_s = 1e-6 * static_cast<double>(state.pose.stamp - systematic_->pose.stamp);
    if (age_s > params_.systematic_max_age_s) {
      warn(fmt::format(
          "input 'systematic' is {:.2f} s older than the state (stamp {} us); expected at most "
          "{} s (systematic_max_age_s): not added",
          age_s, state.pose.stamp, params_.systematic_max_age_s));
      return Status::ok();
    }
    state.covariance.topLeftCorner<6, 6>() += systematic_->covariance;
    return Status::ok();
  }

  // The [dt, dtheta] covariance (parent frame) of the systematic errors at a target position.
  Matrix6d considerCovariance(const Eigen::Vector3d& target_position) const {
    const Eigen::Vector3d r = target_position - extrinsic_->translation;  // line of sight
    const Eigen::Matrix3d rx = skew(r);
    const double sa2 = params_.extrinsic_angle_sigma * params_.extrinsic_angle_sigma;
    const double st2 = params_.extrinsic_position_sigma * params_.extrinsic_position_sigma;
    Matrix6d c = Matrix6d::Zero();
    c.topLeftCorner<3, 3>() = st2 * Eigen::Matrix3d::Identity() + sa2 * rx * rx.transpose();
    c.topRightCorner<3, 3>() = -sa2 * rx;
    c.bottomLeftCorner<3, 3>() = c.topRightCorner<3, 3>().transpose();
    c.bottomRightCorner<3, 3>() = sa2 * Eigen::Matrix3d::Identity();
    c.topLeftCorner<3, 3>() +=
        params_.range_scale_sigma * params_.range_scale_sigma * r * r.transpose();
    if (model_rms_radius_) {
      const double s = params_.model_scale_sigma * *model_rms_radius_;
      c.topLeftCorner<3, 3>() += s * s * Eigen::Matrix3d::Identity();
    }
    return c;
  }

  std::optional<Transform> extrinsic_;
  std::optional<PoseWithCovariance> systematic_;
  std::optional<double> model_rms_radius_;
  const Point4f* model_points_ = nullptr;  // the buffer model_rms_radius_ was computed from
};

CDFF_REGISTER_DFI(ConsiderCovarianceFirstOrder);

}  // namespace cdff::dfn
