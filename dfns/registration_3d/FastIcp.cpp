#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include <Eigen/Cholesky>

#include "Registration3D.gen.hpp"
#include "registration_common.hpp"

namespace cdff::dfn {

namespace {

enum class Kernel { kNone, kHuber, kTukey, kGemanMcClure };

Kernel parseKernel(const std::string& name) {
  if (name == "huber") return Kernel::kHuber;
  if (name == "tukey") return Kernel::kTukey;
  if (name == "geman_mcclure") return Kernel::kGemanMcClure;
  return Kernel::kNone;
}

// Iteratively reweighted least squares weights w(r) = rho'(r) / r, with each kernel's usual
// tuning constant expressed in units of the residual scale s (95 % efficiency on Gaussian noise
// for Huber and Tukey).
double weight(Kernel kernel, double r, double s) {
  switch (kernel) {
    case Kernel::kNone:
      return 1.0;
    case Kernel::kHuber: {
      const double k = 1.345 * s;
      return std::abs(r) <= k ? 1.0 : k / std::abs(r);
    }
    case Kernel::kTukey: {
      const double c = 4.685 * s;
      if (std::abs(r) >= c) return 0.0;
      const double u = 1.0 - (r / c) * (r / c);
      return u * u;
    }
    case Kernel::kGemanMcClure: {
      const double c = 2.0 * s;
      const double u = c * c / (c * c + r * r);
      return u * u;
    }
  }
  return 1.0;
}

double median(std::vector<float>& values) {
  if (values.empty()) return 0.0;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// A dense grid over the model's bounding box (plus a band) whose cells within `band` of the
// surface hold the model point nearest to their centre: a nearest-neighbour lookup in constant
// time for the fine iterations, where correspondences are short. The point returned is the
// nearest to the query's cell centre, at most half a cell diagonal from the query, so it lies on
// the same face as the true nearest except right at an edge: point-to-plane residuals on a face
// are then exact. Built once per model by a wavefront from the cells holding model points.
class NearestGrid {
 public:
  static constexpr std::uint32_t kNone = ~std::uint32_t{0};

  bool empty() const { return labels_.empty(); }
  double band() const { return band_; }

  /// False (and an empty grid) when it would exceed `max_cells`.
  bool build(const Buffer<Point4f>& points, double cell, double band, std::size_t max_cells) {
    labels_.clear();
    opposite_.clear();
    if (points.empty() || !(cell > 0)) return false;
    Eigen::Vector3f lo = points[0].vec(), hi = lo;
    for (const Point4f& p : points) {
      lo = lo.cwiseMin(p.vec());
      hi = hi.cwiseMax(p.vec());
    }
    cell_ = static_cast<float>(cell);
    inverse_ = 1.0f / cell_;
    band_ = band;
    const float margin = static_cast<float>(band) + cell_;
    origin_ = lo - Eigen::Vector3f::Constant(margin);
    const Eigen::Vector3f extent = hi - lo + Eigen::Vector3f::Constant(2 * margin);
    for (int a = 0; a < 3; ++a) size_[a] = static_cast<int>(std::ceil(extent[a] * inverse_)) + 1;
    const double cells = static_cast<double>(size_[0]) * size_[1] * size_[2];
    if (cells > static_cast<double>(max_cells)) return false;
    labels_.assign(static_cast<std::size_t>(cells), kNone);
    std::vector<float> distance(labels_.size(), std::numeric_limits<float>::infinity());
    std::vector<std::uint32_t> queue;
    auto centre = [&](int x, int y, int z) -> Eigen::Vector3f {  // a value, not an expression
      return origin_ + cell_ * Eigen::Vector3f(x + 0.5f, y + 0.5f, z + 0.5f);
    };
    for (std::uint32_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3f p = points[i].vec();
      const Eigen::Vector3i c = cellOf(p);
      const std::size_t k = linear(c.x(), c.y(), c.z());
      const float d = (centre(c.x(), c.y(), c.z()) - p).squaredNorm();
      if (d < distance[k]) {
        if (labels_[k] == kNone) queue.push_back(static_cast<std::uint32_t>(k));
        distance[k] = d;
        labels_[k] = i;
      }
    }
    // Wavefront, one layer of cells at a time: the cells of a layer offer their points to their
    // unsettled neighbours (26-connected), which keep the nearest offer within the band and form
    // the next layer. Every cell is settled once: a cell's point is the nearest to its centre
    // among its neighbours' points (approximately the nearest of all, as in vector-propagation
    // distance transforms).
    const float band2 = static_cast<float>(band * band);
    std::vector<std::uint8_t> settled(labels_.size(), 0);
    for (std::uint32_t k : queue) settled[k] = 1;
    std::vector<std::uint32_t> next;
    while (!queue.empty()) {
      next.clear();
      for (const std::uint32_t k : queue) {
        const int z = static_cast<int>(k / (size_[0] * size_[1]));
        const int y = static_cast<int>(k / size_[0] % size_[1]);
        const int x = static_cast<int>(k % size_[0]);
        const Eigen::Vector3f p = points[labels_[k]].vec();
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int nx = x + dx, ny = y + dy, nz = z + dz;
              if (nx < 0 || ny < 0 || nz < 0 || nx >= size_[0] || ny >= size_[1] || nz >= size_[2])
                continue;
              const std::size_t m = linear(nx, ny, nz);
              if (settled[m]) continue;
              const float d = (centre(nx, ny, nz) - p).squaredNorm();
              if (d < distance[m] && d <= band2) {
                if (labels_[m] == kNone) next.push_back(static_cast<std::uint32_t>(m));
                distance[m] = d;
                labels_[m] = labels_[k];
              }
            }
      }
      for (std::uint32_t m : next) settled[m] = 1;
      queue.swap(next);
    }
    return true;
  }

  static constexpr std::size_t kOutside = ~std::size_t{0};

  /// The cell holding `q`, or kOutside.
  std::size_t cellAt(const Eigen::Vector3f& q) const {
    const Eigen::Vector3f f = (q - origin_) * inverse_;
    const int x = static_cast<int>(std::floor(f.x())), y = static_cast<int>(std::floor(f.y())),
              z = static_cast<int>(std::floor(f.z()));
    if (x < 0 || y < 0 || z < 0 || x >= size_[0] || y >= size_[1] || z >= size_[2]) return kOutside;
    return linear(x, y, z);
  }
  /// The model point nearest to the cell's centre, or kNone outside the band.
  std::uint32_t label(std::size_t cell) const { return labels_[cell]; }

  /// The model point nearest to the cell's centre among those whose normal opposes its label's
  /// (the other side of a thin part), or kNone; found by `tree` at the first request and kept,
  /// since a tracked target keeps showing the same cells.
  std::uint32_t opposite(std::size_t cell, const KdTree3f& tree, const Buffer<Point4f>& normals) {
    // The grid is shared between instances, which may run in different threads.
    const std::lock_guard<std::mutex> lock(opposite_mutex_);
    if (opposite_.size() != labels_.size()) opposite_.assign(labels_.size(), kUnknown);
    std::uint32_t& alt = opposite_[cell];
    if (alt != kUnknown) return alt;
    alt = kNone;
    const auto z = static_cast<int>(cell / (static_cast<std::size_t>(size_[0]) * size_[1]));
    const auto y = static_cast<int>(cell / size_[0] % size_[1]);
    const auto x = static_cast<int>(cell % size_[0]);
    const Eigen::Vector3f c = origin_ + cell_ * Eigen::Vector3f(x + 0.5f, y + 0.5f, z + 0.5f);
    // Facing a far point behind the label's normal = a normal opposing it.
    const Eigen::Vector3f eye = c - 1e4f * normals[labels_[cell]].vec();
    KdTree3f::Neighbour found;
    if (tree.nearestFacing(c, eye, static_cast<float>(band_ * band_), found)) alt = found.index;
    return alt;
  }

 private:
  Eigen::Vector3i cellOf(const Eigen::Vector3f& p) const {
    const Eigen::Vector3f f = (p - origin_) * inverse_;
    return {std::clamp(static_cast<int>(std::floor(f.x())), 0, size_[0] - 1),
            std::clamp(static_cast<int>(std::floor(f.y())), 0, size_[1] - 1),
            std::clamp(static_cast<int>(std::floor(f.z())), 0, size_[2] - 1)};
  }
  std::size_t linear(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * size_[1] + y) * size_[0] + x;
  }

