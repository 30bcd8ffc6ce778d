#pragma once
// How much of the model surface that a spinning LIDAR's lasers would hit at a pose the scan
// confirms: the free-space evidence that the fitness lacks. A sparse scan (a few rings on the
// target at 15 m) fits a model slid along a panel, or turned by 15 degrees, as well as the right
// pose, since every return still lies on some model surface; but such a pose puts model surface
// where the lasers fired and saw nothing (or saw farther), which the right pose does not.
// The lasers are cones about the source frame's z axis through the viewpoint (a VLP-16 in its
// own frame); the rings are those the scan's returns lie on, plus, when the sensor's laser
// elevations are given (its LidarInfo), the sensor's lasers just below the lowest and just above
// the highest of them, which saw nothing of the target. With the elevations a return belongs to
// its nearest laser (a thinned scan's centroids and de-skewed returns lie between lasers);
// without them only the rings with returns count, returns within kSameRing being one ring.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/registration/model_index.hpp"

namespace cdff::registration {

class RingVisibility {
 public:
  /// Returns of one laser share its elevation to float precision (the range noise is along the
  /// ray); lasers closer than this (rad) are one ring.
  static constexpr float kSameRing = 0.25f * static_cast<float>(M_PI / 180.0);

  /// The rings and the returns along each, from the scan (sensor at `viewpoint`); false when it
  /// has no ring with enough returns to measure the azimuth step. `lasers`: the sensor's
  /// distinct laser elevations (rad), lowest first, for the empty rings next to the observed
  /// ones; empty: only the observed rings.
  bool setScan(std::span<const Eigen::Vector3f> points, const Eigen::Vector3f& viewpoint,
               std::span<const double> lasers);

  bool empty() const { return rings_.empty(); }

  /// The fraction of the model's visible surface on the rings at source_T_model `pose` that has
  /// a return within 1.5 azimuth steps, not farther than `through` behind it (a return well
  /// behind means the laser went through where the model has surface). 0 when no model surface
  /// falls on a ring. `model_spacing`: the model's point spacing (modelSpacing()).
  double evaluate(const ModelIndex& model, double model_spacing, const Eigen::Isometry3d& pose,
                  double through);

 private:
  struct Ring {
    float elevation = 0;
    std::vector<float> azimuths;  // of its returns, sorted
    std::vector<float> ranges;    // of the same returns
    float bin = 0;                // azimuth step, rad
    std::size_t bins = 0;
  };

  /// The rings the returns lie on, lowest first (one per laser of `lasers` with returns, when
  /// given); the ranges of all returns into `ranges`.
  void groupRings(std::span<const Eigen::Vector3f> points, std::span<const double> lasers,
                  std::vector<float>& ranges);
  /// The index of the laser of `lasers` (sorted) nearest `elevation`; 0 when there is none.
  static std::size_t nearestLaser(std::span<const double> lasers, float elevation);
  /// The rings of the lasers next to the lowest and the highest observed ring, where the sensor
  /// has them (`lasers` sorted).
  void addEmptyNeighbours(std::span<const double> lasers);
  /// A return of `ring` within `tolerance` of `azimuth` (either side of the +-pi seam), nearer
  /// than `max_range`.
  static bool seen(const Ring& ring, float azimuth, float tolerance, float max_range);

  static constexpr std::size_t kModelSamples = 40000;
  std::vector<Ring> rings_;
  Eigen::Vector3f viewpoint_ = Eigen::Vector3f::Zero();
  float range_ = 1;
  std::vector<std::size_t> offsets_;  // first bin of each ring in nearest_
  std::vector<float> nearest_;        // range of the nearest model point in each bin
  std::vector<std::uint8_t> facing_;  // whether that point faces the sensor
  std::vector<std::uint32_t> touched_;
};

}  // namespace cdff::registration
