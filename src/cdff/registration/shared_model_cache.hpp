#pragma once
// Process-wide sharing of the search structures over a model. The registrations of a process
// that register against the same model buffer (a DFPC's acquisition and tracking registrations,
// two DFN instances fed by one model node) share one ModelIndex (its KD-tree) and, for equal grid
// options, one NearestGrid: the first to see the model builds them, the others reuse them, so a
// registration that starts later (tracking, after the acquisition) does not spend its first call
// building the same structures.
//
// The cache holds weak references: the structures live as long as a registration uses them, and
// a model buffer that no registration holds any more is forgotten. Thread-safe: registrations in
// different threads may ask at once (one lock per kind of structure); the index is immutable
// once built, and the grid's lazily filled part has its own lock (NearestGrid::opposite).

#include <memory>

#include "cdff/registration/model_index.hpp"
#include "cdff/registration/nearest_grid.hpp"
#include "cdff/types/point_cloud.hpp"
#include "cdff/types/status.hpp"

namespace cdff::registration {

class SharedModelCache {
 public:
  /// The ModelIndex of `model`: `current` as it is when it holds the model, else the one a
  /// registration of the process built for the same buffer, else a new one (an error when the
  /// model is not valid: ModelIndex::update).
  static Result<std::shared_ptr<const ModelIndex>> index(
      const PointCloud& model, const std::shared_ptr<const ModelIndex>& current);

  /// The lookup grid over `index` with `options`, shared likewise; null when options.cell is 0
  /// (no grid) or the grid would exceed NearestGrid::kMaxCells cells.
  static std::shared_ptr<NearestGrid> grid(const ModelIndex& index,
                                           const NearestGridOptions& options);
};

}  // namespace cdff::registration
