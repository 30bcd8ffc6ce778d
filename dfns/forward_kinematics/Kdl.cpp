// ForwardKinematics/Kdl: the URDF's chain (cdff/kinematics/arm_model.hpp) at the measured joints.
#include <filesystem>

#include "ForwardKinematics.gen.hpp"
#include "cdff/kinematics/arm_model.hpp"

namespace cdff::dfn {

class ForwardKinematicsKdl final : public ForwardKinematicsKdlBase {
 protected:
  // An empty description is a node not yet given its arm (the description's default, as a
  // graph sets it): configuring accepts it, processing refuses it.
  Status onConfigure() override {
    configured_ = false;
    if (params_.description.empty()) return Status::ok();
    Result<kinematics::ArmModel> arm =
        kinematics::ArmModel::load(params_.description, params_.base_link, params_.link);
    if (!arm) {
      std::string where;
      std::error_code ec;
      if (std::filesystem::path(params_.description).is_relative())
        where = " (a relative path: from the working directory '" +
                std::filesystem::current_path(ec).string() + "')";
      return Status(arm.status().code(),
                    "parameter 'description': " + arm.status().reason() + where,
                    arm.status().location());
    }
    arm_ = std::move(arm).value();
    configured_ = true;
    return Status::ok();
  }

  Status onProcess() override {
    if (!configured_)
      return invalidParameter(
          "parameter 'description' is empty: no arm to compute the pose of; expected the arm's "
          "URDF file");
    Result<std::vector<double>> q = arm_.positionsOf(*in.joints, "input 'joints'");
    if (!q) return q.status();
    CDFF_RETURN_IF_ERROR(
        arm_.checkJoints(*q, params_.limit_margin, "input 'joints'", params_.linear_limit_margin));
    out.pose.set(Transform::fromIsometry(arm_.forward(*q), params_.base_link, params_.link,
                                         in.joints->stamp));
    return Status::ok();
  }

 private:
  kinematics::ArmModel arm_;
  bool configured_ = false;
};

CDFF_REGISTER_DFI(ForwardKinematicsKdl);

}  // namespace cdff::dfn
