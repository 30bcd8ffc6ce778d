#pragma once
// The Data Product Manager (seed §4.1, §7.2.4): the store of the products that DFPCs publish and
// that other DFPCs, the external API and the operator read.
//
// A product is a named series of timestamped, immutable values of one type (pose and velocity
// with covariance, point cloud maps, meshes, models...): `<dfpc>/<output>` for DFPC outputs.
// Each series keeps a bounded history (oldest dropped first). Readers get shared pointers to
// the immutable values, never copies, and never wait for a writer longer than one insertion.
// Thread-safe: any number of readers and writers (a std::shared_mutex guards the index, each
// series has its own).
//
// Queries: latest, at or before t, and a pose interpolated at t (translation linearly, rotation
// by slerp, covariance as the same convex combination of the two covariances; t must lie within
// the history: the DPM does not extrapolate).
//
// save()/restore() write a directory: products.json (the index: names, types, history limits,
// stamps, and the small values inline) plus one file per sample of the other types: binary PLY
// for point clouds and meshes, the MCAP message for the rest (docs/dfpc.md). Each type's form is
// in the type registry.

#include <cstddef>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <string>
#include <vector>

#include "cdff/types/geometry.hpp"
#include "cdff/types/status.hpp"
#include "cdff/types/time.hpp"
#include "cdff/types/type_registry.hpp"
#include "cdff/types/value.hpp"

namespace cdff::dfpc {

struct Product {
  std::string name;
  Timestamp stamp = 0;
  Value value;

  TypeId type() const { return value.type(); }
  template <RegisteredType T>
  std::shared_ptr<const T> as() const {
    return value.as<T>();
  }
};

class DataProductManager {
 public:
  static constexpr std::size_t kDefaultHistory = 100;

  explicit DataProductManager(std::size_t default_history = kDefaultHistory);

  /// Adds a sample. The first sample fixes a product's type; another type later is an error.
  /// Samples may arrive out of order; the history stays sorted by stamp.
  Status publish(const std::string& name, Timestamp stamp, Value value);
  template <RegisteredType T>
  Status publish(const std::string& name, Timestamp stamp, std::shared_ptr<const T> value) {
    return publish(name, stamp, Value::of<T>(std::move(value)));
  }
  template <RegisteredType T>
  Status publish(const std::string& name, Timestamp stamp, T value) {
    return publish<T>(name, stamp, std::make_shared<const T>(std::move(value)));
  }

  /// Bounds a product's history (at least 1); applies to a product not yet published too.
  Status setHistoryLimit(const std::string& name, std::size_t samples);

  Result<Product> latest(const std::string& name) const;
  /// The newest sample with stamp <= t.
  Result<Product> atOrBefore(const std::string& name, Timestamp t) const;
  /// All samples, oldest first.
  Result<std::vector<Product>> history(const std::string& name) const;

  template <RegisteredType T>
  Result<std::shared_ptr<const T>> latestAs(const std::string& name) const {
    Result<Product> p = latest(name);
    if (!p) return p.status();
    if (auto v = p->as<T>()) return v;
    return typeError(*p, TypeTraits<T>::name);
  }

  /// The pose of a PoseWithCovariance, RigidBodyState or Transform product at t, interpolated
  /// between the samples around t (exact at a sample). Twist and the velocity part of a
  /// RigidBodyState's covariance are not returned here; see stateAt().
  Result<PoseWithCovariance> poseAt(const std::string& name, Timestamp t) const;
  /// A RigidBodyState product at t: pose as poseAt(), twist and the full covariance
  /// interpolated linearly.
  Result<RigidBodyState> stateAt(const std::string& name, Timestamp t) const;

  /// Product names, sorted.
  std::vector<std::string> names() const;
  bool contains(const std::string& name) const;
  /// Removes every sample (history limits stay).
  void clear();

  /// Writes every product to `directory` (created if needed; an existing index is replaced). An
  /// error names each product or sample that could not be written; the others are written.
  Status save(const std::string& directory) const;
  /// Replaces the contents with what save() wrote to `directory`.
  Status restore(const std::string& directory);

 private:
  struct Series {
    TypeId type;
    std::size_t limit = 0;
    std::deque<Product> samples;  // sorted by stamp, at most `limit`
    mutable std::shared_mutex mutex;
  };

  static Status typeError(const Product& p, std::string_view expected);
  std::shared_ptr<Series> find(const std::string& name) const;
  std::shared_ptr<Series> findOrAdd(const std::string& name);

  std::size_t default_history_;
  mutable std::shared_mutex mutex_;  // guards series_ (the map), not the series themselves
  std::map<std::string, std::shared_ptr<Series>> series_;
  std::map<std::string, std::size_t> limits_;  // set before a product exists
};

/// Pose interpolation between two samples (fraction in [0, 1] from a to b): translation linear,
/// rotation slerp, covariance (1 - f) Pa + f Pb. Frames must agree.
Result<PoseWithCovariance> interpolatePose(const PoseWithCovariance& a, const PoseWithCovariance& b,
                                           Timestamp t);

}  // namespace cdff::dfpc
