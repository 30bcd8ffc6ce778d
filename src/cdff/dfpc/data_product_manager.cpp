#include "cdff/dfpc/data_product_manager.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace cdff::dfpc {

DataProductManager::DataProductManager(std::size_t default_history)
    : default_history_(std::max<std::size_t>(default_history, 1)) {}

Status DataProductManager::typeError(const Product& p, std::string_view expected) {
  return invalidInput("product '{}' holds {} values; expected {}", p.name, p.type().name(),
                      expected);
}

std::shared_ptr<DataProductManager::Series> DataProductManager::find(
    const std::string& name) const {
  std::shared_lock lock(mutex_);
  auto it = series_.find(name);
  return it == series_.end() ? nullptr : it->second;
}

std::shared_ptr<DataProductManager::Series> DataProductManager::findOrAdd(const std::string& name) {
  if (auto s = find(name)) return s;
  std::unique_lock lock(mutex_);
  auto& slot = series_[name];
  if (!slot) {
    slot = std::make_shared<Series>();
    auto limit = limits_.find(name);
    slot->limit = limit == limits_.end() ? default_history_ : limit->second;
  }
  return slot;
}

Status DataProductManager::publish(const std::string& name, Timestamp stamp, Value value) {
  if (name.empty()) return invalidInput("a product needs a name");
  if (value.empty()) return invalidInput("product '{}' at t = {} us: no value", name, stamp);
  const TypeId type = value.type();
  std::shared_ptr<Series> s = findOrAdd(name);
  std::unique_lock lock(s->mutex);
  if (s->samples.empty() && !s->type) s->type = type;
  if (s->type != type)
    return invalidInput("product '{}' holds {} values; got a {} at t = {} us", name, s->type.name(),
                        type.name(), stamp);
  Product p{name, stamp, std::move(value)};
  if (s->samples.empty() || s->samples.back().stamp <= stamp) {
    s->samples.push_back(std::move(p));
  } else {
    auto pos = std::upper_bound(s->samples.begin(), s->samples.end(), stamp,
                                [](Timestamp t, const Product& q) { return t < q.stamp; });
    s->samples.insert(pos, std::move(p));
  }
  while (s->samples.size() > s->limit) s->samples.pop_front();
  return Status::ok();
}

Status DataProductManager::setHistoryLimit(const std::string& name, std::size_t samples) {
  if (samples == 0) return invalidInput("product '{}': history limit 0; expected >= 1", name);
  {
    std::unique_lock lock(mutex_);
    limits_[name] = samples;
  }
  if (auto s = find(name)) {
    std::unique_lock lock(s->mutex);
    s->limit = samples;
    while (s->samples.size() > s->limit) s->samples.pop_front();
  }
  return Status::ok();
}

Result<Product> DataProductManager::latest(const std::string& name) const {
  std::shared_ptr<Series> s = find(name);
  if (!s) return notFound("no product '{}'", name);
  std::shared_lock lock(s->mutex);
  if (s->samples.empty()) return notFound("product '{}' has no sample", name);
  return s->samples.back();
}

Result<Product> DataProductManager::atOrBefore(const std::string& name, Timestamp t) const {
  std::shared_ptr<Series> s = find(name);
  if (!s) return notFound("no product '{}'", name);
  std::shared_lock lock(s->mutex);
  auto it = std::upper_bound(s->samples.begin(), s->samples.end(), t,
                             [](Timestamp x, const Product& q) { return x < q.stamp; });
  if (it == s->samples.begin())
    return notFound(
        "product '{}' has no sample at or before t = {} us{}", name, t,
        s->samples.empty() ? "" : fmt::format(" (oldest kept: {} us)", s->samples.front().stamp));
  return *std::prev(it);
}

Result<std::vector<Product>> DataProductManager::history(const std::string& name) const {
  std::shared_ptr<Series> s = find(name);
  if (!s) return notFound("no product '{}'", name);
  std::shared_lock lock(s->mutex);
  return std::vector<Product>(s->samples.begin(), s->samples.end());
}

std::vector<std::string> DataProductManager::names() const {
  std::shared_lock lock(mutex_);
  std::vector<std::string> out;
  for (const auto& [name, s] : series_) out.push_back(name);
  return out;
}

bool DataProductManager::contains(const std::string& name) const {
  return find(name) != nullptr;
}

void DataProductManager::clear() {
  std::unique_lock lock(mutex_);
  for (auto& [name, s] : series_) {
    std::unique_lock series_lock(s->mutex);
    s->samples.clear();
  }
}

// ---------------------------------------------------------------------------------------------
// Interpolation

