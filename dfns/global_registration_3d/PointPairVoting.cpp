// GlobalRegistration3D/PointPairVoting: Drost et al.'s point pair feature voting (2010), with
// the neighbouring-cell lookup of Hinterstoisser et al. (2016), written for speed: the model's
// pair table is one flat array of entries addressed by an open-addressing hash of integer
// feature keys, every model point's rotation onto the x axis is computed once, and the voting
// uses one flat accumulator, cleared per reference point; nothing is
// allocated per pair.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "GlobalRegistration3D.gen.hpp"
#include "cdff/types/cloud_extent.hpp"
#include "cdff/types/kd_tree.hpp"
#include "registration_common.hpp"

namespace cdff::dfn {
namespace {

using global_registration::downsampleWithNormals;
using global_registration::Oriented;
using global_registration::VoxelRuns;

constexpr float kPi = static_cast<float>(M_PI);
constexpr float kTwoPi = 2.0f * kPi;

/// A downsampled model of more points than this is refused: its table holds n^2 pairs (16
/// bytes each while it is built), 100 MB at this size; a finer sampling is a configuration
/// mistake for a detection whose hypotheses a verification refines anyway.
constexpr std::size_t kMostModelPoints = 2500;
/// Fewer downsampled model points than this describe no shape (a bus face alone holds 25).
constexpr std::size_t kFewestModelPoints = 10;
/// A pose needs one reference and two more points to fix it.
constexpr std::size_t kFewestScenePoints = 3;
/// A reference's peak gives a pose only with this many votes: three scene points agreeing on one
/// model point and rotation, the least that is not a single chance match.
constexpr float kFewestPeakVotes = 3;
/// A scene normal is fitted only where its neighbourhood spreads across as well as along: the
/// middle eigenvalue of the scatter at least this times the largest (a spread across of at
/// least a fifth of that along). One ring of a sparse scan alone is a line, whose "normal" is
/// any direction across it.
constexpr float kLeastPlanarity = 0.04f;
/// A neighbourhood that is a line is grown up to this many times normal_radius (see fitNormals):
/// at 4 x 2 d = 0.32 D it spans two rings of a VLP-16 on a 5 m target at 17 m, and a normal
/// fitted wider than that mixes the faces of the model's parts.
constexpr int kMostNormalRadii = 4;

/// Model pairs on one plane (both normals within this of each other and of square to the line
/// between them, 5 deg) match every pair of points on every plane of the model at the same
/// distance: on a satellite of boxes and panels they are most of the pairs and most of the
/// voting time, and their votes spread evenly over every point of the large faces and every
/// rotation about their normal. Only one in kPlanarShare of them is kept (chosen by a hash of the
/// pair): the evidence they give is kept in proportion, the time spent on it is not.
const float kPlanarCos = std::cos(5.0f * kPi / 180.0f);
const float kPlanarSin = std::sin(5.0f * kPi / 180.0f);
constexpr std::uint32_t kPlanarShare = 8;

/// Whether unit normals `a`, `b` and the unit direction `u` between them lie on one plane.
bool isPlanar(const Eigen::Vector3f& a, const Eigen::Vector3f& b, const Eigen::Vector3f& u) {
  return a.dot(b) > kPlanarCos && std::abs(a.dot(u)) < kPlanarSin &&
         std::abs(b.dot(u)) < kPlanarSin;
}

/// The planar model pairs kept: one in kPlanarShare, by a hash of the pair spread over the model.
bool keepPlanar(std::size_t i, std::size_t j) {
  const std::uint64_t h = (static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ull) ^
                          (static_cast<std::uint64_t>(j) * 0xC2B2AE3D27D4EB4Full);
  return ((h >> 29) % kPlanarShare) == 0;
}

/// The rotation that turns `n` onto +x (Drost's T_{m->g}, less its translation).
Eigen::Matrix3f alignToX(const Eigen::Vector3f& n) {
  return Eigen::Quaternionf::FromTwoVectors(n, Eigen::Vector3f::UnitX()).toRotationMatrix();
}

/// A rotation about x by `angle`.
Eigen::Matrix3f aboutX(float angle) {
  return Eigen::AngleAxisf(angle, Eigen::Vector3f::UnitX()).toRotationMatrix();
}

/// The angle of `v` about the x axis, from +y towards +z, in [-pi, pi].
float angleAboutX(const Eigen::Vector3f& v) {
  return std::atan2(v.z(), v.y());
}

/// An angle in 32-bit fixed point, a full turn being 2^32: differences wrap modulo a turn by
/// themselves, and the top bits of a difference times the bin count are its bin.
std::uint32_t fixedAngle(float radians) {
  const double turns = static_cast<double>(radians) / (2.0 * M_PI);
  return static_cast<std::uint32_t>(static_cast<std::int64_t>(std::floor(turns * 4294967296.0)));
}

float angleBetween(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  return std::acos(std::clamp(a.dot(b), -1.0f, 1.0f));
}

/// The voxel moments of a cloud without normals: per voxel its count, centroid and scatter about
/// the centroid, from which a normal over any set of voxels follows without revisiting points.
struct VoxelMoments {
  std::vector<Point4f> centroids;        // w unused
  std::vector<Eigen::Matrix3f> scatter;  // sum of (p - centroid)(p - centroid)^T
  std::vector<float> counts;

