#pragma once
// Proprioceptive samples: IMU, force/torque, joints.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff {

struct ImuSample {
  Timestamp stamp = 0;
  std::string frame_id;  // the IMU's body frame
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();     // rad/s
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();  // specific force, m/s^2
  Eigen::Matrix3d angular_velocity_covariance = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d linear_acceleration_covariance = Eigen::Matrix3d::Zero();

  Status validate() const;
};

/// Force and torque acting at the origin of frame_id, expressed in frame_id.
struct Wrench {
  Timestamp stamp = 0;
  std::string frame_id;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   // N
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();  // N m

  Status validate() const;
};

struct JointState {
  Timestamp stamp = 0;
  std::vector<std::string> names;
  std::vector<double> position;  // rad or m
  std::vector<double> velocity;  // rad/s or m/s, or empty
  std::vector<double> effort;    // N m or N, or empty

  Status validate() const;
};

}  // namespace cdff