  static constexpr std::uint32_t kUnknown = kNone - 1;
  std::vector<std::uint32_t> labels_;
  std::vector<std::uint32_t> opposite_;  // kUnknown until asked for
  std::mutex opposite_mutex_;
  Eigen::Vector3f origin_ = Eigen::Vector3f::Zero();
  float cell_ = 0, inverse_ = 0;
  double band_ = 0;
  int size_[3] = {0, 0, 0};
};

// How much of the model surface that a spinning LIDAR's lasers would hit at a pose the scan
// confirms: the free-space evidence that the fitness lacks. A sparse scan (a few rings on the
// target at 15 m) fits a model slid along a panel, or turned by 15 degrees, as well as the
// right pose, since every return still lies on some model surface; but such a pose puts model
// surface where the lasers fired and saw nothing (or saw farther), which the right pose does not.
// The lasers are cones about the source frame's z axis through the viewpoint (a VLP-16 in its
// own frame); the rings are those the scan's returns lie on, plus, when ring_spacing > 0, the
// rings next to them that the sensor has (within max_elevation) and that saw nothing.
class RingVisibility {
 public:
  /// The rings and the returns along each, from the scan; false when it has no ring with enough
  /// returns to measure the azimuth step.
  bool setScan(const std::vector<Eigen::Vector3f>& points, const Eigen::Vector3f& viewpoint,
               double ring_spacing, double max_elevation) {
    rings_.clear();
    viewpoint_ = viewpoint;
    struct Return {
      float elevation, azimuth, range;
    };
    std::vector<Return> returns;
    returns.reserve(points.size());
    for (const Eigen::Vector3f& p : points) {
      const Eigen::Vector3f d = p - viewpoint;
      const float range = d.norm();
      if (!(range > 0)) continue;
      returns.push_back(
          {std::asin(std::clamp(d.z() / range, -1.0f, 1.0f)), std::atan2(d.y(), d.x()), range});
    }
    if (returns.size() < 3) return false;
    std::sort(returns.begin(), returns.end(),
              [](const Return& a, const Return& b) { return a.elevation < b.elevation; });
    // Returns of one laser share its elevation to float precision (the range noise is along the
    // ray); lasers are a degree or more apart.
    constexpr float kSameRing = 0.25f * static_cast<float>(M_PI / 180.0);
    std::vector<float> ranges;
    for (std::size_t i = 0; i < returns.size();) {
      std::size_t j = i + 1;
      while (j < returns.size() && returns[j].elevation - returns[j - 1].elevation < kSameRing) ++j;
      Ring ring;
      ring.elevation = returns[(i + j) / 2].elevation;
      std::vector<std::pair<float, float>> along;
      for (std::size_t k = i; k < j; ++k) along.emplace_back(returns[k].azimuth, returns[k].range);
      std::sort(along.begin(), along.end());
      for (const auto& [az, r] : along) {
        ring.azimuths.push_back(az);
        ring.ranges.push_back(r);
        ranges.push_back(r);
      }
      rings_.push_back(std::move(ring));
      i = j;
    }
    // The azimuth step of the returns along a ring (the firing step, or the voxel grid's at
    // close range): the bin of predicted surface, and the gap a return may be away.
    std::vector<float> gaps;
    for (const Ring& ring : rings_)
      for (std::size_t k = 1; k < ring.azimuths.size(); ++k)
        gaps.push_back(ring.azimuths[k] - ring.azimuths[k - 1]);
    if (gaps.empty()) return false;
    const float step = std::max(static_cast<float>(median(gaps)), 1e-4f);
    const float range = static_cast<float>(median(ranges));
    if (ring_spacing > 0) {
      // The sensor's rings just above and below the observed ones saw nothing of the target.
      const float lo = rings_.front().elevation, hi = rings_.back().elevation;
      const auto spacing = static_cast<float>(ring_spacing);
      const auto limit = static_cast<float>(max_elevation) + kSameRing;
      if (lo - spacing >= -limit) rings_.insert(rings_.begin(), Ring{lo - spacing, {}, {}, 0, 0});
      if (hi + spacing <= limit) rings_.push_back(Ring{hi + spacing, {}, {}, 0, 0});
    }
    offsets_.assign(1, 0);
    for (Ring& ring : rings_) {
      ring.bin = step;
      ring.bins = static_cast<std::size_t>(std::ceil(2 * M_PI / step)) + 1;
      offsets_.push_back(offsets_.back() + ring.bins);
    }
    nearest_.assign(offsets_.back(), std::numeric_limits<float>::infinity());
    facing_.assign(offsets_.back(), 0);
    range_ = range;
    return true;
  }