  void build(const PointCloud& cloud, const VoxelRuns& runs) {
    const std::size_t voxels = runs.starts.size() - 1;
    centroids.resize(voxels);
    scatter.resize(voxels);
    counts.resize(voxels);
    for (std::size_t r = 0; r < voxels; ++r) {
      const std::uint32_t begin = runs.starts[r], end = runs.starts[r + 1];
      // Accumulated relative to the run's first point: single precision keeps the millimetres of
      // a scene tens of metres away.
      const Eigen::Vector3f origin = cloud.points[runs.keyed[begin].second].vec();
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      Eigen::Matrix3f sum2 = Eigen::Matrix3f::Zero();
      for (std::uint32_t k = begin; k < end; ++k) {
        const Eigen::Vector3f d = cloud.points[runs.keyed[k].second].vec() - origin;
        sum += d;
        sum2.noalias() += d * d.transpose();
      }
      const auto n = static_cast<float>(end - begin);
      const Eigen::Vector3f mean = sum / n;
      const Eigen::Vector3f c = origin + mean;
      centroids[r] = Point4f(c.x(), c.y(), c.z());
      scatter[r] = sum2 - n * mean * mean.transpose();
      counts[r] = n;
    }
  }
};

/// The model prepared for voting: its downsampled points, their rotations onto x, and the
/// table of its pairs' features.
class PairTable {
 public:
  struct Entry {
    std::uint32_t model = 0;  // the pair's first point, the one a scene reference would be
    std::uint32_t alpha = 0;  // the second point's angle about x once the first is aligned
  };

  /// Feature quantisation: distance in steps of `step`, angles in steps of `angle_step`.
  struct Quantisation {
    float step = 0, angle_step = 0;
    std::uint64_t distance_bins = 0, angle_bins = 0;
  };

  Status build(std::vector<Oriented> points, float step, float angle_step, double diameter) {
    points_ = std::move(points);
    q_.step = step;
    q_.angle_step = angle_step;
    q_.distance_bins = static_cast<std::uint64_t>(std::floor(diameter / step)) + 2;
    q_.angle_bins = static_cast<std::uint64_t>(std::floor(kPi / angle_step)) + 1;
    rotations_.resize(points_.size());
    for (std::size_t i = 0; i < points_.size(); ++i) rotations_[i] = alignToX(points_[i].n);

    struct Keyed {
      std::uint64_t key;
      Entry entry;
    };
    std::vector<Keyed> pairs;
    pairs.reserve(points_.size() * (points_.size() - 1));
    for (std::size_t i = 0; i < points_.size(); ++i) {
      const Oriented& a = points_[i];
      for (std::size_t j = 0; j < points_.size(); ++j) {
        if (i == j) continue;
        const Oriented& b = points_[j];
        const Eigen::Vector3f d = b.p - a.p;
        const float distance = d.norm();
        if (distance < 1e-6f) continue;
        const Eigen::Vector3f u = d / distance;
        const std::uint64_t key =
            keyOf(static_cast<std::uint64_t>(distance / step),
                  static_cast<std::uint64_t>(angleBetween(a.n, u) / angle_step),
                  static_cast<std::uint64_t>(angleBetween(b.n, u) / angle_step),
                  static_cast<std::uint64_t>(angleBetween(a.n, b.n) / angle_step));
        if (isPlanar(a.n, b.n, u) && !keepPlanar(i, j)) continue;
        pairs.push_back(
            {key, {static_cast<std::uint32_t>(i), fixedAngle(angleAboutX(rotations_[i] * d))}});
      }
    }
    std::sort(pairs.begin(), pairs.end(),
              [](const Keyed& x, const Keyed& y) { return x.key < y.key; });

    entries_.resize(pairs.size());
    std::size_t unique = 0;
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      entries_[k] = pairs[k].entry;
      if (k == 0 || pairs[k].key != pairs[k - 1].key) ++unique;
    }
    // Open addressing at most half full: a miss (most scene lookups) ends within ~2 probes.
    int bits = 4;
    while ((std::size_t{1} << bits) < 2 * unique) ++bits;
    shift_ = 64 - bits;
    slots_.assign(std::size_t{1} << bits, Slot{});
    for (std::size_t k = 0; k < pairs.size();) {
      std::size_t end = k;
      while (end < pairs.size() && pairs[end].key == pairs[k].key) ++end;
      std::size_t s = slotOf(pairs[k].key);
      while (slots_[s].key != kEmpty) s = (s + 1) & (slots_.size() - 1);
      slots_[s] = {pairs[k].key, static_cast<std::uint32_t>(k), static_cast<std::uint32_t>(end)};
      k = end;
    }
    return Status::ok();
  }

