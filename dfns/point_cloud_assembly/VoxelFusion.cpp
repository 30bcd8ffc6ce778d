// PointCloudAssembly/VoxelFusion: a confidence-weighted voxel map in the model frame, kept
// between calls; each voxel's output point is the weighted mean of its supported 3x3x3
// neighbourhood.
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "PointCloudAssembly.gen.hpp"
#include "assembly_common.hpp"
#include "cdff/types/kd_tree.hpp"

namespace cdff::dfn {

namespace {

struct Voxel {
  std::uint64_t key = 0;
  Eigen::Vector3d weighted_points = Eigen::Vector3d::Zero();   // sum of w p, model frame
  Eigen::Vector3d weighted_normals = Eigen::Vector3d::Zero();  // sum of w n (unit normals)
  double weight = 0;                                           // sum of w, 1/m^2
  std::uint32_t count = 0;                                     // points fused
  std::uint32_t frames = 0;                                    // distinct frames among them
  std::uint32_t last_frame = std::numeric_limits<std::uint32_t>::max();
};

/// Voxel keys to indices into a vector of voxels: open addressing with linear probing, grown
/// (rehashed) to keep the load at most one half.
class VoxelIndex {
 public:
  static constexpr std::uint32_t kAbsent = std::numeric_limits<std::uint32_t>::max();

  void clear() {
    keys_.assign(kInitialCapacity, kEmpty);
    slots_.assign(kInitialCapacity, kAbsent);
    size_ = 0;
  }
  std::uint32_t find(std::uint64_t key) const {
    for (std::size_t s = home(key);; s = (s + 1) & mask()) {
      if (keys_[s] == key) return slots_[s];
      if (keys_[s] == kEmpty) return kAbsent;
    }
  }
  /// The index of `key`, or `next` (inserted) when it is new.
  std::uint32_t findOrInsert(std::uint64_t key, std::uint32_t next) {
    if (2 * (size_ + 1) > keys_.size()) grow();
    std::size_t s = home(key);
    while (keys_[s] != kEmpty && keys_[s] != key) s = (s + 1) & mask();
    if (keys_[s] == key) return slots_[s];
    keys_[s] = key;
    slots_[s] = next;
    ++size_;
    return next;
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  static constexpr std::size_t kInitialCapacity = 1024;

  std::size_t mask() const { return keys_.size() - 1; }
  std::size_t home(std::uint64_t key) const {
    // Fibonacci hashing: the product's top bits.
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >>
                                    (64 - std::countr_zero(keys_.size())));
  }
  void grow() {
    std::vector<std::uint64_t> keys(2 * keys_.size(), kEmpty);
    std::vector<std::uint32_t> slots(keys.size(), kAbsent);
    keys.swap(keys_);
    slots.swap(slots_);
    for (std::size_t i = 0; i < keys.size(); ++i) {
      if (keys[i] == kEmpty) continue;
      std::size_t s = home(keys[i]);
      while (keys_[s] != kEmpty) s = (s + 1) & mask();
      keys_[s] = keys[i];
      slots_[s] = slots[i];
    }
  }

  std::vector<std::uint64_t> keys_ = std::vector<std::uint64_t>(kInitialCapacity, kEmpty);
  std::vector<std::uint32_t> slots_ = std::vector<std::uint32_t>(kInitialCapacity, kAbsent);
  std::size_t size_ = 0;
};

/// The variance of a point's position that the pose's covariance gives, per axis (a third of
/// the trace of J S J^T, J = [I, -[a]x] for a = model_R_s p_s: t = t^ + dt, R = exp(dtheta) R^),
/// as a quadratic in a: trace = t0 + b.a + a^T C a.
struct PoseVariance {
  double t0 = 0;
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();

  explicit PoseVariance(const Matrix6d& s) {
    const Eigen::Matrix3d tt = s.topLeftCorner<3, 3>();
    const Eigen::Matrix3d rt = s.bottomLeftCorner<3, 3>();  // cov(dtheta, dt)
    const Eigen::Matrix3d rr = s.bottomRightCorner<3, 3>();
    t0 = tt.trace();
    // -2 trace([a]x rt) = -2 a . (rt12 - rt21, rt20 - rt02, rt01 - rt10)
    b = -2 * Eigen::Vector3d(rt(1, 2) - rt(2, 1), rt(2, 0) - rt(0, 2), rt(0, 1) - rt(1, 0));
    // trace([a]x rr [a]x^T) = |a|^2 trace(rr) - a^T rr a
    c = rr.trace() * Eigen::Matrix3d::Identity() - rr;
  }
  double perAxis(const Eigen::Vector3d& a) const { return (t0 + b.dot(a) + a.dot(c * a)) / 3; }
};

}  // namespace

class PointCloudAssemblyVoxelFusion final : public PointCloudAssemblyVoxelFusionBase {
 protected:
  Status onConfigure() override {
    if (!(params_.range_sigma_constant > 0 || params_.range_sigma_quadratic > 0))
      return invalidParameter(
          "parameters 'range_sigma_constant' and 'range_sigma_quadratic' are both 0; expected "
          "the sensor's range noise model (a point's weight is 1 / sigma^2)");
    clear();
    return Status::ok();
  }