  bool empty() const { return rings_.empty(); }

  /// The fraction of the model's visible surface on the rings at source_T_model (R, t) that has
  /// a return within 1.5 azimuth steps, not farther than `through` behind it (a return well
  /// behind means the laser went through where the model has surface). 0 when no model surface
  /// falls on a ring.
  double evaluate(const registration::ModelIndex& model, double model_spacing,
                  const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation,
                  double through) {
    if (rings_.empty()) return 0;
    const Eigen::Matrix3f r = rotation.cast<float>();
    const Eigen::Vector3f t = translation.cast<float>();
    // A model point is on a laser's ring when its elevation is within half the model's point
    // spacing (seen at the scan's range) of the laser's: the ring's strip of surface.
    // A subsample of the model is enough to tell where its surface is (the bins are a few cm).
    const std::size_t stride = std::max<std::size_t>(1, model.points.size() / kModelSamples);
    const float half_band =
        0.5f * static_cast<float>(model_spacing * std::sqrt(static_cast<double>(stride))) / range_;
    std::vector<float> sin_lo(rings_.size()), sin_hi(rings_.size());
    for (std::size_t k = 0; k < rings_.size(); ++k) {
      sin_lo[k] = std::sin(rings_[k].elevation - half_band);
      sin_hi[k] = std::sin(rings_[k].elevation + half_band);
    }
    touched_.clear();
    for (std::size_t i = 0; i < model.points.size(); i += stride) {
      const Eigen::Vector3f d = r * model.points[i].vec() + t - viewpoint_;
      const float range2 = d.squaredNorm();
      if (!(range2 > 0)) continue;
      const float range = std::sqrt(range2);
      const float s = d.z() / range;
      if (s < sin_lo.front() || s > sin_hi.back()) continue;
      const auto k = static_cast<std::size_t>(std::upper_bound(sin_lo.begin(), sin_lo.end(), s) -
                                              sin_lo.begin());
      if (k == 0 || s > sin_hi[k - 1]) continue;
      const Ring& ring = rings_[k - 1];
      const float azimuth = std::atan2(d.y(), d.x());
      const auto bin = static_cast<std::size_t>((azimuth + static_cast<float>(M_PI)) / ring.bin);
      const std::size_t cell = offsets_[k - 1] + std::min(bin, ring.bins - 1);
      if (range < nearest_[cell]) {
        if (std::isinf(nearest_[cell])) touched_.push_back(static_cast<std::uint32_t>(cell));
        nearest_[cell] = range;
        facing_[cell] = (r * model.normals[i].vec()).dot(d) < 0;
      }
    }
    std::size_t predicted = 0, confirmed = 0;
    for (const std::uint32_t cell : touched_) {
      if (!facing_[cell]) continue;  // a hole in the near side's sampling shows the far side
      ++predicted;
      const auto k = static_cast<std::size_t>(
          std::upper_bound(offsets_.begin(), offsets_.end(), std::size_t{cell}) - offsets_.begin() -
          1);
      const Ring& ring = rings_[k];
      const float centre =
          (static_cast<float>(cell - offsets_[k]) + 0.5f) * ring.bin - static_cast<float>(M_PI);
      if (seen(ring, centre, 1.5f * ring.bin, nearest_[cell] + static_cast<float>(through)))
        ++confirmed;
    }
    for (std::uint32_t cell : touched_) nearest_[cell] = std::numeric_limits<float>::infinity();
    return predicted ? static_cast<double>(confirmed) / static_cast<double>(predicted) : 0.0;
  }

 private:
  struct Ring {
    float elevation = 0;
    std::vector<float> azimuths;  // of its returns, sorted
    std::vector<float> ranges;    // of the same returns
    float bin = 0;                // azimuth step, rad
    std::size_t bins = 0;
  };

  /// A return of `ring` within `tolerance` of `azimuth` (either side of the +-pi seam), nearer
  /// than `max_range`.
  static bool seen(const Ring& ring, float azimuth, float tolerance, float max_range) {
    for (const float shift :
         {0.0f, 2.0f * static_cast<float>(M_PI), -2.0f * static_cast<float>(M_PI)}) {
      const float a = azimuth + shift;
      auto it = std::lower_bound(ring.azimuths.begin(), ring.azimuths.end(), a - tolerance);
      for (; it != ring.azimuths.end() && *it <= a + tolerance; ++it)
        if (ring.ranges[static_cast<std::size_t>(it - ring.azimuths.begin())] <= max_range)
          return true;
    }
    return false;
  }

  static constexpr std::size_t kModelSamples = 40000;
  std::vector<Ring> rings_;
  Eigen::Vector3f viewpoint_ = Eigen::Vector3f::Zero();
  float range_ = 1;
  std::vector<std::size_t> offsets_;  // first bin of each ring in nearest_
  std::vector<float> nearest_;        // range of the nearest model point in each bin
  std::vector<std::uint8_t> facing_;  // whether that point faces the sensor
  std::vector<std::uint32_t> touched_;
};

}  // namespace

class Registration3DFastIcp final : public Registration3DFastIcpBase {
 protected:
  Status onConfigure() override {
    if (params_.min_correspondence_distance > params_.max_correspondence_distance)
      return invalidParameter(
          "parameter 'min_correspondence_distance' = {} exceeds 'max_correspondence_distance' "
          "= {}; expected min <= max",
          params_.min_correspondence_distance, params_.max_correspondence_distance);
    kernel_ = parseKernel(params_.robust_kernel);
    grid_model_ = 0;  // the grid's parameters may have changed
    viewpoint_ = Eigen::Vector3f(params_.viewpoint[0], params_.viewpoint[1], params_.viewpoint[2]);
    return Status::ok();
  }