  std::uint64_t keyOf(std::uint64_t distance, std::uint64_t angle1, std::uint64_t angle2,
                      std::uint64_t angle3) const {
    return ((distance * q_.angle_bins + angle1) * q_.angle_bins + angle2) * q_.angle_bins + angle3;
  }

  /// The entries with `key`: [begin, end) of entries(); empty when none.
  std::pair<std::uint32_t, std::uint32_t> find(std::uint64_t key) const {
    for (std::size_t s = slotOf(key);; s = (s + 1) & (slots_.size() - 1)) {
      const Slot& slot = slots_[s];
      if (slot.key == key) return {slot.begin, slot.end};
      if (slot.key == kEmpty) return {0, 0};
    }
  }

  const std::vector<Oriented>& points() const { return points_; }
  const std::vector<Eigen::Matrix3f>& rotations() const { return rotations_; }
  const std::vector<Entry>& entries() const { return entries_; }
  const Quantisation& quantisation() const { return q_; }
  std::size_t pairCount() const { return entries_.size(); }

 private:
  static constexpr std::uint64_t kEmpty = std::numeric_limits<std::uint64_t>::max();
  struct Slot {
    std::uint64_t key = kEmpty;
    std::uint32_t begin = 0, end = 0;
  };

  std::size_t slotOf(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
  }

  std::vector<Oriented> points_;
  std::vector<Eigen::Matrix3f> rotations_;
  std::vector<Entry> entries_;
  std::vector<Slot> slots_;
  int shift_ = 60;
  Quantisation q_;
};

/// One reference's pose, before clustering.
struct Vote {
  Eigen::Quaternionf rotation;
  Eigen::Vector3f centre;  // the model's bounding-box centre at this pose
  float votes = 0;
};

}  // namespace

class GlobalRegistration3DPointPairVoting final : public GlobalRegistration3DPointPairVotingBase {
 protected:
  Status onConfigure() override {
    CDFF_RETURN_IF_ERROR(global_registration::checkSampling(params_.sampling));
    prepared_points_ = nullptr;  // the table depends on the parameters: rebuilt on the next call
    return Status::ok();
  }

  Status onProcess() override {
    CDFF_RETURN_IF_ERROR(prepare(*in.model));
    const PointCloud& scene = *in.scene;
    CDFF_RETURN_IF_ERROR(global_registration::checkScene(scene));
    CDFF_RETURN_IF_ERROR(checkModelScale(scene, sizes_.diameter, "scene", "model"));
    CDFF_RETURN_IF_ERROR(sampleScene(scene));
    std::vector<global_registration::Cluster> clusters;
    if (!scene_.empty()) cluster(vote(), clusters);
    global_registration::publish(std::move(clusters), params_.max_hypotheses, scene_.size(), scene,
                                 *in.model, out);
    return Status::ok();
  }

