// OctomapUpdate/OcTree: contacts placed in the target's frame and accumulated in octomap's OcTree
// (occupancy as the confidence) with the per-voxel sums in a map beside it.
#include <octomap/OcTree.h>

#include <cmath>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "OctomapUpdate.gen.hpp"

namespace cdff::dfn {

namespace {

/// A unit normal's norm may be off by float rounding and by the estimator's own normalisation;
/// anything farther is not a normal.
constexpr double kUnitTolerance = 1e-3;

struct Voxel {
  octomap::OcTreeKey key;
  Eigen::Vector3d point_sum = Eigen::Vector3d::Zero();   // target frame, m
  Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();  // of unit normals
  double force_sum = 0;                                  // N
  std::uint64_t count = 0;                               // contact samples
};

}  // namespace

class OctomapUpdateOcTree final : public OctomapUpdateOcTreeBase {
 protected:
  Status onConfigure() override {
    tree_ = std::make_unique<octomap::OcTree>(params_.resolution);
    tree_->setProbHit(params_.hit_probability);
    voxels_.clear();
    index_.clear();
    last_output_.reset();
    return Status::ok();
  }

  Status onProcess() override {
    // Triggered by a pose alone, the last contact has already been inserted.
    if (!in.contact.isFresh()) return Status::ok();
    const PointCloud& contact = *in.contact;
    CDFF_RETURN_IF_ERROR(checkContact(contact));
    Result<Eigen::Isometry3d> target_T_sensor = targetTSensor(contact);
    if (!target_T_sensor) return target_T_sensor.status();
    // Every point is checked before any is inserted: a rejected cloud leaves the map as it was.
    std::vector<octomap::OcTreeKey> keys(contact.size());
    for (std::size_t i = 0; i < contact.size(); ++i) {
      const Eigen::Vector3d p = *target_T_sensor * contact.points[i].vec().cast<double>();
      if (!tree_->coordToKeyChecked(p.x(), p.y(), p.z(), keys[i]))
        return invalidInput(
            "input 'contact' point {} at ({:.3f}, {:.3f}, {:.3f}) m in the target frame is outside "
            "the octree's range (+-{:.1f} m at resolution {} m); expected a contact on the target",
            i, p.x(), p.y(), p.z(), 32768 * params_.resolution, params_.resolution);
    }
    bool created = false;
    for (std::size_t i = 0; i < contact.size(); ++i) {
      tree_->updateNode(keys[i], true);
      const auto [it, inserted] = index_.try_emplace(keys[i], voxels_.size());
      if (inserted) voxels_.push_back(Voxel{keys[i]});
      created = created || inserted;
      Voxel& v = voxels_[it->second];
      v.point_sum += *target_T_sensor * contact.points[i].vec().cast<double>();
      v.normal_sum += target_T_sensor->linear() * contact.normals[i].vec().cast<double>();
      v.force_sum += contact.intensity[i];
      ++v.count;
    }
    const bool due =
        !last_output_ || toSeconds(contact.stamp - *last_output_) >= params_.output_period;
    if (created || due) publish(contact.stamp);
    return Status::ok();
  }

 private:
  Status checkContact(const PointCloud& contact) const {
    CDFF_RETURN_IF_ERROR(contact.validate("input 'contact'"));
    if (!contact.hasNormals() || contact.intensity.empty())
      return invalidInput(
          "input 'contact' ({} points at {} us) has {}; expected each contact's normal and its "
          "normal force as intensity (ContactDetection's output)",
          contact.size(), contact.stamp, contact.hasNormals() ? "no intensity" : "no normals");
    for (std::size_t i = 0; i < contact.size(); ++i) {
      const double norm = contact.normals[i].vec().cast<double>().norm();
      if (!(std::abs(norm - 1) <= kUnitTolerance))
        return invalidInput(
            "input 'contact' point {} at {} us has a normal of norm {}; expected a unit normal", i,
            contact.stamp, norm);
      if (!(std::isfinite(contact.intensity[i]) && contact.intensity[i] >= 0))
        return invalidInput(
            "input 'contact' point {} at {} us has a normal force (intensity) of {} N; expected "
            "a finite force >= 0 (a contact pushes)",
            i, contact.stamp, contact.intensity[i]);
    }
    return Status::ok();
  }

