#include "cdff/dfpc/api.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <map>
#include <mutex>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/dfpc/designation.hpp"
#include "cdff/dfpc/orchestrator.hpp"

namespace cdff::api {

namespace {

// Every public function runs its body through this: an exception never crosses the API.
template <typename R, typename F>
R guarded(const char* function, F&& body) noexcept {
  try {
    return body();
  } catch (const std::exception& e) {
    return Status(StatusCode::kInternal,
                  fmt::format("{}: unexpected exception: {}", function, e.what()));
  } catch (...) {
    return Status(StatusCode::kInternal, fmt::format("{}: unexpected exception", function));
  }
}

Matrix6d rotateCovariance(const Matrix6d& covariance, const Eigen::Matrix3d& r) {
  Matrix6d big = Matrix6d::Zero();
  big.topLeftCorner<3, 3>() = r;
  big.bottomRightCorner<3, 3>() = r;
  return big * covariance * big.transpose();
}

}  // namespace

const char* toString(CdffState state) {
  switch (state) {
    case CdffState::kUninitialised:
      return "uninitialised";
    case CdffState::kRunning:
      return "running";
    case CdffState::kIdle:
      return "idle";
    case CdffState::kStopped:
      return "stopped";
  }
  return "?";
}

const char* toString(StateRequest request) {
  switch (request) {
    case StateRequest::kInitialize:
      return "initialize";
    case StateRequest::kIdle:
      return "idle";
    case StateRequest::kReset:
      return "reset";
    case StateRequest::kStop:
      return "stop";
  }
  return "?";
}

struct Cdff::Impl {
  struct Subscription {
    enum class Kind { kPose, kStatus } kind;
    std::string dfpc;
    std::string product;  // for poses
    Timestamp period = 0;
    Timestamp next_due = 0;
    PoseCallback pose;
    StatusCallback status;
  };

  Config config;
  std::shared_ptr<dfpc::Clock> clock;
  dfpc::SimulatedClock* simulated = nullptr;  // when the clock is one (participant protocol)
  std::shared_ptr<dfpc::LiveStream> live;
  std::shared_ptr<dfpc::InputStream> input;
  std::unique_ptr<dfpc::Orchestrator> orchestrator;

  // State and input thread.
  mutable std::mutex mutex;
  std::condition_variable changed;  // state, progress, shutdown
  CdffState state = CdffState::kUninitialised;
  bool shutting_down = false;
  std::uint64_t pushed = 0, processed = 0;
  // What the input has shown so far, for designations: the stream time (the latest message's
  // stamp) and each channel's latest image. The mutex is held while a message is processed, so
  // that a designation goes in at the stream time of the images it was drawn on.
  struct ImageSeen {
    int width = 0, height = 0;
    Timestamp stamp = 0;
    std::string frame_id;
  };
  std::mutex process_mutex;
  std::optional<Timestamp> stream_time;
  std::map<std::string, ImageSeen> images;
  bool input_ended = false;
  Status input_error;
  std::thread input_thread;

  // Subscriptions.
  std::mutex subscription_mutex;  // guards the members below (scheduler_id is set once)
  std::condition_variable callbacks_done;
  std::map<SubscriptionId, Subscription> subscriptions;
  SubscriptionId next_id = 1;
  bool running_callbacks = false;
  bool scheduler_stop = false;
  std::thread scheduler;
  std::thread::id scheduler_id;

  Status invalidRequest(StateRequest request, const char* accepted) const {
    return invalidInput("setCDFFState({}) in state {}; accepted here: {}", toString(request),
                        toString(state), accepted);
  }