 private:
  /// Builds the table when the model's buffers (or the parameters) changed since the last call.
  Status prepare(const PointCloud& model) {
    if (prepared_points_ != nullptr && model.points.data() == prepared_points_ &&
        model.normals.data() == prepared_normals_ && model.size() == prepared_size_)
      return Status::ok();
    prepared_points_ = nullptr;
    CDFF_RETURN_IF_ERROR(global_registration::checkModel(model));
    const global_registration::ModelExtent extent = global_registration::extentOf(model);
    sizes_ = global_registration::sizesOf(params_.sampling, params_.cluster_distance,
                                          params_.normal_radius, extent);
    model_centre_ = extent.centre();
    std::vector<Oriented> points;
    downsampleWithNormals(model, static_cast<float>(sizes_.step), runs_, points);
    CDFF_RETURN_IF_ERROR(global_registration::checkDownsampledModel(
        points.size(), kFewestModelPoints, sizes_, params_.sampling));
    if (points.size() > kMostModelPoints)
      return invalidInput(
          "input 'model' has {} points after downsampling to {:.4g} m (parameter 'sampling' = "
          "{}); expected at most {} (its pair table grows with their square): raise 'sampling'",
          points.size(), sizes_.step, params_.sampling, kMostModelPoints);
    CDFF_RETURN_IF_ERROR(table_.build(std::move(points), static_cast<float>(sizes_.step),
                                      static_cast<float>(params_.angle_step), sizes_.diameter));
    alpha_bins_ = static_cast<int>(std::ceil(kTwoPi / static_cast<float>(params_.angle_step)));
    accumulator_.assign(table_.points().size() * static_cast<std::size_t>(alpha_bins_), 0u);
    prepared_points_ = model.points.data();
    prepared_normals_ = model.normals.data();
    prepared_size_ = model.size();
    return Status::ok();
  }

  /// The scene downsampled to the model's step, with its normals (given, or fitted).
  Status sampleScene(const PointCloud& scene) {
    const auto step = static_cast<float>(sizes_.step);
    if (scene.hasNormals()) {
      downsampleWithNormals(scene, step, runs_, scene_);
      // Turned towards the sensor as fitted ones are: the model's outward normals face it.
      const Eigen::Vector3f eye = viewpoint();
      for (Oriented& o : scene_)
        if (o.n.dot(eye - o.p) < 0) o.n = -o.n;
    } else {
      fitNormals(scene, step);
    }
    if (scene_.size() < kFewestScenePoints)
      return invalidInput(
          "input 'scene' has {} points with a normal after downsampling its {} points to "
          "{:.4g} m; expected at least {}",
          scene_.size(), scene.size(), step, kFewestScenePoints);
    return Status::ok();
  }

  /// scene_: the centroid of each voxel with the normal of the voxel moments within
  /// normal_radius of it, turned towards the viewpoint. A neighbourhood that is a line (one ring
  /// of a sparse scan: at 17 m a VLP-16's rings are 0.6 m apart) is grown by normal_radius at a
  /// time, up to kMostNormalRadii times it, until it spans across; voxels whose neighbourhood
  /// is still a line get no normal and are left out.
  void fitNormals(const PointCloud& scene, float step) {
    runs_.build(scene, step);
    moments_.build(scene, runs_);
    centroid_tree_.build(moments_.centroids);
    const Eigen::Vector3f eye = viewpoint();
    const auto radius = static_cast<float>(sizes_.normal_radius);
    scene_.clear();
    for (std::size_t v = 0; v < moments_.centroids.size(); ++v) {
      const Eigen::Vector3f p = moments_.centroids[v].vec();
      for (int grown = 1; grown <= kMostNormalRadii; ++grown) {
        centroid_tree_.withinRadius(p, static_cast<float>(grown) * radius, neighbours_);
        const std::optional<Eigen::Vector3f> n = normalOf(p);
        if (!n) continue;
        scene_.push_back({p, n->dot(eye - p) < 0 ? Eigen::Vector3f(-*n) : *n});
        break;
      }
    }
  }

  /// The normal of the merged moments of neighbours_ about `p` (parallel axis theorem, relative
  /// to p for precision); none when they are fewer than 3 points or spread along a line.
  std::optional<Eigen::Vector3f> normalOf(const Eigen::Vector3f& p) {
    float count = 0;
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    Eigen::Matrix3f sum2 = Eigen::Matrix3f::Zero();
    for (const KdTree3f::Neighbour& nb : neighbours_) {
      const float n = moments_.counts[nb.index];
      const Eigen::Vector3f c = moments_.centroids[nb.index].vec() - p;
      count += n;
      sum += n * c;
      sum2 += moments_.scatter[nb.index] + n * c * c.transpose();
    }
    if (count < 3) return std::nullopt;
    const Eigen::Vector3f mean = sum / count;
    const Eigen::Matrix3f covariance = sum2 / count - mean * mean.transpose();
    solver_.computeDirect(covariance);
    const Eigen::Vector3f eigenvalues = solver_.eigenvalues();  // increasing
    if (!(eigenvalues(1) >= kLeastPlanarity * eigenvalues(2))) return std::nullopt;
    return Eigen::Vector3f(solver_.eigenvectors().col(0).normalized());
  }

