#include "cdff/registration/ring_visibility.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "cdff/registration/median.hpp"

namespace cdff::registration {

void RingVisibility::groupRings(std::span<const Eigen::Vector3f> points,
                                std::span<const double> lasers, std::vector<float>& ranges) {
  struct Return {
    float elevation, azimuth, range;
    std::size_t laser = 0;
  };
  std::vector<Return> returns;
  returns.reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    const Eigen::Vector3f d = p - viewpoint_;
    const float range = d.norm();
    if (!(range > 0)) continue;
    returns.push_back(
        {std::asin(std::clamp(d.z() / range, -1.0f, 1.0f)), std::atan2(d.y(), d.x()), range});
  }
  if (returns.size() < 3) return;
  std::sort(returns.begin(), returns.end(),
            [](const Return& a, const Return& b) { return a.elevation < b.elevation; });
  // With the sensor's lasers, a return belongs to the laser nearest its elevation: a thinned
  // scan's voxel centroid that averages two lasers' returns (a voxel as tall as the lasers'
  // spacing at close range) or a de-skewed return lies between two lasers, and would otherwise
  // start a ring of its own. Without them, returns within kSameRing of each other are one ring.
  if (!lasers.empty())
    for (Return& r : returns) r.laser = nearestLaser(lasers, r.elevation);
  for (std::size_t i = 0; i < returns.size();) {
    std::size_t j = i + 1;
    while (j < returns.size() &&
           (lasers.empty() ? returns[j].elevation - returns[j - 1].elevation < kSameRing
                           : returns[j].laser == returns[i].laser))
      ++j;
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
}

std::size_t RingVisibility::nearestLaser(std::span<const double> lasers, float elevation) {
  if (lasers.empty()) return 0;
  const auto it = std::lower_bound(lasers.begin(), lasers.end(), static_cast<double>(elevation));
  auto k = static_cast<std::size_t>(it - lasers.begin());
  if (k == lasers.size() || (k > 0 && elevation - lasers[k - 1] < lasers[k] - elevation)) --k;
  return k;
}

void RingVisibility::addEmptyNeighbours(std::span<const double> lasers) {
  if (lasers.empty()) return;
  // Each observed ring is the sensor's laser nearest to its elevation. The neighbour's ring is
  // the observed ring's elevation plus the sensor's step between the two lasers, so that an
  // offset all lasers share (a calibration error of their elevations) carries over to it.
  const float lo = rings_.front().elevation, hi = rings_.back().elevation;
  const std::size_t low = nearestLaser(lasers, lo), high = nearestLaser(lasers, hi);
  if (low > 0)
    rings_.insert(rings_.begin(),
                  Ring{lo + static_cast<float>(lasers[low - 1] - lasers[low]), {}, {}, 0, 0});
  if (high + 1 < lasers.size())
    rings_.push_back(Ring{hi + static_cast<float>(lasers[high + 1] - lasers[high]), {}, {}, 0, 0});
}

bool RingVisibility::setScan(std::span<const Eigen::Vector3f> points,
                             const Eigen::Vector3f& viewpoint, std::span<const double> lasers) {
  rings_.clear();
  viewpoint_ = viewpoint;
  std::vector<float> ranges;
  groupRings(points, lasers, ranges);
  if (rings_.empty()) return false;
  // The azimuth step of the returns along a ring (the firing step, or the voxel grid's at close
  // range): the bin of predicted surface, and the gap a return may be away.
  std::vector<float> gaps;
  for (const Ring& ring : rings_)
    for (std::size_t k = 1; k < ring.azimuths.size(); ++k)
      gaps.push_back(ring.azimuths[k] - ring.azimuths[k - 1]);
  if (gaps.empty()) return false;
  const float step = std::max(static_cast<float>(median(gaps)), 1e-4f);
  const float range = static_cast<float>(median(ranges));
  addEmptyNeighbours(lasers);
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

double RingVisibility::evaluate(const ModelIndex& model, double model_spacing,
                                const Eigen::Isometry3d& pose, double through) {
  if (rings_.empty()) return 0;
  const Eigen::Matrix3f r = pose.linear().cast<float>();
  const Eigen::Vector3f t = pose.translation().cast<float>();
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

bool RingVisibility::seen(const Ring& ring, float azimuth, float tolerance, float max_range) {
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

}  // namespace cdff::registration