  Status onProcess() override {
    const bool resetting = in.reset.isFresh() && *in.reset;
    const PointCloud& cloud = *in.cloud;
    const PoseWithCovariance& pose = *in.pose;
    CDFF_RETURN_IF_ERROR(assembly::checkInputs(cloud, pose, resetting ? std::string() : frame_,
                                               params_.max_pose_offset));
    CDFF_RETURN_IF_ERROR(prepare(cloud, pose));
    if (resetting) clear();
    fuse(cloud);
    publish(cloud);
    return Status::ok();
  }

 private:
  void clear() {
    voxels_.clear();
    index_.clear();
    frame_.clear();
    frames_ = 0;
    points_ = 0;
    all_normals_ = true;
  }

  /// Places the cloud's usable points in the model frame with their keys and weights (scratch),
  /// without touching the map: an error leaves it as it was.
  Status prepare(const PointCloud& cloud, const PoseWithCovariance& pose) {
    const Eigen::Matrix3d rotation = pose.pose.rotation.toRotationMatrix();
    const Eigen::Vector3d& translation = pose.pose.translation;
    const PoseVariance pose_variance(pose.covariance);
    const double inverse = 1.0 / params_.voxel_size;
    const bool normals = cloud.hasNormals();
    keys_.clear();
    points_scratch_.clear();
    normals_scratch_.clear();
    weights_.clear();
    skipped_ = 0;
    wide_ = 0;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Point4f& p = cloud.points[i];
      const double range = p.vec().cast<double>().norm();
      // A point at the sensor's origin is the "no return" some drivers write as zeros.
      if (!assembly::isFinite(p) || range == 0 ||
          (normals && !assembly::isFinite(cloud.normals[i]))) {
        ++skipped_;
        continue;
      }
      const Eigen::Vector3d a = rotation * p.vec().cast<double>();
      const Eigen::Vector3d m = a + translation;
      const std::optional<std::uint64_t> key = assembly::voxelKey(m, inverse);
      if (!key)
        return invalidInput(
            "input 'cloud' point {} at ({:.3f}, {:.3f}, {:.3f}) m in the model frame is more "
            "than 2^20 voxels of {} m from its origin; expected a point on the target",
            i, m.x(), m.y(), m.z(), params_.voxel_size);
      const double sigma =
          params_.range_sigma_constant + params_.range_sigma_quadratic * range * range;
      wide_ += sigma > 0.5 * params_.voxel_size;
      keys_.push_back(*key);
      points_scratch_.push_back(m);
      weights_.push_back(1.0 / (sigma * sigma + std::max(0.0, pose_variance.perAxis(a))));
      if (normals) normals_scratch_.push_back(rotation * cloud.normals[i].vec().cast<double>());
    }
    return Status::ok();
  }

  void fuse(const PointCloud& cloud) {
    assembly::warnSkipped(cloud, skipped_, [this](std::string m) { warn(std::move(m)); });
    if (wide_ > 0)
      warn(fmt::format(
          "input 'cloud' at {} us: {} of {} points have a range sigma above half a voxel "
          "({} m): their noise spreads beyond the averaging neighbourhood",
          cloud.stamp, wide_, cloud.size(), 0.5 * params_.voxel_size));
    if (keys_.empty()) return;
    if (frame_.empty()) frame_ = in.pose->pose.parent_frame;
    all_normals_ = all_normals_ && cloud.hasNormals();
    for (std::size_t j = 0; j < keys_.size(); ++j) {
      const auto next = static_cast<std::uint32_t>(voxels_.size());
      const std::uint32_t v = index_.findOrInsert(keys_[j], next);
      if (v == next) voxels_.push_back(Voxel{.key = keys_[j]});
      Voxel& voxel = voxels_[v];
      voxel.weighted_points += weights_[j] * points_scratch_[j];
      if (!normals_scratch_.empty()) voxel.weighted_normals += weights_[j] * normals_scratch_[j];
      voxel.weight += weights_[j];
      ++voxel.count;
      if (voxel.last_frame != frames_) {
        voxel.last_frame = frames_;
        ++voxel.frames;
      }
    }
    ++frames_;
    points_ += keys_.size();
  }