  // ---- input thread ---------------------------------------------------------------------------
  void consumeInput() {
    std::optional<Timestamp> wall_start, stream_start;
    for (;;) {
      {
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return shutting_down || state == CdffState::kRunning; });
        if (shutting_down) return;
      }
      Result<std::optional<dfpc::Message>> next = input->next();
      if (!next || !next.value()) {
        (void)orchestrator->finish();
        std::lock_guard lock(mutex);
        input_ended = true;
        if (!next) input_error = next.status();
        changed.notify_all();
        return;
      }
      const dfpc::Message& m = *next.value();
      {
        // Paused after the message was read: it waits (a message is never dropped here).
        std::unique_lock lock(mutex);
        changed.wait(lock, [&] { return shutting_down || state == CdffState::kRunning; });
        if (shutting_down) return;
      }
      if (config.realtime && !live) {
        if (!wall_start) {
          wall_start = clock->now();
          stream_start = m.stamp;
        }
        const Timestamp due = *wall_start + (m.stamp - *stream_start);
        for (;;) {
          // The interrupt count is read before checking for shutdown: the destructor's
          // interrupt cannot fall between the check and the sleep.
          const std::uint64_t interrupts = clock->interrupts();
          if (isShuttingDown() || clock->now() >= due) break;
          clock->sleepUntil(due, interrupts);
        }
      }
      processInput(m);
      std::lock_guard lock(mutex);
      ++processed;
      changed.notify_all();
    }
  }

  void processInput(const dfpc::Message& m) {
    std::lock_guard lock(process_mutex);
    if (const Image* image = m.as<Image>())
      images[m.channel] = {image->width, image->height, m.stamp, image->frame_id};
    stream_time = stream_time ? std::max(*stream_time, m.stamp) : m.stamp;
    // Faults are events; an error here is a message that fits no input (also an event).
    (void)orchestrator->process(m);
  }

  bool isShuttingDown() {
    std::lock_guard lock(mutex);
    return shutting_down;
  }

  // ---- subscriptions --------------------------------------------------------------------------
  void schedule() {
    std::unique_lock lock(subscription_mutex);
    while (!scheduler_stop) {
      // Read under the lock: a subscription added after this interrupts the sleep below.
      const std::uint64_t interrupts = clock->interrupts();
      Timestamp next = dfpc::kForever;
      for (const auto& [id, s] : subscriptions) next = std::min(next, s.next_due);
      lock.unlock();
      clock->sleepUntil(next, interrupts);
      lock.lock();
      if (scheduler_stop) break;
      const Timestamp now = clock->now();
      std::vector<Subscription> due;
      for (auto& [id, s] : subscriptions) {
        if (s.next_due > now) continue;
        due.push_back(s);
        // A late scheduler skips the periods it missed rather than bursting callbacks.
        while (s.next_due <= now) s.next_due += s.period;
      }
      if (due.empty()) continue;
      running_callbacks = true;
      lock.unlock();
      for (const Subscription& s : due) call(s, now);
      lock.lock();
      running_callbacks = false;
      callbacks_done.notify_all();
    }
    lock.unlock();
    if (simulated) simulated->removeParticipant();
  }

  void call(const Subscription& s, Timestamp now) {
    try {
      if (s.kind == Subscription::Kind::kPose)
        s.pose(now, poseOf(s.product));
      else
        s.status(now, orchestrator->status(s.dfpc));
    } catch (...) {
      // A callback that throws does not stop the others; it is the caller's own fault.
    }
  }

  Result<PoseWithCovariance> poseOf(const std::string& product) const {
    Result<dfpc::Product> p = orchestrator->products().latest(product);
    if (!p) return p.status();
    if (auto pose = p->as<PoseWithCovariance>()) return *pose;
    if (auto state = p->as<RigidBodyState>()) return state->poseWithCovariance();
    return invalidInput("product '{}' holds {} values; expected a pose", product, p->type().name());
  }

  Result<SubscriptionId> subscribe(Subscription s, double frequency_hz) {
    if (!(frequency_hz > 0) || frequency_hz > 1e6)
      return invalidInput("subscription frequency {} Hz; expected (0, 1e6] Hz", frequency_hz);
    if (!orchestrator->contains(s.dfpc))
      return notFound("no DFPC '{}'; expected one of {{{}}}", s.dfpc,
                      fmt::join(orchestrator->dfpcNames(), ", "));
    s.period = std::max<Timestamp>(1, fromSeconds(1.0 / frequency_hz));
    s.next_due = clock->now() + s.period;
    SubscriptionId id;
    {
      std::lock_guard lock(subscription_mutex);
      id = next_id++;
      subscriptions.emplace(id, std::move(s));
    }
    clock->interrupt();
    return id;
  }

  // The latest sample among products with one of `roles`.
  Result<dfpc::Product> latestWithRole(std::initializer_list<const char*> roles) const {
    std::optional<dfpc::Product> best;
    std::vector<std::string> names;
    for (const char* role : roles)
      for (const std::string& name : orchestrator->productsWithRole(role)) {
        names.push_back(name);
        Result<dfpc::Product> p = orchestrator->products().latest(name);
        if (p && (!best || p->stamp > best->stamp)) best = p.value();
      }
    if (best) return *best;
    if (names.empty())
      return notFound("no DFPC output has role {}; declare one in a graph's outputs",
                      fmt::join(roles, " or "));
    return notFound("no {} product yet (from {{{}}})", fmt::join(roles, " or "),
                    fmt::join(names, ", "));
  }

  // frame_T_parent from the static transforms, directly or inverted.
  Result<Transform> staticTransform(const std::string& frame, const std::string& parent) const {
    std::vector<std::string> known{parent};
    for (const Transform& t : config.static_transforms) {
      if (t.parent_frame == frame && t.child_frame == parent) return t;
      if (t.child_frame == frame && t.parent_frame == parent) return t.inverse();
      if (t.parent_frame == parent) known.push_back(t.child_frame);
      if (t.child_frame == parent) known.push_back(t.parent_frame);
    }
    return notFound(
        "no transform from '{}' to '{}'; the pose can be given in {{{}}} (add a "
        "static transform to Config::static_transforms)",
        parent, frame, fmt::join(known, ", "));
  }
};