  Status onProcess() override {
    const PointCloud& model = *in.model;
    CDFF_RETURN_IF_ERROR(prepareModel(model));
    // Without a new scan the call only prepares the model (see the DFN's `source`).
    if (!in.source.isFresh()) return Status::ok();
    const PointCloud& source = *in.source;
    Result<Eigen::Isometry3d> guess =
        registration::checkInputs(source, model, in.initial_guess.get());
    if (!guess) return guess.status();
    registration::selectSource(source, params_.max_source_points, points_);
    const std::vector<Eigen::Vector3f>& points = points_;
    const bool visibility_check =
        params_.visibility_check &&
        visibility_.setScan(points, viewpoint_, params_.ring_spacing, params_.max_elevation);
    auto visibility = [&](const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
      return visibility_.evaluate(*shared_index_, model_spacing_, rotation, translation,
                                  3.0 * params_.inlier_distance);
    };

    bool ambiguous = false;
    Search search;
    search.setPose(*guess);
    search.distance = params_.max_correspondence_distance;
    if (params_.hypotheses > 1) {
      // Acquisition from a poor guess: a sparse scan of a target that looks alike from several
      // sides has local minima within the guess's error, into which a single ICP run falls.
      // Every start gets a short run; the one that explains the scan best (most inliers, then
      // the smallest inlier RMS) goes on to the full refinement.
      std::vector<Candidate> candidates;
      std::vector<Eigen::Vector3d> positions = {guess->translation()};
      if (params_.hypothesis_centroid) positions.push_back(centredPosition(points, *guess));
      // Hypotheses being followed need no new starts (the search is most of the cost).
      if (following(source.stamp)) positions.clear();
      for (const Eigen::Vector3d& position : positions)
        for (const Eigen::Matrix3d& turn : hypothesisTurns()) {
          Search start;
          // Turned about the model's origin: its position in the sensor frame stays put.
          start.rotation = turn * guess->linear();
          start.translation = position;
          start.distance = params_.max_correspondence_distance;
          CDFF_RETURN_IF_ERROR(iterate(points, start, params_.hypothesis_iterations));
          // The guess's error is about hypothesis_angle: a start that turned much farther than
          // that found another minimum (a symmetric view of the target), not the pose.
          const double turned =
              Eigen::AngleAxisd(start.rotation * guess->linear().transpose()).angle();
          if (start.starved || turned > params_.hypothesis_max_turn) continue;
          candidates.push_back(
              {start,
               registration::evaluate(points, *shared_index_, start.pose(), params_.inlier_distance,
                                      params_.covariance_inflation),
               turned});
        }
      // Every start explains the returns about as well on a sparse scan; those that also have
      // a return wherever they put visible model surface (visibility >= min_visibility) are
      // the candidates, the best fit among them wins. The visibility (a pass over the model)
      // is computed only for starts whose fitness could still win.
      std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return a.quality.fitness > b.quality.fitness;
      });
      std::optional<Search> best;
      registration::Quality best_quality;
      double best_turn = 0;
      if (params_.confirmation_scans > 0) {
        CDFF_RETURN_IF_ERROR(confirm(points, source.stamp, *guess, candidates, visibility_check,
                                     visibility, best, ambiguous));
        candidates.clear();
      }
      for (const Candidate& c : candidates) {
        if (best && c.quality.fitness < best_quality.fitness - 0.02) break;
        if (visibility_check && params_.min_visibility > 0 &&
            visibility(c.search.rotation, c.search.translation) < params_.min_visibility)
          continue;
        if (!best || betterFit(c.quality, c.turned, best_quality, best_turn)) {
          best = c.search;
          best_quality = c.quality;
          best_turn = c.turned;
        }
      }
      if (best) {
        search = *best;
        search.converged = false;
      }
    }
    CDFF_RETURN_IF_ERROR(iterate(points, search, params_.max_iterations));
    if (search.converged && grid_ready_ && params_.exact_refinement_iterations > 0) {
      search.converged = false;
      CDFF_RETURN_IF_ERROR(
          iterate(points, search, params_.exact_refinement_iterations, NearestPoints::kExact));
      // Refinement steps that have not shrunk below the epsilons still end at a better pose
      // than the grid's; the registration converged with the grid already.
      if (!search.starved) search.converged = true;
    }
    const Eigen::Matrix3d& rotation = search.rotation;
    const Eigen::Vector3d& translation = search.translation;
    const double distance = search.distance;
    const bool converged = search.converged, starved = search.starved;
    const int iterations = search.iterations;
    const std::size_t last_pairs = search.last_pairs;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::Quaterniond(rotation).normalized().toRotationMatrix();
    pose.translation() = translation;
    if (starved) {
      warn(fmt::format(
          "only {} source points of {} have a model point within {:.3g} m (iteration {}); "
          "expected at least min_correspondences = {}: no overlap with the model",
          last_pairs, points.size(), distance, iterations + 1, params_.min_correspondences));
      pose = *guess;
    }
    const registration::Quality quality =
        registration::evaluate(points, *shared_index_, pose, params_.inlier_distance,
                               params_.covariance_inflation, starved ? nullptr : &previous_);
    if (converged && quality.degenerate)
      warn(
          "the scan constrains some direction of the pose poorly (degenerate geometry); its "
          "covariance is large there");
    registration::publish(out, source, model, pose, quality, converged && !starved, iterations);
    out.ambiguous.set(ambiguous);
    out.visibility.set(visibility_check ? visibility(pose.linear(), pose.translation())
                                        : std::numeric_limits<double>::quiet_NaN());
    return Status::ok();
  }

 private:
  // The search structures over the model (shared with every instance registering against the
  // same buffer), built when the buffer is new.
  Status prepareModel(const PointCloud& model) {
    Result<std::shared_ptr<const registration::ModelIndex>> shared =
        registration::sharedIndex(model, shared_index_);
    if (!shared) return shared.status();
    shared_index_ = std::move(shared).value();
    if (grid_model_ != shared_index_->builds) {
      grid_model_ = shared_index_->builds;
      grid_ = sharedGrid();
      grid_ready_ = grid_ != nullptr;
      if (params_.lookup_grid_cell > 0 && !grid_ready_)
        warn(
            fmt::format("the model's lookup grid would need more than {} cells of {} m; only "
                        "the KD-tree is used (a larger lookup_grid_cell would allow it)",
                        kMaxGridCells, params_.lookup_grid_cell));
    }
    if (params_.visibility_check && spacing_for_ != shared_index_->builds) {
      model_spacing_ = modelSpacing(*shared_index_);
      spacing_for_ = shared_index_->builds;
    }
    return Status::ok();
  }

  /// The state of one ICP run, carried over when a run continues (acquisition).
  struct Search {
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
    double distance = 0;  // the current correspondence distance
    bool converged = false, starved = false;
    int iterations = 0;
    std::size_t last_pairs = 0;
    Vector6d previous_step = Vector6d::Zero();
    // A Gaussian prior on the pose (a hypothesis followed into the next scan, which a sparse
    // scan alone lets slide along its poorly constrained directions): the offset from `anchor`
    // ([dt, dtheta], as the steps) weighted by `anchor_precision`, in the residuals' squared
    // units. Zero: none.
    Eigen::Isometry3d anchor = Eigen::Isometry3d::Identity();
    Vector6d anchor_precision = Vector6d::Zero();

    /// The offset from the anchor, [dt, dtheta].
    Vector6d fromAnchor() const {
      Vector6d d;
      d.head<3>() = translation - anchor.translation();
      d.tail<3>() = logSO3(Eigen::Quaterniond(rotation * anchor.linear().transpose()));
      return d;
    }

    Eigen::Isometry3d pose() const {
      Eigen::Isometry3d at = Eigen::Isometry3d::Identity();
      at.linear() = rotation;
      at.translation() = translation;
      return at;
    }
    void setPose(const Eigen::Isometry3d& at) {
      rotation = at.linear();
      translation = at.translation();
    }
  };

  /// A start's short run in the multi-start search.
  struct Candidate {
    Search search;
    registration::Quality quality;
    double turned;
  };

  /// An acquisition hypothesis followed over consecutive scans (confirmation_scans).
  struct Hypothesis {
    Search search;
    Eigen::Isometry3d from_guess;  // pose * guess^-1: how it moves with the next guesses
    double misfit = 0;             // summed over the scans it was followed through
  };

  /// How badly `pose` explains the scan, in squared noise units (noise sigma = inlier_distance
  /// / 3): the inliers' point-to-plane residuals, every unmatched return as one at the inlier
  /// distance, and the fraction of the visible model surface without a return as that fraction
  /// of the returns unmatched. Additive over scans: a negative log-likelihood up to a constant.
  double misfit(std::span<const Eigen::Vector3f> points, const Eigen::Isometry3d& pose,
                double visibility) const {
    const registration::Quality q =
        registration::evaluate(points, *shared_index_, pose, params_.inlier_distance, 1.0);
    const double sigma = params_.inlier_distance / 3.0;
    const double n = static_cast<double>(points.size());
    double cost = (n - static_cast<double>(q.inliers)) * kUnmatchedCost;
    if (q.inliers > 0)
      cost += static_cast<double>(q.inliers) * q.inlier_rms * q.inlier_rms / (sigma * sigma);
    if (std::isfinite(visibility)) cost += (1.0 - visibility) * n * kUnmatchedCost;
    return cost;
  }

  /// `s` moved to a local minimum of `cost` (its misfit) by a pattern search along the six pose
  /// axes, with steps halving from 4 cm and 2 degrees: the ICP minimises the residuals alone,
  /// which on a sparse scan leave some directions loose by several degrees; the misfit's
  /// visibility term (surface put where the lasers saw nothing) is what constrains them, and it
  /// has no gradient. Returns the cost at the minimum.
  template <typename Cost>
  static double descend(Search& s, Cost&& cost) {
    double best = cost(s);
    double shift = 0.04, turn = 2.0 * M_PI / 180;
    for (int level = 0; level < 3; ++level, shift /= 2, turn /= 2)
      for (int pass = 0; pass < 4; ++pass) {
        bool moved = false;
        for (int axis = 0; axis < 6; ++axis)
          for (const double sign : {-1.0, 1.0}) {
            Search trial = s;
            if (axis < 3)
              trial.translation[axis] += sign * shift;
            else
              trial.rotation = Eigen::AngleAxisd(sign * turn, Eigen::Vector3d::Unit(axis - 3))
                                   .toRotationMatrix() *
                               trial.rotation;
            const double c = cost(trial);
            if (c < best) {
              best = c;
              s = trial;
              moved = true;
            }
          }
        if (!moved) break;
      }
    return best;
  }

  /// Whether a scan at `stamp` follows the kept hypotheses (else it starts a new set): there
  /// are some, from an earlier scan less than confirmation_timeout ago, and the set has not
  /// been followed for long without a decision.
  bool following(Timestamp stamp) const {
    return params_.confirmation_scans > 0 && !hypotheses_.empty() && stamp > hypotheses_stamp_ &&
           toSeconds(stamp - hypotheses_stamp_) <= params_.confirmation_timeout &&
           hypotheses_scans_ < 4 * params_.confirmation_scans;
  }

  /// The multi-scan choice among acquisition hypotheses: a new set (the best distinct
  /// `candidates` of this scan's multi-start search) when there is none or it is stale, else
  /// each kept hypothesis followed into this scan; the one with the least accumulated misfit is
  /// returned, `ambiguous` until confirmation_scans scans are scored and every other one's
  /// misfit exceeds it by confirmation_margin.
  template <typename Visibility>
  Status confirm(const std::vector<Eigen::Vector3f>& points, Timestamp stamp,
                 const Eigen::Isometry3d& guess, const std::vector<Candidate>& candidates,
                 bool visibility_check, Visibility&& visibility, std::optional<Search>& best,
                 bool& ambiguous) {
    auto scoreOf = [&](const Search& s) {
      return misfit(points, s.pose(),
                    visibility_check ? visibility(s.rotation, s.translation)
                                     : std::numeric_limits<double>::quiet_NaN());
    };
    const bool stale = !following(stamp);
    // Hypotheses that ended in the same minimum (starts, or followed ones) are one: the
    // kept_hypotheses best distinct ones are kept, best first.
    auto keepDistinct = [&] {
      std::sort(hypotheses_.begin(), hypotheses_.end(),
                [](const Hypothesis& a, const Hypothesis& b) { return a.misfit < b.misfit; });
      std::vector<Hypothesis> distinct;
      for (const Hypothesis& h : hypotheses_) {
        bool duplicate = false;
        for (const Hypothesis& d : distinct)
          duplicate =
              duplicate ||
              ((h.search.translation - d.search.translation).norm() < kSameHypothesisDistance &&
               Eigen::AngleAxisd(h.search.rotation * d.search.rotation.transpose()).angle() <
                   kSameHypothesisAngle);
        if (!duplicate && static_cast<int>(distinct.size()) < params_.kept_hypotheses)
          distinct.push_back(h);
      }
      hypotheses_ = std::move(distinct);
    };
    if (stale) {
      hypotheses_.clear();
      hypotheses_scans_ = 0;
      for (const Candidate& c : candidates)
        hypotheses_.push_back({c.search, c.search.pose() * guess.inverse(), scoreOf(c.search)});
      // Only the kept ones are moved to their misfit's minimum (the search costs about a
      // hundred misfit evaluations each).
      keepDistinct();
      for (Hypothesis& h : hypotheses_) {
        h.misfit = descend(h.search, scoreOf);
        h.from_guess = h.search.pose() * guess.inverse();
      }
    } else {
      // A hypothesis that finds no overlap any more explains nothing of the scan.
      const double unexplained = 2.0 * kUnmatchedCost * static_cast<double>(points.size());
      // Each hypothesis moves with the guess, and by what the target's own motion since the
      // last scan can add (the prior; the guess, an acquisition's prediction, may not know the
      // motion yet): a damped run that keeps it in its own minimum instead of sliding along
      // the directions the sparse scan leaves loose into another's. Its move is part of the
      // misfit (the prior's negative log-likelihood, in the same units).
      const double dt = toSeconds(stamp - hypotheses_stamp_);
      const double shift_sigma = std::max(1e-6, params_.follow_shift_sigma * dt);
      const double turn_sigma = std::max(1e-9, params_.follow_turn_sigma * dt);
      Vector6d prior;
      prior << Eigen::Vector3d::Constant(1.0 / (shift_sigma * shift_sigma)),
          Eigen::Vector3d::Constant(1.0 / (turn_sigma * turn_sigma));
      const double noise = params_.inlier_distance / 3.0;
      for (Hypothesis& h : hypotheses_) {
        const Eigen::Isometry3d start = h.from_guess * guess;
        Search s;
        s.setPose(start);
        s.distance =
            std::clamp(params_.inlier_distance + 3.0 * shift_sigma,
                       params_.min_correspondence_distance, params_.max_correspondence_distance);
        s.anchor = start;
        s.anchor_precision = noise * noise * prior;
        CDFF_RETURN_IF_ERROR(iterate(points, s, params_.hypothesis_iterations));
        if (s.starved) {
          h.misfit += unexplained;
          h.search.setPose(start);
        } else {
          h.misfit += descend(s, [&](const Search& at) {
            const Vector6d moved = at.fromAnchor();
            return scoreOf(at) + moved.dot(prior.cwiseProduct(moved));
          });
          h.search = s;
        }
        h.from_guess = h.search.pose() * guess.inverse();
      }
    }
    hypotheses_stamp_ = stamp;
    ++hypotheses_scans_;
    keepDistinct();
    if (hypotheses_.empty()) {
      ambiguous = true;
      return Status::ok();
    }
    // A single distinct hypothesis left (every start, or every followed one, ended in the same
    // minimum) has no rival for more scans to rule out: it is decided at once.
    const double margin = hypotheses_.size() > 1 ? hypotheses_[1].misfit - hypotheses_[0].misfit
                                                 : std::numeric_limits<double>::infinity();
    ambiguous = hypotheses_.size() > 1 && (hypotheses_scans_ < params_.confirmation_scans ||
                                           margin < params_.confirmation_margin);
    best = hypotheses_.front().search;
    if (!ambiguous) hypotheses_.clear();  // decided: a later acquisition starts a new set
    return Status::ok();
  }

  /// kGridWhereItReaches: the lookup grid for correspondences within its band, else the
  /// KD-tree; kExact: the KD-tree only.
  enum class NearestPoints { kGridWhereItReaches, kExact };

  /// At most `max_iterations` more ICP iterations of `s`, until converged or starved.
  Status iterate(const std::vector<Eigen::Vector3f>& points, Search& s, int max_iterations,
                 NearestPoints nearest = NearestPoints::kGridWhereItReaches) {
    bool first = true;
    const int stop = s.iterations + max_iterations;
    for (; s.iterations < stop; ++s.iterations) {
      if (!associate(points, s.rotation, s.translation, s.distance, first, nearest)) {
        s.starved = true;
        s.last_pairs = pairs_.size();
        break;
      }
      first = false;
      const double scale = params_.kernel_scale > 0 ? params_.kernel_scale
                                                    : std::max(params_.min_kernel_scale,
                                                               1.4826 * median(abs_residuals_));
      Matrix6d h = Matrix6d::Zero();
      Vector6d g = Vector6d::Zero();
      bool point_to_plane = false;
      double weighted_r2 = 0, weight_sum = 0;
      if (s.distance > params_.point_to_point_above && params_.point_to_point_above > 0) {
        // Coarse phase: point-to-point, whose basin of convergence is wider. The residual
        // e = (R q + t) - p has the Jacobian [I, -[R q]x] in the pose perturbation.
        const double pp_scale =
            std::max(params_.min_kernel_scale, 1.4826 * median(pair_distances_));
        for (const Pair& pair : pairs_) {
          const double w = weight(kernel_, pair.offset.norm(), pp_scale);
          if (w <= 0) continue;
          Eigen::Matrix<double, 3, 6> j;
          j << Eigen::Matrix3d::Identity(), -skew(pair.rq);
          h.noalias() += w * j.transpose() * j;
          g.noalias() += w * j.transpose() * pair.offset;
        }
      } else {
        point_to_plane = true;
        for (const Pair& pair : pairs_) {
          const double w = weight(kernel_, pair.r, scale);
          if (w <= 0) continue;
          h.selfadjointView<Eigen::Lower>().rankUpdate(pair.j, w);
          g += w * pair.r * pair.j;
          weighted_r2 += w * pair.r * pair.r;
          weight_sum += w;
        }
      }
      h = h.selfadjointView<Eigen::Lower>();
      if (!s.anchor_precision.isZero()) {
        h.diagonal() += s.anchor_precision;
        g += s.anchor_precision.cwiseProduct(s.fromAnchor());
      }
      // A relative ridge keeps the step finite when the scan leaves a direction unconstrained
      // (e.g. one flat face): that direction then stays at the guess instead of jumping.
      h.diagonal().array() += 1e-9 * h.diagonal().maxCoeff() + 1e-12;
      const Vector6d step = -h.ldlt().solve(g);
      if (!step.allFinite())
        return numericalFailure(
            "the Gauss-Newton step of iteration {} is not finite ({} correspondences); the "
            "problem is degenerate",
            s.iterations + 1, pairs_.size());
      // Converged when the step is below the epsilons, or below convergence_sigma standard
      // deviations of the estimate (its length under the Gauss-Newton covariance): moving by a
      // small fraction of the uncertainty cannot improve the estimate. Correspondences that flip
      // between neighbouring model points can also make the pose hop back and forth: a step
      // that undoes the previous one ends the iterations halfway between the two.
      const double variance = weighted_r2 / std::max(1.0, weight_sum - 6.0);
      auto small = [&](const Vector6d& d) {
        if (d.head<3>().norm() < params_.translation_epsilon &&
            d.tail<3>().norm() < params_.rotation_epsilon)
          return true;
        return point_to_plane && params_.convergence_sigma > 0 && variance > 0 &&
               d.dot(h * d) / variance < params_.convergence_sigma * params_.convergence_sigma;
      };
      const bool hop_back = s.iterations > 0 && small(step + s.previous_step);
      const Vector6d applied = hop_back ? Vector6d(0.5 * step) : step;
      s.translation += applied.head<3>();
      s.rotation = expSO3(applied.tail<3>()).toRotationMatrix() * s.rotation;
      s.previous_step = step;
      // Shrink the correspondence distance as the alignment improves: three robust standard
      // deviations of the point-to-point distances, never below the configured floor.
      s.distance = std::clamp(3.0 * 1.4826 * median(pair_distances_),
                              params_.min_correspondence_distance, s.distance);
      if (hop_back || small(step)) {
        s.converged = true;
        ++s.iterations;
        break;
      }
    }
    return Status::ok();
  }

  /// The lookup grid of the current model for this instance's grid parameters, shared by the
  /// instances that register against the same model with the same parameters; null when the
  /// grid is off or too large.
  std::shared_ptr<NearestGrid> sharedGrid() {
    if (!(params_.lookup_grid_cell > 0)) return nullptr;
    struct Entry {
      std::uint64_t model;
      double cell, band;
      std::weak_ptr<NearestGrid> grid;
    };
    static std::mutex mutex;
    static std::vector<Entry> live;
    const std::lock_guard<std::mutex> lock(mutex);
    std::erase_if(live, [](const Entry& e) { return e.grid.expired(); });
    for (const Entry& e : live)
      if (e.model == shared_index_->builds && e.cell == params_.lookup_grid_cell &&
          e.band == params_.lookup_grid_band)
        if (std::shared_ptr<NearestGrid> grid = e.grid.lock()) return grid;
    auto grid = std::make_shared<NearestGrid>();
    if (!grid->build(shared_index_->points, params_.lookup_grid_cell, params_.lookup_grid_band,
                     kMaxGridCells))
      return nullptr;
    live.push_back(
        {shared_index_->builds, params_.lookup_grid_cell, params_.lookup_grid_band, grid});
    return grid;
  }

  /// The starting rotations of an acquisition (applied to the guess in the sensor frame): none,
  /// then turns by hypothesis_angle about hypotheses - 1 axes spread evenly over the sphere (a
  /// Fibonacci lattice), so that a guess whose attitude error is about that angle has a start
  /// within a fraction of it.
  const std::vector<Eigen::Matrix3d>& hypothesisTurns() {
    if (static_cast<int>(turns_.size()) == params_.hypotheses) return turns_;
    turns_.assign(1, Eigen::Matrix3d::Identity());
    const int n = params_.hypotheses - 1;
    const double golden = M_PI * (3.0 - std::sqrt(5.0));
    for (int k = 0; k < n; ++k) {
      const double z = 1.0 - (2.0 * k + 1.0) / n;
      const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
      const Eigen::Vector3d axis(rho * std::cos(golden * k), rho * std::sin(golden * k), z);
      turns_.push_back(Eigen::AngleAxisd(params_.hypothesis_angle, axis).toRotationMatrix());
    }
    return turns_;
  }

  /// The guess's position moved across the line of sight so that the model's centroid (at the
  /// guess's attitude) lies on the line of sight to the scan's centroid: a guess off by more
  /// than the target's size across the line of sight leaves the ICP sliding the model along
  /// the scan into a wrong minimum, while the scan's centroid, across the line of sight, is
  /// within a fraction of the target's size of its centre. Its depth stays the guess's.
  Eigen::Vector3d centredPosition(const std::vector<Eigen::Vector3f>& points,
                                  const Eigen::Isometry3d& guess) {
    if (model_centroid_for_ != shared_index_->builds) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (const Point4f& p : shared_index_->points) sum += p.vec().cast<double>();
      model_centroid_ =
          sum / static_cast<double>(std::max<std::size_t>(1, shared_index_->points.size()));
      model_centroid_for_ = shared_index_->builds;
    }
    Eigen::Vector3d scan = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3f& p : points) scan += p.cast<double>();
    scan /= static_cast<double>(std::max<std::size_t>(1, points.size()));
    const Eigen::Vector3d centre = guess * model_centroid_;
    const Eigen::Vector3d sight = (centre - viewpoint_.cast<double>()).normalized();
    Eigen::Vector3d offset = scan - centre;
    offset -= offset.dot(sight) * sight;
    return guess.translation() + offset;
  }

  /// More inliers (by more than 2 % of the scan); or as many with an inlier RMS smaller by more
  /// than 10 %; or a fit as good nearer the guess (`turn`: the angle from the guess's attitude),
  /// which is then the best information left.
  static bool betterFit(const registration::Quality& a, double a_turn,
                        const registration::Quality& b, double b_turn) {
    if (a.fitness > b.fitness + 0.02) return true;
    if (a.fitness < b.fitness - 0.02) return false;
    if (a.inlier_rms < 0.9 * b.inlier_rms) return true;
    if (b.inlier_rms < 0.9 * a.inlier_rms) return false;
    return a_turn < b_turn;
  }

  struct Pair {
    Vector6d j;              // point-to-plane Jacobian
    double r;                // point-to-plane residual, m
    Eigen::Vector3d offset;  // R q + t - p, the point-to-point residual
    Eigen::Vector3d rq;      // R q
  };

  /// Pairs every source point with its nearest (visible) model point within `distance`; false
  /// when there are fewer than min_correspondences pairs.
  bool associate(const std::vector<Eigen::Vector3f>& points, const Eigen::Matrix3d& rotation,
                 const Eigen::Vector3d& translation, double distance, bool first,
                 NearestPoints nearest) {
    pairs_.clear();
    abs_residuals_.clear();
    pair_distances_.clear();
    if (first) previous_.assign(points.size(), kNoMatch);
    const Eigen::Matrix3f r_inv = rotation.transpose().cast<float>();
    const Eigen::Vector3f t = translation.cast<float>();
    const float max_sq = static_cast<float>(distance * distance);
    // The viewpoint in the model frame: visible model points have normals facing it.
    const Eigen::Vector3f eye = r_inv * (viewpoint_ - t);
    const bool use_grid =
        grid_ready_ && nearest == NearestPoints::kGridWhereItReaches && distance <= grid_->band();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3f& p = points[i];
      const Eigen::Vector3f pm = r_inv * (p - t);
      KdTree3f::Neighbour nn;
      const bool found = use_grid ? nearestFromGrid(pm, eye, max_sq, nn)
                                  : nearestVisible(pm, eye, max_sq, previous_[i], nn);
      if (!found) {
        previous_[i] = kNoMatch;
        continue;
      }
      previous_[i] = nn.index;
      const Eigen::Vector3f nm = shared_index_->normals[nn.index].vec();
      const float r = nm.dot(pm - shared_index_->points[nn.index].vec());
      const Eigen::Vector3d n = rotation * nm.cast<double>();
      Pair pair;
      pair.j << -n, n.cross(p.cast<double>() - translation);
      pair.r = r;
      pair.rq = rotation * shared_index_->points[nn.index].vec().cast<double>();
      pair.offset = pair.rq + translation - p.cast<double>();
      pairs_.push_back(pair);
      abs_residuals_.push_back(std::abs(r));
      pair_distances_.push_back(std::sqrt(nn.squared_distance));
    }
    return pairs_.size() >= static_cast<std::size_t>(params_.min_correspondences);
  }

  bool facesEye(std::uint32_t index, const Eigen::Vector3f& eye) const {
    return shared_index_->normals[index].vec().dot(eye - shared_index_->points[index].vec()) > 0;
  }

  /// The nearest model point to `q` within sqrt(max_sq) (that faces `eye` when back faces are
  /// rejected, unless none does: the pose is then still far off and the plain nearest pulls the
  /// right way). `previous` (the match of the last iteration, or kNoMatch) bounds the search:
  /// the pose moved little, so the new match is at most about as far as the old one.
  bool nearestVisible(const Eigen::Vector3f& q, const Eigen::Vector3f& eye, float max_sq,
                      std::uint32_t previous, KdTree3f::Neighbour& found) const {
    const bool facing = params_.back_face_rejection;
    float bound = max_sq;
    if (previous != kNoMatch && (!facing || facesEye(previous, eye))) {
      const float d = (shared_index_->points[previous].vec() - q).squaredNorm();
      bound = std::min(max_sq, d * 1.0001f + 1e-12f);
    }
    auto search = [&](float b) {
      return facing ? shared_index_->tree.nearestFacing(q, eye, b, found)
                    : shared_index_->tree.nearest(q, b, found);
    };
    if (search(bound) || (bound < max_sq && search(max_sq))) return true;
    return facing && shared_index_->tree.nearest(q, max_sq, found);
  }

  /// As nearestVisible, from the lookup grid: constant time, also on thin parts where the
  /// nearest point is on the hidden side (the grid keeps the other side's nearest point).
  bool nearestFromGrid(const Eigen::Vector3f& q, const Eigen::Vector3f& eye, float max_sq,
                       KdTree3f::Neighbour& found) {
    const std::size_t cell = grid_->cellAt(q);
    if (cell == NearestGrid::kOutside) return false;
    std::uint32_t label = grid_->label(cell);
    if (label == NearestGrid::kNone) return false;  // farther than the band from the model
    if (params_.back_face_rejection && !facesEye(label, eye)) {
      const std::uint32_t other =
          grid_->opposite(cell, shared_index_->tree, shared_index_->normals);
      if (other == NearestGrid::kNone || !facesEye(other, eye))
        return nearestVisible(q, eye, max_sq, kNoMatch, found);
      label = other;
    }
    const float d = (shared_index_->points[label].vec() - q).squaredNorm();
    if (d > max_sq) return false;
    found = {label, d};
    return true;
  }

  /// The model's point spacing: the median distance from a sample of its points to their
  /// nearest neighbour.
  static double modelSpacing(const registration::ModelIndex& index) {
    std::vector<float> distances;
    std::vector<KdTree3f::Neighbour> found;
    const std::size_t n = index.points.size(), samples = std::min<std::size_t>(n, 201);
    for (std::size_t k = 0; k < samples; ++k) {
      index.tree.kNearest(index.points[k * n / samples].vec(), 2, found);
      if (found.size() == 2) distances.push_back(std::sqrt(found[1].squared_distance));
    }
    return distances.empty() ? 0.01 : median(distances);
  }

  static constexpr std::uint32_t kNoMatch = ~std::uint32_t{0};
  static constexpr std::size_t kMaxGridCells = std::size_t{1} << 24;  // 64 MB of labels
  Kernel kernel_ = Kernel::kGemanMcClure;
  std::shared_ptr<const registration::ModelIndex> shared_index_;
  std::shared_ptr<NearestGrid> grid_;  // shared like the index; null: none
  std::uint64_t grid_model_ = 0;       // shared_index_->builds the grid was built for (0: none)
  bool grid_ready_ = false;
  // Scratch kept between calls, so that a warmed-up DFI does not allocate.
  std::vector<Eigen::Vector3f> points_;
  std::vector<Pair> pairs_;
  std::vector<float> abs_residuals_, pair_distances_;
  std::vector<std::uint32_t> previous_;
  std::vector<Eigen::Matrix3d> turns_;  // hypothesisTurns(), for params_.hypotheses
  std::vector<Hypothesis> hypotheses_;  // confirm()'s followed hypotheses, best first
  Timestamp hypotheses_stamp_ = 0;      // the scan they were last followed into
  int hypotheses_scans_ = 0;            // scans scored since the set was made
  static constexpr double kSameHypothesisDistance = 0.05;           // m
  static constexpr double kSameHypothesisAngle = 2.0 * M_PI / 180;  // rad
  // misfit()'s cost of an unmatched return: (inlier_distance / sigma)^2 with sigma a third of it.
  static constexpr double kUnmatchedCost = 9.0;
  Eigen::Vector3d model_centroid_ = Eigen::Vector3d::Zero();
  std::uint64_t model_centroid_for_ = 0;  // shared_index_->builds it was computed for (0: none)
  Eigen::Vector3f viewpoint_ = Eigen::Vector3f::Zero();
  RingVisibility visibility_;
  double model_spacing_ = 0.01;
  std::uint64_t spacing_for_ = 0;  // shared_index_->builds model_spacing_ is of (0: none)
};

CDFF_REGISTER_DFI(Registration3DFastIcp);

}  // namespace cdff::dfn