  void publish(const PointCloud& cloud) {
    // State of each voxel: 0 unsupported, 1 supported, 2 supported and its neighbourhood's
    // mean inside it.
    state_.assign(voxels_.size(), 0);
    for (std::size_t v = 0; v < voxels_.size(); ++v)
      state_[v] = voxels_[v].frames >= static_cast<std::uint32_t>(params_.min_observations);
    const double inverse = 1.0 / params_.voxel_size;
    supported_.clear();
    for (std::size_t v = 0; v < voxels_.size(); ++v) {
      if (!state_[v]) continue;
      Eigen::Vector3d points = Eigen::Vector3d::Zero(), normals = Eigen::Vector3d::Zero();
      double weight = 0;
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const std::uint32_t n = index_.find(assembly::neighbourKey(voxels_[v].key, dx, dy, dz));
            if (n == VoxelIndex::kAbsent || state_[n] == 0) continue;
            points += voxels_[n].weighted_points;
            normals += voxels_[n].weighted_normals;
            weight += voxels_[n].weight;
          }
      const Eigen::Vector3d mean = points / weight;
      // Within the neighbourhood, so within the key's range.
      const std::uint64_t key = assembly::voxelKey(mean, inverse).value_or(0);
      if (key == voxels_[v].key) state_[v] = 2;
      supported_.push_back({static_cast<std::uint32_t>(v), key, mean, normals});
    }
    std::vector<Point4f> out_points, out_normals;
    for (const Supported& s : supported_) {
      if (state_[s.voxel] != 2) {
        // The patch is output by the voxel its mean lies in when that one's own mean is in it.
        const std::uint32_t holder = index_.find(s.mean_key);
        if (holder != VoxelIndex::kAbsent && state_[holder] == 2) continue;
      }
      out_points.emplace_back(static_cast<float>(s.mean.x()), static_cast<float>(s.mean.y()),
                              static_cast<float>(s.mean.z()));
      if (all_normals_) {
        const Eigen::Vector3d n = s.normals.normalized();
        out_normals.emplace_back(static_cast<float>(n.x()), static_cast<float>(n.y()),
                                 static_cast<float>(n.z()));
      }
    }
    PointCloud assembled;
    assembled.stamp = cloud.stamp;
    assembled.frame_id = frame_.empty() ? in.pose->pose.parent_frame : frame_;
    assembled.points = Buffer<Point4f>::fromVector(std::move(out_points));
    if (all_normals_ && frames_ > 0)
      assembled.normals = Buffer<Point4f>::fromVector(std::move(out_normals));
    assembly::Statistics stats;
    stats.frames = frames_;
    stats.points = points_;
    stats.skipped_points = skipped_;
    stats.voxels = voxels_.size();
    stats.supported_voxels = supported_.size();
    const std::size_t before = assembled.size();
    if (params_.outlier_neighbours > 0 && assembled.size() > 1)
      assembled = removeOutliers(assembled);
    stats.outliers_removed = before - assembled.size();
    stats.output_points = assembled.size();
    out.assembled.set(std::move(assembled));
    out.statistics.set(stats.toJson());
  }

  /// Drops the points whose mean distance to their k nearest neighbours exceeds the mean of all
  /// by more than outlier_std_ratio standard deviations.
  PointCloud removeOutliers(const PointCloud& cloud) {
    tree_.build(cloud.points.span());
    const int k = params_.outlier_neighbours;
    const double threshold = outlierDistanceThreshold(
        tree_, cloud.points.span(), k, params_.outlier_std_ratio, mean_distance_, neighbours_);
    std::vector<Point4f> points, normals;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (mean_distance_[i] > threshold) continue;
      points.push_back(cloud.points[i]);
      if (cloud.hasNormals()) normals.push_back(cloud.normals[i]);
    }
    PointCloud kept;
    kept.stamp = cloud.stamp;
    kept.frame_id = cloud.frame_id;
    kept.points = Buffer<Point4f>::fromVector(std::move(points));
    if (cloud.hasNormals()) kept.normals = Buffer<Point4f>::fromVector(std::move(normals));
    return kept;
  }

  struct Supported {
    std::uint32_t voxel;
    std::uint64_t mean_key;
    Eigen::Vector3d mean, normals;
  };

  // The map.
  std::vector<Voxel> voxels_;
  VoxelIndex index_;
  std::string frame_;  // the model frame, set by the first fused cloud
  std::uint32_t frames_ = 0;
  std::uint64_t points_ = 0;
  bool all_normals_ = true;
  // Scratch kept between calls.
  std::vector<std::uint64_t> keys_;
  std::vector<Eigen::Vector3d> points_scratch_, normals_scratch_;
  std::vector<double> weights_;
  std::size_t skipped_ = 0, wide_ = 0;
  std::vector<std::uint8_t> state_;
  std::vector<Supported> supported_;
  std::vector<double> mean_distance_;
  std::vector<KdTree3f::Neighbour> neighbours_;
  KdTree3f tree_;
};

CDFF_REGISTER_DFI(PointCloudAssemblyVoxelFusion);

}  // namespace cdff::dfn