  /// Every reference's peaks as poses.
  std::vector<Vote> vote() {
    const PairTable::Quantisation& q = table_.quantisation();
    const std::vector<PairTable::Entry>& entries = table_.entries();
    const auto diameter2 = static_cast<float>(sizes_.diameter * sizes_.diameter);
    const auto max_bins = std::array<std::int64_t, 4>{
        static_cast<std::int64_t>(q.distance_bins), static_cast<std::int64_t>(q.angle_bins),
        static_cast<std::int64_t>(q.angle_bins), static_cast<std::int64_t>(q.angle_bins)};
    std::vector<Vote> votes;
    const auto stride = static_cast<std::size_t>(params_.reference_stride);
    const auto bins = static_cast<std::uint64_t>(alpha_bins_);
    for (std::size_t r = 0; r < scene_.size(); r += stride) {
      const Oriented& ref = scene_[r];
      const Eigen::Matrix3f ref_rotation = alignToX(ref.n);
      std::fill(accumulator_.begin(), accumulator_.end(), 0u);
      for (std::size_t j = 0; j < scene_.size(); ++j) {
        if (j == r) continue;
        const Oriented& other = scene_[j];
        const Eigen::Vector3f d = other.p - ref.p;
        const float distance2 = d.squaredNorm();
        if (distance2 > diameter2 || distance2 < 1e-12f) continue;
        const float distance = std::sqrt(distance2);
        const Eigen::Vector3f u = d / distance;
        // The feature in bins (continuous), its cell and, per dimension, the neighbouring cell
        // on the side its value is nearer.
        const std::array<float, 4> value{distance / q.step, angleBetween(ref.n, u) / q.angle_step,
                                         angleBetween(other.n, u) / q.angle_step,
                                         angleBetween(ref.n, other.n) / q.angle_step};
        std::array<std::int64_t, 4> cell{}, side{};
        for (int k = 0; k < 4; ++k) {
          cell[k] = static_cast<std::int64_t>(value[k]);
          side[k] = value[k] - static_cast<float>(cell[k]) >= 0.5f ? 1 : -1;
        }
        const std::uint32_t alpha_scene = fixedAngle(angleAboutX(ref_rotation * d));
        for (int mask = 0; mask < 16; ++mask) {
          std::array<std::int64_t, 4> c = cell;
          bool inside = true;
          for (int k = 0; k < 4; ++k) {
            if (mask & (1 << k)) c[k] += side[k];
            inside = inside && c[k] >= 0 && c[k] < max_bins[k];
          }
          if (!inside) continue;
          const auto [begin, end] = table_.find(
              table_.keyOf(static_cast<std::uint64_t>(c[0]), static_cast<std::uint64_t>(c[1]),
                           static_cast<std::uint64_t>(c[2]), static_cast<std::uint64_t>(c[3])));
          for (std::uint32_t e = begin; e < end; ++e) {
            // alpha = alpha_model - alpha_scene, wrapped by the fixed point; its bin is the top
            // bits of alpha times the bin count.
            const std::uint32_t alpha = entries[e].alpha - alpha_scene;
            const std::uint64_t bin = (static_cast<std::uint64_t>(alpha) * bins) >> 32;
            ++accumulator_[entries[e].model * bins + bin];
          }
        }
      }
      peak(ref, ref_rotation, votes);
    }
    return votes;
  }

