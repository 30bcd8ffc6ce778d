#include "cdff/registration/shared_model_cache.hpp"

#include <cstdint>
#include <mutex>
#include <utility>
#include <vector>

namespace cdff::registration {

Result<std::shared_ptr<const ModelIndex>> SharedModelCache::index(
    const PointCloud& model, const std::shared_ptr<const ModelIndex>& current) {
  if (current && current->holds(model)) return current;
  static std::mutex mutex;
  static std::vector<std::weak_ptr<const ModelIndex>> live;
  const std::lock_guard<std::mutex> lock(mutex);
  std::erase_if(live, [](const std::weak_ptr<const ModelIndex>& w) { return w.expired(); });
  for (const std::weak_ptr<const ModelIndex>& w : live)
    if (std::shared_ptr<const ModelIndex> index = w.lock(); index && index->holds(model))
      return index;
  auto fresh = std::make_shared<ModelIndex>();
  CDFF_RETURN_IF_ERROR(fresh->update(model));
  live.push_back(fresh);
  return std::shared_ptr<const ModelIndex>(std::move(fresh));
}

std::shared_ptr<NearestGrid> SharedModelCache::grid(const ModelIndex& index,
                                                    const NearestGridOptions& options) {
  if (!(options.cell > 0)) return nullptr;
  struct Entry {
    std::uint64_t model;  // ModelIndex::builds
    double cell, band;
    std::weak_ptr<NearestGrid> grid;
  };
  static std::mutex mutex;
  static std::vector<Entry> live;
  const std::lock_guard<std::mutex> lock(mutex);
  std::erase_if(live, [](const Entry& e) { return e.grid.expired(); });
  for (const Entry& e : live)
    if (e.model == index.builds && e.cell == options.cell && e.band == options.band)
      if (std::shared_ptr<NearestGrid> grid = e.grid.lock()) return grid;
  auto grid = std::make_shared<NearestGrid>();
  if (!grid->build(index.points, options.cell, options.band, NearestGrid::kMaxCells))
    return nullptr;
  live.push_back({index.builds, options.cell, options.band, grid});
  return grid;
}

}  // namespace cdff::registration