  /// target_T_sensor at the contact's stamp from the two poses, their frames and stamps checked.
  Result<Eigen::Isometry3d> targetTSensor(const PointCloud& contact) const {
    const Transform& sensor = *in.sensor_pose;
    const Transform& target = in.target_pose->pose;
    CDFF_RETURN_IF_ERROR(sensor.validate().withContext("input 'sensor_pose'"));
    CDFF_RETURN_IF_ERROR(in.target_pose->validate().withContext("input 'target_pose'"));
    if (sensor.child_frame != contact.frame_id)
      return invalidInput(
          "input 'sensor_pose' is {}_T_{} but input 'contact' is in frame '{}'; expected the pose "
          "of the contact's frame",
          sensor.parent_frame, sensor.child_frame, contact.frame_id);
    if (target.parent_frame != sensor.parent_frame)
      return invalidInput(
          "input 'target_pose' is {}_T_{} but input 'sensor_pose' is {}_T_{}; expected both in "
          "the arm's base frame '{}'",
          target.parent_frame, target.child_frame, sensor.parent_frame, sensor.child_frame,
          sensor.parent_frame);
    const double sensor_offset = std::abs(toSeconds(contact.stamp - sensor.stamp));
    if (sensor_offset > params_.max_sensor_pose_offset + 1e-9)
      return invalidInput(
          "input 'sensor_pose' is stamped {} us, {:.4f} s from the contact at {} us; expected "
          "within max_sensor_pose_offset = {} s",
          sensor.stamp, sensor_offset, contact.stamp, params_.max_sensor_pose_offset);
    const double age = toSeconds(contact.stamp - target.stamp);
    if (age > params_.max_target_pose_age + 1e-9 || age < -params_.max_sensor_pose_offset - 1e-9)
      return invalidInput(
          "input 'target_pose' is stamped {} us, {:.4f} s before the contact at {} us; expected "
          "a pose at most max_target_pose_age = {} s old: no contact is placed without the "
          "target's pose",
          target.stamp, age, contact.stamp, params_.max_target_pose_age);
    return Eigen::Isometry3d(target.isometry().inverse() * sensor.isometry());
  }

  void publish(Timestamp stamp) {
    std::vector<Point4f> points, normals;
    std::vector<float> forces;
    for (const Voxel& v : voxels_) {
      const octomap::OcTreeNode* node = tree_->search(v.key);
      if (node == nullptr || node->getOccupancy() < params_.min_confidence) continue;
      const Eigen::Vector3d p = v.point_sum / static_cast<double>(v.count);
      // The mean of unit normals points along their mean direction; a voxel's contacts have
      // normals within degrees of each other, so its norm is near 1 and never 0.
      const Eigen::Vector3d n = v.normal_sum.normalized();
      points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()),
                          static_cast<float>(p.z()));
      normals.emplace_back(static_cast<float>(n.x()), static_cast<float>(n.y()),
                           static_cast<float>(n.z()));
      forces.push_back(static_cast<float>(v.force_sum / static_cast<double>(v.count)));
    }
    out.voxels.set(static_cast<int>(voxels_.size()));
    last_output_ = stamp;
    if (points.empty()) return;  // no voxel is confident enough yet
    PointCloud cloud;
    cloud.stamp = stamp;
    cloud.frame_id = in.target_pose->pose.child_frame;
    cloud.points = Buffer<Point4f>::fromVector(std::move(points));
    cloud.normals = Buffer<Point4f>::fromVector(std::move(normals));
    cloud.intensity = Buffer<float>::fromVector(std::move(forces));
    out.contacts.set(std::move(cloud));
  }

  std::unique_ptr<octomap::OcTree> tree_;
  std::vector<Voxel> voxels_;  // in the order they were created
  std::unordered_map<octomap::OcTreeKey, std::size_t, octomap::OcTreeKey::KeyHash> index_;
  std::optional<Timestamp> last_output_;
};

CDFF_REGISTER_DFI(OctomapUpdateOcTree);

}  // namespace cdff::dfn