  /// The reference's accumulator peak as a pose: the best cell with its better neighbour in
  /// alpha (a rotation near a bin's edge splits its votes), alpha interpolated between them.
  void peak(const Oriented& ref, const Eigen::Matrix3f& ref_rotation, std::vector<Vote>& votes) {
    const auto best_it = std::max_element(accumulator_.begin(), accumulator_.end());
    const auto best = static_cast<float>(*best_it);
    if (best <= 0) return;
    const auto best_index = static_cast<std::uint32_t>(best_it - accumulator_.begin());
    const std::uint32_t model = best_index / static_cast<std::uint32_t>(alpha_bins_);  // row
    const int bin = static_cast<int>(best_index % static_cast<std::uint32_t>(alpha_bins_));
    const std::size_t row = static_cast<std::size_t>(model) * static_cast<std::size_t>(alpha_bins_);
    const auto below = static_cast<float>(
        accumulator_[row + static_cast<std::size_t>((bin + alpha_bins_ - 1) % alpha_bins_)]);
    const auto above =
        static_cast<float>(accumulator_[row + static_cast<std::size_t>((bin + 1) % alpha_bins_)]);
    const float neighbour = std::max(below, above);
    const float total = best + neighbour;
    if (total < kFewestPeakVotes) return;
    const float bin_width = kTwoPi / static_cast<float>(alpha_bins_);
    const float shift = (above >= below ? 1.0f : -1.0f) * bin_width * neighbour / total;
    const float alpha = (static_cast<float>(bin) + 0.5f) * bin_width + shift;
    // scene = ref + ref_R^T Rx(-alpha) model_R (model - model_point)
    const Oriented& m = table_.points()[model];
    const Eigen::Matrix3f rotation =
        ref_rotation.transpose() * aboutX(-alpha) * table_.rotations()[model];
    Vote v;
    v.rotation = Eigen::Quaternionf(rotation).normalized();
    v.centre = ref.p + rotation * (model_centre_ - m.p);
    v.votes = total;
    votes.push_back(v);
  }

  /// Greedy clustering, most votes first: a pose joins the first cluster whose first pose is
  /// within cluster_angle and cluster_distance (model centres), else starts one; a cluster's
  /// pose is its members' vote-weighted mean.
  void cluster(std::vector<Vote> votes, std::vector<global_registration::Cluster>& clusters) const {
    std::stable_sort(votes.begin(), votes.end(),
                     [](const Vote& a, const Vote& b) { return a.votes > b.votes; });
    struct Sum {
      Eigen::Quaternionf first;
      Eigen::Vector3f first_centre;
      Eigen::Vector4f rotation = Eigen::Vector4f::Zero();
      Eigen::Vector3f centre = Eigen::Vector3f::Zero();
      float votes = 0;
    };
    std::vector<Sum> sums;
    const auto distance = static_cast<float>(sizes_.cluster_distance);
    const auto angle = static_cast<float>(params_.cluster_angle);
    for (const Vote& v : votes) {
      Sum* into = nullptr;
      for (Sum& s : sums)
        if ((s.first_centre - v.centre).norm() < distance &&
            s.first.angularDistance(v.rotation) < angle) {
          into = &s;
          break;
        }
      if (into == nullptr) {
        into = &sums.emplace_back();
        into->first = v.rotation;
        into->first_centre = v.centre;
      }
      // q and -q are one rotation: averaged on the first pose's side.
      const float sign = into->first.coeffs().dot(v.rotation.coeffs()) < 0 ? -1.0f : 1.0f;
      into->rotation += sign * v.votes * v.rotation.coeffs();
      into->centre += v.votes * v.centre;
      into->votes += v.votes;
    }
    clusters.clear();
    for (const Sum& s : sums) {
      Eigen::Quaternionf q;
      q.coeffs() = s.rotation.normalized();
      const Eigen::Vector3f centre = s.centre / s.votes;
      global_registration::Cluster c;
      c.scene_T_model.linear() = q.toRotationMatrix().cast<double>();
      c.scene_T_model.translation() = (centre - q * model_centre_).cast<double>();
      c.votes = s.votes;
      clusters.push_back(c);
    }
  }

  Eigen::Vector3f viewpoint() const {
    return Eigen::Vector3d(params_.viewpoint[0], params_.viewpoint[1], params_.viewpoint[2])
        .cast<float>();
  }

  const Point4f* prepared_points_ = nullptr;
  const Point4f* prepared_normals_ = nullptr;
  std::size_t prepared_size_ = 0;
  global_registration::Sizes sizes_;
  Eigen::Vector3f model_centre_ = Eigen::Vector3f::Zero();
  PairTable table_;
  int alpha_bins_ = 30;
  std::vector<std::uint32_t> accumulator_;  // votes per (model point, alpha bin)
  VoxelRuns runs_;
  VoxelMoments moments_;
  KdTree3f centroid_tree_;
  std::vector<KdTree3f::Neighbour> neighbours_;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver_;
  std::vector<Oriented> scene_;
};

CDFF_REGISTER_DFI(GlobalRegistration3DPointPairVoting);

}  // namespace cdff::dfn