Cdff::Cdff(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Cdff::~Cdff() {
  Impl& d = *impl_;
  {
    std::lock_guard lock(d.mutex);
    d.shutting_down = true;
    d.changed.notify_all();
  }
  if (d.live) d.live->close();
  {
    std::lock_guard lock(d.subscription_mutex);
    d.scheduler_stop = true;
  }
  d.clock->interrupt();
  if (d.input_thread.joinable()) d.input_thread.join();
  if (d.scheduler.joinable()) d.scheduler.join();
}

Result<std::unique_ptr<Cdff>> Cdff::create(Config config) noexcept {
  return guarded<Result<std::unique_ptr<Cdff>>>("create", [&]() -> Result<std::unique_ptr<Cdff>> {
    auto d = std::make_unique<Impl>();
    d->config = std::move(config);
    d->clock = d->config.clock ? d->config.clock : std::make_shared<dfpc::SteadyClock>();
    d->simulated = dynamic_cast<dfpc::SimulatedClock*>(d->clock.get());
    dfpc::OrchestratorOptions options;
    options.sink = d->config.sink;
    options.record_timing = d->config.record_timing;
    d->orchestrator = std::make_unique<dfpc::Orchestrator>(options);
    for (const std::string& path : d->config.graph_files)
      CDFF_RETURN_IF_ERROR(d->orchestrator->addGraphFile(path));
    for (const dfpc::GraphSpec& spec : d->config.graphs) {
      Result<std::unique_ptr<dfpc::Dfpc>> dfpc = dfpc::Dfpc::create(spec);
      if (!dfpc) return dfpc.status();
      CDFF_RETURN_IF_ERROR(d->orchestrator->add(std::move(dfpc).value()));
    }
    if (d->orchestrator->dfpcNames().empty())
      return invalidInput("no DFPC to run; expected graph files or graphs in the Config");
    for (const dfpc::ActivationRule& rule : d->config.run_while)
      CDFF_RETURN_IF_ERROR(d->orchestrator->runWhile(rule));
    for (const Transform& t : d->config.static_transforms) CDFF_RETURN_IF_ERROR(t.validate());
    if (d->config.input) {
      d->input = d->config.input;
      CDFF_RETURN_IF_ERROR(d->orchestrator->checkChannels(d->input->channels()));
    } else {
      d->live = std::make_shared<dfpc::LiveStream>(d->config.live_capacity);
      d->input = d->live;
    }
    Impl* impl = d.get();
    d->input_thread = std::thread([impl] { impl->consumeInput(); });
    if (d->simulated) d->simulated->addParticipant();
    d->scheduler = std::thread([impl] { impl->schedule(); });
    d->scheduler_id = d->scheduler.get_id();
    return std::unique_ptr<Cdff>(new Cdff(std::move(d)));
  });
}

Status Cdff::setCDFFState(StateRequest request) noexcept {
  return guarded<Status>("setCDFFState", [&]() -> Status {
    Impl& d = *impl_;
    std::lock_guard lock(d.mutex);
    switch (request) {
      case StateRequest::kInitialize:
        if (d.state == CdffState::kRunning)
          return d.invalidRequest(request, "idle, reset, stop (it is running already)");
        if (d.state == CdffState::kStopped) {
          CDFF_RETURN_IF_ERROR(d.orchestrator->initAll());
          d.orchestrator->products().clear();
        }
        if (d.state != CdffState::kIdle) CDFF_RETURN_IF_ERROR(d.orchestrator->startAll());
        d.state = CdffState::kRunning;
        break;
      case StateRequest::kIdle:
        if (d.state != CdffState::kRunning)
          return d.invalidRequest(request, d.state == CdffState::kIdle
                                               ? "initialize, reset, stop (it is idle already)"
                                               : "initialize");
        d.state = CdffState::kIdle;
        break;
      case StateRequest::kReset:
        if (d.state == CdffState::kUninitialised) return d.invalidRequest(request, "initialize");
        CDFF_RETURN_IF_ERROR(d.orchestrator->resetAll());
        d.orchestrator->products().clear();
        break;
      case StateRequest::kStop:
        if (d.state != CdffState::kRunning && d.state != CdffState::kIdle)
          return d.invalidRequest(request, "initialize");
        CDFF_RETURN_IF_ERROR(d.orchestrator->stopAll());
        d.state = CdffState::kStopped;
        break;
    }
    d.changed.notify_all();
    return Status::ok();
  });
}

CdffState Cdff::getCDFFState() const noexcept {
  std::lock_guard lock(impl_->mutex);
  return impl_->state;
}

Result<dfpc::DfpcStatus> Cdff::getDFPCStatus(const std::string& dfpc) const noexcept {
  return guarded<Result<dfpc::DfpcStatus>>("getDFPCStatus",
                                           [&] { return impl_->orchestrator->status(dfpc); });
}

Status Cdff::initDFPC(const std::string& dfpc) noexcept {
  return guarded<Status>("initDFPC", [&]() -> Status {
    Impl& d = *impl_;
    std::lock_guard lock(d.mutex);
    if (d.state != CdffState::kRunning && d.state != CdffState::kIdle)
      return invalidInput(
          "initDFPC({}) while the CDFF is {}; expected running or idle "
          "(setCDFFState(initialize) first)",
          dfpc, toString(d.state));
    Result<dfpc::DfpcStatus> status = d.orchestrator->status(dfpc);
    if (!status) return status.status();
    if (status->state == dfpc::DfpcState::kRunning)
      CDFF_RETURN_IF_ERROR(d.orchestrator->stop(dfpc));
    CDFF_RETURN_IF_ERROR(d.orchestrator->init(dfpc));
    return d.orchestrator->start(dfpc);
  });
}

Status Cdff::stopDFPC(const std::string& dfpc) noexcept {
  return guarded<Status>("stopDFPC", [&] { return impl_->orchestrator->stop(dfpc); });
}

Result<PoseWithCovariance> Cdff::getTargetRelativePose(const std::string& frame) const noexcept {
  return guarded<Result<PoseWithCovariance>>(
      "getTargetRelativePose", [&]() -> Result<PoseWithCovariance> {
        const Impl& d = *impl_;
        Result<dfpc::Product> p = d.latestWithRole({"target_state", "target_pose"});
        if (!p) return p.status();
        PoseWithCovariance pose;
        if (auto s = p->as<RigidBodyState>())
          pose = s->poseWithCovariance();
        else if (auto q = p->as<PoseWithCovariance>())
          pose = *q;
        if (frame.empty() || frame == pose.pose.parent_frame) return pose;
        Result<Transform> frame_T_parent = d.staticTransform(frame, pose.pose.parent_frame);
        if (!frame_T_parent) return frame_T_parent.status();
        Result<Transform> composed = frame_T_parent->compose(pose.pose);
        if (!composed) return composed.status();
        PoseWithCovariance out;
        out.pose = composed.value();
        out.pose.stamp = pose.pose.stamp;
        out.covariance =
            rotateCovariance(pose.covariance, frame_T_parent->rotation.toRotationMatrix());
        return out;
      });
}

Result<VelocityWithCovariance> Cdff::getTargetRelativeVelocity(
    const std::string& frame) const noexcept {
  return guarded<Result<VelocityWithCovariance>>(
      "getTargetRelativeVelocity", [&]() -> Result<VelocityWithCovariance> {
        const Impl& d = *impl_;
        Result<dfpc::Product> p = d.latestWithRole({"target_state"});
        if (!p) return p.status();
        auto s = p->as<RigidBodyState>();
        VelocityWithCovariance v;
        v.stamp = s->pose.stamp;
        v.frame = s->pose.parent_frame;
        v.target_frame = s->pose.child_frame;
        v.twist = s->twist;
        v.covariance = s->covariance.bottomRightCorner<6, 6>();
        if (frame.empty() || frame == v.frame) return v;
        // The frames are fixed to each other: the relative velocity only rotates.
        Result<Transform> frame_T_parent = d.staticTransform(frame, v.frame);
        if (!frame_T_parent) return frame_T_parent.status();
        const Eigen::Matrix3d r = frame_T_parent->rotation.toRotationMatrix();
        v.frame = frame;
        v.twist.linear = r * s->twist.linear;
        v.twist.angular = r * s->twist.angular;
        v.covariance = rotateCovariance(v.covariance, r);
        return v;
      });
}

Result<TargetModel> Cdff::getModelOfTarget() const noexcept {
  return guarded<Result<TargetModel>>("getModelOfTarget", [&]() -> Result<TargetModel> {
    Result<dfpc::Product> p = impl_->latestWithRole({"target_model"});
    if (!p) return p.status();
    TargetModel model;
    model.product = p->name;
    model.stamp = p->stamp;
    model.mesh = p->as<TriangleMesh>();
    model.cloud = p->as<PointCloud>();
    return model;
  });
}

Result<SubscriptionId> Cdff::getDFPCPose(const std::string& dfpc, double frequency_hz,
                                         PoseCallback callback) noexcept {
  return guarded<Result<SubscriptionId>>("getDFPCPose", [&]() -> Result<SubscriptionId> {
    Impl& d = *impl_;
    if (!callback) return invalidInput("getDFPCPose({}): no callback", dfpc);
    if (!d.orchestrator->contains(dfpc))
      return notFound("no DFPC '{}'; expected one of {{{}}}", dfpc,
                      fmt::join(d.orchestrator->dfpcNames(), ", "));
    std::vector<std::string> products = d.orchestrator->productsWithRole("target_state", dfpc);
    for (const std::string& p : d.orchestrator->productsWithRole("target_pose", dfpc))
      products.push_back(p);
    if (products.empty())
      if (auto p = d.orchestrator->productOfType(dfpc, {"RigidBodyState", "PoseWithCovariance"}))
        products.push_back(*p);
    if (products.empty())
      return notFound("DFPC '{}' has no pose output (RigidBodyState or PoseWithCovariance)", dfpc);
    Impl::Subscription s;
    s.kind = Impl::Subscription::Kind::kPose;
    s.dfpc = dfpc;
    s.product = products.front();
    s.pose = std::move(callback);
    return d.subscribe(std::move(s), frequency_hz);
  });
}

Result<SubscriptionId> Cdff::getDFPCStatus(const std::string& dfpc, double frequency_hz,
                                           StatusCallback callback) noexcept {
  return guarded<Result<SubscriptionId>>("getDFPCStatus", [&]() -> Result<SubscriptionId> {
    if (!callback) return invalidInput("getDFPCStatus({}): no callback", dfpc);
    Impl::Subscription s;
    s.kind = Impl::Subscription::Kind::kStatus;
    s.dfpc = dfpc;
    s.status = std::move(callback);
    return impl_->subscribe(std::move(s), frequency_hz);
  });
}

Status Cdff::cancelSubscription(SubscriptionId id) noexcept {
  return guarded<Status>("cancelSubscription", [&]() -> Status {
    Impl& d = *impl_;
    std::unique_lock lock(d.subscription_mutex);
    if (!d.subscriptions.erase(id)) return notFound("no subscription {}", id);
    // Let a callback batch in flight finish, unless this is called from one of its callbacks.
    if (std::this_thread::get_id() != d.scheduler_id)
      d.callbacks_done.wait(lock, [&] { return !d.running_callbacks; });
    return Status::ok();
  });
}

Status Cdff::push(dfpc::Message message) noexcept {
  return guarded<Status>("push", [&]() -> Status {
    Impl& d = *impl_;
    if (!d.live)
      return invalidInput("push({}): the CDFF consumes a given input stream, not live messages",
                          message.channel);
    CDFF_RETURN_IF_ERROR(d.live->push(std::move(message)));
    std::lock_guard lock(d.mutex);
    ++d.pushed;
    return Status::ok();
  });
}

Status Cdff::flush(double timeout_s) noexcept {
  return guarded<Status>("flush", [&]() -> Status {
    Impl& d = *impl_;
    std::unique_lock lock(d.mutex);
    auto done = [&] {
      if (!d.live) return d.input_ended;
      // Messages the bounded live queue dropped will never be processed.
      return d.processed + d.live->dropped() >= d.pushed;
    };
    const bool ok = d.changed.wait_for(lock, std::chrono::duration<double>(timeout_s), done);
    if (!d.input_error.isOk()) return d.input_error;
    if (!ok)
      return Status(StatusCode::kTimeout,
                    fmt::format("flush: {} of {} messages processed after {} s (CDFF {})",
                                d.processed, d.pushed, timeout_s, toString(d.state)));
    return Status::ok();
  });
}

namespace {

/// designateTarget's readers: the running DFPCs with an ImageRegion input on the designation
/// channel (into out.dfpcs) and their Image inputs (what the box is drawn on); an error when there
/// is none.
Status designationReaders(dfpc::Orchestrator& orchestrator, Designated& out,
                          std::vector<std::string>& image_channels) {
  std::vector<std::string> readers, idle;
  for (const std::string& name : orchestrator.dfpcNames()) {
    const std::vector<dfpc::DfpcInputSpec> inputs = orchestrator.inputsOf(name);
    if (std::none_of(inputs.begin(), inputs.end(), [](const dfpc::DfpcInputSpec& i) {
          return i.channel == dfpc::kDesignationChannel && i.type == "ImageRegion";
        }))
      continue;
    readers.push_back(name);
    Result<dfpc::DfpcStatus> status = orchestrator.status(name);
    if (!status) return status.status();
    if (status->state != dfpc::DfpcState::kRunning) {
      idle.push_back(fmt::format("{} is {}", name, dfpc::toString(status->state)));
      continue;
    }
    out.dfpcs.push_back(name);
    for (const dfpc::DfpcInputSpec& i : inputs)
      if (i.type == "Image" && std::find(image_channels.begin(), image_channels.end(), i.channel) ==
                                   image_channels.end())
        image_channels.push_back(i.channel);
  }
  if (readers.empty())
    return notFound(
        "designateTarget: no DFPC reads designations (an ImageRegion input on {}); the DFPCs "
        "are {{{}}}",
        dfpc::kDesignationChannel, fmt::join(orchestrator.dfpcNames(), ", "));
  if (out.dfpcs.empty())
    return notFound(
        "designateTarget: no running DFPC reads designations ({}); expected one running "
        "(setCDFFState(initialize) or initDFPC)",
        fmt::join(idle, ", "));
  if (image_channels.empty())
    return notFound(
        "designateTarget: {} read designations but have no Image input; a designation is a "
        "box of an image",
        fmt::join(out.dfpcs, ", "));
  return Status::ok();
}

}  // namespace

Result<Designated> Cdff::designateTarget(double x, double y, int width, int height) noexcept {
  return guarded<Result<Designated>>("designateTarget", [&]() -> Result<Designated> {
    Impl& d = *impl_;
    if (!std::isfinite(x) || !std::isfinite(y))
      return invalidInput(
          "designateTarget: the box's corner ({}, {}) is not finite; expected pixel coordinates "
          "of the image",
          x, y);
    if (width < 1 || height < 1)
      return invalidInput("designateTarget: the box's size {}x{} px; expected at least 1x1 px",
                          width, height);
    Designated out;
    std::vector<std::string> image_channels;
    CDFF_RETURN_IF_ERROR(designationReaders(*d.orchestrator, out, image_channels));

    std::lock_guard lock(d.process_mutex);
    const Impl::ImageSeen* image = nullptr;
    for (const std::string& channel : image_channels)
      if (auto it = d.images.find(channel); it != d.images.end())
        if (!image || it->second.stamp > image->stamp) {
          image = &it->second;
          out.image_channel = channel;
        }
    if (!image || !d.stream_time)
      return notFound(
          "designateTarget: no image on {} yet (the Image input of {}); a designation is a box "
          "of an image: expected one first",
          fmt::join(image_channels, ", "), fmt::join(out.dfpcs, ", "));
    if (x < 0 || y < 0 || x + width > image->width || y + height > image->height)
      return invalidInput(
          "designateTarget: the box [{}, {}) x [{}, {}) leaves the {}x{} image of {}; expected "
          "0 <= x, x + width <= {}, 0 <= y, y + height <= {} (full-resolution pixels)",
          x, x + width, y, y + height, image->width, image->height, out.image_channel, image->width,
          image->height);
    out.image_width = image->width;
    out.image_height = image->height;
    out.image_stamp = image->stamp;
    out.region = ImageRegion::box(x, y, width, height);
    out.region.stamp = *d.stream_time;
    out.region.frame_id = image->frame_id;
    out.region.source = "user";
    CDFF_RETURN_IF_ERROR(d.orchestrator->process(
        dfpc::Message::of(dfpc::kDesignationChannel, out.region.stamp, out.region)));
    return out;
  });
}

std::shared_ptr<const dfpc::DataProductManager> Cdff::products() const noexcept {
  return impl_->orchestrator->sharedProducts();
}

}  // namespace cdff::api
