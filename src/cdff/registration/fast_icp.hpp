#pragma once
// FastIcp: the registration of a LIDAR scan against a dense model with normals, composed of the
// library's stages (as KISS-ICP's pipeline composes its own):
//
//   prepare(model)   the model's index and lookup grid, shared through SharedModelCache
//   registerScan()   [multi-start search -> (multi-scan confirmation | best start)] -> ICP to
//                    convergence -> exact refinement with the KD-tree -> quality, visibility
//
// With one start it is a tracking registration from the guess; with several, an acquisition.
// Every stage returns its result; the object keeps only what must outlive a scan (the shared
// model structures, the confirmation's hypotheses, scratch reused without allocating).

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "cdff/registration/hypothesis_confirmation.hpp"
#include "cdff/registration/icp.hpp"
#include "cdff/registration/multi_start.hpp"
#include "cdff/registration/nearest_grid.hpp"
#include "cdff/registration/quality.hpp"
#include "cdff/registration/ring_visibility.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"

namespace cdff::registration {

struct FastIcpOptions {
  IcpOptions icp;
  int max_iterations = 30;  // of the registration from the guess or the chosen start
  /// After converging with the lookup grid, at most this many iterations with the KD-tree's
  /// exact nearest points (the grid's point can be on the neighbouring face near an edge).
  int exact_refinement_iterations = 0;
  QualityOptions quality;
  NearestGridOptions grid;
  MultiStartOptions multi_start;
  bool visibility_check = false;     // compute the visibility (RingVisibility)
  ConfirmationOptions confirmation;  // its registration fields are filled by configure()
};

/// What preparing a model found.
struct ModelPreparation {
  /// The model is new and its lookup grid would exceed NearestGrid::kMaxCells cells: only the
  /// KD-tree is used.
  bool grid_too_large = false;
};

/// The registration of one scan.
struct Registration {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // source_T_model; the guess if starved
  Quality quality;
  /// The ICP's final state (converged, starved, iterations, ...); its pose is `pose` before the
  /// re-orthonormalisation.
  IcpRun run;
  bool ambiguous = false;  // one of several hypotheses, not yet confirmed
  double visibility = std::numeric_limits<double>::quiet_NaN();  // NaN without visibility_check
};

class FastIcp {
 public:
  /// New options; with other grid options the lookup grid is fetched again at the next
  /// prepare() (the model stays prepared otherwise).
  void configure(const FastIcpOptions& options);

  /// The search structures over `model`, shared with every registration of the process that
  /// registers against the same buffer; built when the buffer is new.
  Result<ModelPreparation> prepare(const PointCloud& model);

  /// Registers `points` (source frame, the scan's sensor at options.icp.association.viewpoint)
  /// against the prepared model from source_T_model `guess`; `stamp` orders the scans for the
  /// confirmation. `lasers`: the sensor's distinct laser elevations (rad), lowest first, for the
  /// visibility's empty rings (RingVisibility::setScan); empty: only the rings with returns.
  /// `guess_position_covariance` (source frame, m^2): how far the guess's position may be off;
  /// an acquisition then also starts at other depths along the line of sight (depthStarts).
  Result<Registration> registerScan(
      std::span<const Eigen::Vector3f> points, const Eigen::Isometry3d& guess, Timestamp stamp,
      std::span<const double> lasers = {},
      const std::optional<Eigen::Matrix3d>& guess_position_covariance = std::nullopt);

 private:
  /// The acquisition's choice of a start (multi-start search, then confirmation or the best
  /// fit); none leaves the guess.
  Result<ConfirmationResult> acquire(std::span<const Eigen::Vector3f> points,
                                     const Eigen::Isometry3d& guess, Timestamp stamp,
                                     bool visibility_check,
                                     const std::optional<Eigen::Matrix3d>& position_covariance);
  double visibilityAt(const Eigen::Isometry3d& pose);
  const std::vector<Eigen::Matrix3d>& turns();

  FastIcpOptions options_;
  Icp icp_;
  ModelSearch model_;
  std::uint64_t grid_model_ = 0;  // model_.index->builds the grid was fetched for (0: none)
  double model_spacing_ = 0.01;
  std::uint64_t spacing_for_ = 0;  // model_.index->builds model_spacing_ is of (0: none)
  Eigen::Vector3d model_centroid_ = Eigen::Vector3d::Zero();
  std::uint64_t centroid_for_ = 0;      // model_.index->builds model_centroid_ is of (0: none)
  std::vector<Eigen::Matrix3d> turns_;  // startTurns() for multi_start.hypotheses
  RingVisibility visibility_;
  HypothesisConfirmation confirmation_;
};

}  // namespace cdff::registration