namespace {

Result<PoseWithCovariance> asPose(const Product& p) {
  if (auto v = p.as<PoseWithCovariance>()) return *v;
  if (auto v = p.as<RigidBodyState>()) return v->poseWithCovariance();
  if (auto v = p.as<Transform>()) return PoseWithCovariance{*v, Matrix6d::Zero()};
  return invalidInput(
      "product '{}' holds {} values; expected PoseWithCovariance, RigidBodyState "
      "or Transform",
      p.name, p.type().name());
}

// The two samples around t (equal when t hits one), or an error outside the history.
Status bracket(const std::deque<Product>& samples, const std::string& name, Timestamp t,
               const Product*& a, const Product*& b) {
  if (samples.empty()) return notFound("product '{}' has no sample", name);
  if (t < samples.front().stamp || t > samples.back().stamp)
    return notFound(
        "product '{}': t = {} us is outside the kept history [{}, {}] us; the DPM "
        "interpolates, it does not extrapolate",
        name, t, samples.front().stamp, samples.back().stamp);
  auto it = std::lower_bound(samples.begin(), samples.end(), t,
                             [](const Product& q, Timestamp x) { return q.stamp < x; });
  b = &*it;
  a = (it->stamp == t || it == samples.begin()) ? b : &*std::prev(it);
  return Status::ok();
}

double fraction(Timestamp ta, Timestamp tb, Timestamp t) {
  return tb == ta ? 0.0 : static_cast<double>(t - ta) / static_cast<double>(tb - ta);
}

}  // namespace

Result<PoseWithCovariance> interpolatePose(const PoseWithCovariance& a, const PoseWithCovariance& b,
                                           Timestamp t) {
  if (a.pose.parent_frame != b.pose.parent_frame || a.pose.child_frame != b.pose.child_frame)
    return invalidInput(
        "cannot interpolate between poses {}_T_{} and {}_T_{}; expected the same "
        "frames",
        a.pose.parent_frame, a.pose.child_frame, b.pose.parent_frame, b.pose.child_frame);
  const double f = fraction(a.pose.stamp, b.pose.stamp, t);
  PoseWithCovariance out = a;
  out.pose.stamp = t;
  out.pose.translation = (1 - f) * a.pose.translation + f * b.pose.translation;
  out.pose.rotation = a.pose.rotation.slerp(f, b.pose.rotation).normalized();
  out.covariance = (1 - f) * a.covariance + f * b.covariance;
  return out;
}

Result<PoseWithCovariance> DataProductManager::poseAt(const std::string& name, Timestamp t) const {
  std::shared_ptr<Series> s = find(name);
  if (!s) return notFound("no product '{}'", name);
  std::shared_lock lock(s->mutex);
  const Product *a = nullptr, *b = nullptr;
  CDFF_RETURN_IF_ERROR(bracket(s->samples, name, t, a, b));
  Result<PoseWithCovariance> pa = asPose(*a);
  if (!pa) return pa.status();
  Result<PoseWithCovariance> pb = asPose(*b);
  if (!pb) return pb.status();
  // Interpolate on the product stamps (the pose's own stamp may differ, e.g. a prediction).
  pa->pose.stamp = a->stamp;
  pb->pose.stamp = b->stamp;
  return interpolatePose(*pa, *pb, t);
}

Result<RigidBodyState> DataProductManager::stateAt(const std::string& name, Timestamp t) const {
  std::shared_ptr<Series> s = find(name);
  if (!s) return notFound("no product '{}'", name);
  std::shared_lock lock(s->mutex);
  const Product *a = nullptr, *b = nullptr;
  CDFF_RETURN_IF_ERROR(bracket(s->samples, name, t, a, b));
  auto sa = a->as<RigidBodyState>();
  auto sb = b->as<RigidBodyState>();
  if (!sa || !sb) return typeError(*a, "RigidBodyState");
  PoseWithCovariance pa{sa->pose, Matrix6d::Zero()}, pb{sb->pose, Matrix6d::Zero()};
  pa.pose.stamp = a->stamp;
  pb.pose.stamp = b->stamp;
  Result<PoseWithCovariance> pose = interpolatePose(pa, pb, t);
  if (!pose) return pose.status();
  const double f = fraction(a->stamp, b->stamp, t);
  RigidBodyState out;
  out.pose = pose->pose;
  out.twist.linear = (1 - f) * sa->twist.linear + f * sb->twist.linear;
  out.twist.angular = (1 - f) * sa->twist.angular + f * sb->twist.angular;
  out.covariance = (1 - f) * sa->covariance + f * sb->covariance;
  return out;
}

}  // namespace cdff::dfpc
