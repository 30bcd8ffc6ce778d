#include "cdff/serve/live_run.hpp"

#include <algorithm>
#include <cmath>
#include <deque>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/dfpc/graph.hpp"
#include "cdff/dfpc/recording_streams.hpp"
#include "cdff/egse/model_io.hpp"
#include "cdff/eval/pose_evaluation.hpp"
#include "cdff/serve/contour.hpp"
#include "cdff/serve/replay_stream.hpp"
#include "cdff/serve/scene.hpp"

namespace cdff::serve {

using nlohmann::json;

namespace {

constexpr double kPoseHz = 20;        // clock time: poses sent at most this often per DFPC
constexpr double kStatusHz = 2;       // DFPC status frames
constexpr std::size_t kEvents = 200;  // events kept for GET /api/live
constexpr int kImageWidth = 640;      // camera frames downscaled to this width at most
constexpr int kImageQuality = 80;
constexpr std::size_t kCloudPoints = 20000;  // LIDAR points per scan sent at most

// The steady clock run `speed` times faster: the API paces the recording and its subscriptions
// on it, so a run at 4x plays 4 s of recording per second.
class ScaledClock final : public dfpc::Clock {
 public:
  explicit ScaledClock(double speed) : speed_(speed), start_(steady_.now()) {}
  Timestamp now() const override {
    return static_cast<Timestamp>(static_cast<double>(steady_.now() - start_) * speed_);
  }
  std::uint64_t interrupts() const override { return steady_.interrupts(); }
  using Clock::sleepUntil;
  bool sleepUntil(Timestamp t, std::uint64_t since) override {
    if (t >= dfpc::kForever / 2) return steady_.sleepUntil(dfpc::kForever, since);
    const auto wall = start_ + static_cast<Timestamp>(std::ceil(static_cast<double>(t) / speed_));
    return steady_.sleepUntil(wall, since);
  }
  void interrupt() override { steady_.interrupt(); }

 private:
  mutable dfpc::SteadyClock steady_;
  double speed_;
  Timestamp start_;
};

json poseJson(const Transform& p) {
  return {{"frame", p.parent_frame},
          {"child_frame", p.child_frame},
          {"p", {p.translation.x(), p.translation.y(), p.translation.z()}},
          {"q", {p.rotation.w(), p.rotation.x(), p.rotation.y(), p.rotation.z()}}};
}

std::string dump(const json& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

// The model the 3D view draws: the graph's first `mesh_file` parameter (its LIDAR model's), ""
// when it names none.
std::string modelFileOf(const dfpc::GraphSpec& graph) {
  for (const dfpc::InstanceSpec& instance : graph.instances)
    if (instance.parameters.IsMap() && instance.parameters["mesh_file"] &&
        instance.parameters["mesh_file"].IsScalar())
      return instance.parameters["mesh_file"].as<std::string>();
  return "";
}

}  // namespace

Result<api::StateRequest> parseStateRequest(const std::string& text) {
  if (text == "idle") return api::StateRequest::kIdle;
  if (text == "initialize") return api::StateRequest::kInitialize;
  if (text == "reset") return api::StateRequest::kReset;
  if (text == "stop") return api::StateRequest::kStop;
  return invalidInput("\"request\" = \"{}\": expected one of idle, initialize, reset, stop", text);
}

// ---- the run -----------------------------------------------------------------------------------

class LiveHub::Run final : public dfpc::Sink {
 public:
  Run(LiveHub& hub, std::uint64_t id, LiveSpec spec, const Recording& recording, std::string dfpc,
      std::string model_file)
      : hub_(hub),
        id_(id),
        spec_(std::move(spec)),
        recording_(recording),
        dfpc_(std::move(dfpc)),
        model_file_(std::move(model_file)) {}

  ~Run() override {
    // The API's threads (input, subscriptions) call into this run. The subscriptions are
    // cancelled first (their callbacks use cdff_, which is null while it is being destroyed);
    // the input thread ends with the Cdff.
    if (cdff_)
      for (api::SubscriptionId id : subscriptions_) (void)cdff_->cancelSubscription(id);
    cdff_.reset();
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    if (encoder_.joinable()) encoder_.join();
  }

  Status start(const std::string& graph_file) {
    auto mcap = std::make_unique<dfpc::McapInputStream>();
    CDFF_RETURN_IF_ERROR(mcap->open({recording_.path()}));
    api::Config config;
    config.graph_files = {graph_file};
    config.input = std::make_shared<Tee>(std::move(mcap), *this);
    config.realtime = true;
    config.clock = std::make_shared<ScaledClock>(spec_.speed);
    config.sink = this;
    Result<std::unique_ptr<api::Cdff>> cdff = api::Cdff::create(std::move(config));
    if (!cdff) return cdff.status();
    cdff_ = std::move(*cdff);
    loadOutline();
    encoder_ = std::thread([this] { encode(); });
    Result<api::SubscriptionId> poses = cdff_->getDFPCPose(
        dfpc_, kPoseHz,
        [this](Timestamp, const Result<PoseWithCovariance>& pose) { onPose(pose); });
    // A graph without a pose output (a model, a haptic scan) runs too; the state says why no
    // pose comes.
    if (poses)
      subscriptions_.push_back(*poses);
    else
      pose_error_ = poses.status().message();
    Result<api::SubscriptionId> status = cdff_->getDFPCStatus(
        dfpc_, kStatusHz, [this](Timestamp, const Result<dfpc::DfpcStatus>& s) { onStatus(s); });
    if (!status) return status.status();
    subscriptions_.push_back(*status);
    return cdff_->setCDFFState(api::StateRequest::kInitialize);
  }

  api::Cdff& cdff() { return *cdff_; }
  const std::string& modelFile() const { return model_file_; }
  const LiveSpec& spec() const { return spec_; }

  json state() const {
    json j = {{"active", true},
              {"run", id_},
              {"graph", spec_.graph},
              {"recording", spec_.recording},
              {"speed", spec_.speed},
              {"camera", spec_.camera},
              {"points", spec_.points},
              {"model_file", model_file_},
              {"state", api::toString(cdff_->getCDFFState())}};
    if (!pose_error_.empty()) j["pose_error"] = pose_error_;
    j["contour_model"] = outline_source_;
    if (!contour_error_.empty()) j["contour_error"] = contour_error_;
    // The API is asked without mutex_ held: its input thread calls the sink (which takes
    // mutex_) under the API's own locks.
    Result<dfpc::DfpcStatus> s = cdff_->getDFPCStatus(dfpc_);
    j["dfpcs"] = json::array();
    if (s)
      j["dfpcs"].push_back(statusJson(*s));
    else
      j["dfpcs"].push_back({{"name", dfpc_}, {"error", s.status().message()}});
    std::lock_guard lock(mutex_);
    j["input_ended"] = input_ended_;
    if (!input_error_.empty()) j["input_error"] = input_error_;
    j["t"] = last_stamp_ ? seconds(*last_stamp_) : 0.0;
    j["duration_s"] = recording_.secondsOf(recording_.endNs());
    j["events"] = json(std::vector<json>(events_.begin(), events_.end()));
    return j;
  }

  Result<json> designate(double x, double y, int width, int height) {
    Result<api::Designated> d = cdff_->designateTarget(x, y, width, height);
    if (!d) return d.status();
    json j = {{"type", "designation"},
              {"run", id_},
              {"x", x},
              {"y", y},
              {"width", width},
              {"height", height},
              {"t", seconds(d->region.stamp)},
              {"stamp_us", d->region.stamp},
              {"frame_id", d->region.frame_id},
              {"dfpcs", d->dfpcs},
              {"image",
               {{"channel", d->image_channel},
                {"width", d->image_width},
                {"height", d->image_height},
                {"t", seconds(d->image_stamp)}}}};
    return j;
  }

  // ---- dfpc::Sink (the API's input thread) ----
  // The products the page draws: bearings (far-range tracking) and image regions (a designation,
  // a match), each as a small frame.
  Status writeMessage(const dfpc::Message& m) override {
    if (const Bearing* b = m.as<Bearing>()) {
      const double variance = b->covariance.trace() / 2;  // rank 2: across the direction
      json j = {{"type", "bearing"},
                {"run", id_},
                {"dfpc", dfpc_},
                {"channel", m.channel},
                {"t", seconds(m.stamp)},
                {"stamp_us", m.stamp},
                {"frame", b->frame_id},
                {"direction", {b->direction.x(), b->direction.y(), b->direction.z()}},
                {"azimuth", b->azimuth()},
                {"elevation", b->elevation()},
                {"sigma", std::sqrt(std::max(0.0, variance))},
                {"range", b->range},
                {"range_sigma", std::sqrt(b->range_variance)},
                {"designation", b->designation}};
      hub_.publish({false, dump(j)});
    } else if (const ImageRegion* r = m.as<ImageRegion>()) {
      // The template's outer edges in the image (pixel centres at integer coordinates).
      const double w = r->width - 0.5, h = r->height - 0.5;
      json corners = json::array();
      const double edges[4][2] = {{-0.5, -0.5}, {w, -0.5}, {w, h}, {-0.5, h}};
      for (const auto& e : edges) {
        const Eigen::Vector2d p = r->map(e[0], e[1]);
        corners.push_back({p.x(), p.y()});
      }
      const Eigen::Vector2d c = r->centre();
      json j = {{"type", "region"},
                {"run", id_},
                {"dfpc", dfpc_},
                {"channel", m.channel},
                {"output", m.channel.substr(m.channel.rfind('/') + 1)},
                {"t", seconds(m.stamp)},
                {"stamp_us", m.stamp},
                {"source", r->source},
                {"score", r->score},
                {"centre", {c.x(), c.y()}},
                {"corners", corners}};
      hub_.publish({false, dump(j)});
    }
    return Status::ok();
  }
  Status writeEvent(const dfpc::Event& event) override {
    // An event before the first message (a DFPC started) has no stream time yet.
    const bool timed = static_cast<double>(event.stamp) * 1e3 >= recording_.startNs();
    json e = {{"type", "event"},
              {"t", timed ? json(seconds(event.stamp)) : json()},
              {"event", dfpc::eventRecord(event)}};
    {
      std::lock_guard lock(mutex_);
      events_.push_back(e);
      if (events_.size() > kEvents) events_.pop_front();
    }
    hub_.publish({false, dump(e)});
    return Status::ok();
  }
  Status writeTiming(const dfpc::TimingRecord& timing) override {
    std::lock_guard lock(mutex_);
    Timing& t = timings_[std::string(timing.instance)];
    t.last_s = timing.wall_s;
    ++t.calls;
    return Status::ok();
  }

 private:
  struct Timing {
    double last_s = 0;
    std::uint64_t calls = 0;
  };

  // The recording as the API reads it, with the camera's images kept for the encoder (the
  // image's shared pointer: no copy, no work on the input thread).
  class Tee final : public dfpc::InputStream {
   public:
    Tee(std::unique_ptr<dfpc::McapInputStream> input, Run& run)
        : input_(std::move(input)), run_(run) {}
    Result<std::optional<dfpc::Message>> next() override {
      Result<std::optional<dfpc::Message>> m = input_->next();
      run_.onInput(m);
      return m;
    }
    std::vector<dfpc::ChannelInfo> channels() const override { return input_->channels(); }
    std::optional<std::pair<Timestamp, Timestamp>> timeRange() const override {
      return input_->timeRange();
    }

   private:
    std::unique_ptr<dfpc::McapInputStream> input_;
    Run& run_;
  };

  double seconds(Timestamp stamp) const {
    return (static_cast<double>(stamp) * 1e3 - static_cast<double>(recording_.startNs())) * 1e-9;
  }

  void onInput(const Result<std::optional<dfpc::Message>>& m) {
    std::lock_guard lock(mutex_);
    if (!m || !m.value()) {
      input_ended_ = true;
      if (!m) input_error_ = m.status().message();
      return;
    }
    const dfpc::Message& message = *m.value();
    last_stamp_ = message.stamp;
    if (message.channel == spec_.camera) {
      if (std::shared_ptr<const Image> image = message.value.as<Image>()) {
        image_ = std::move(image);
        image_stamp_ = message.stamp;
        wake_.notify_all();
      }
    } else if (!spec_.points.empty() && message.channel == spec_.points) {
      if (std::shared_ptr<const PointCloud> cloud = message.value.as<PointCloud>()) {
        cloud_ = std::move(cloud);
        cloud_stamp_ = message.stamp;
        wake_.notify_all();
      }
    }
  }

  // The encoder thread: the latest image and scan, when a browser watches (older ones are
  // skipped).
  void encode() {
    std::unique_lock lock(mutex_);
    for (;;) {
      wake_.wait(lock, [&] { return stop_ || image_ || cloud_; });
      if (stop_) return;
      std::shared_ptr<const Image> image = std::move(image_);
      std::shared_ptr<const PointCloud> cloud = std::move(cloud_);
      image_.reset();
      cloud_.reset();
      const Timestamp stamp = image_stamp_, scan_stamp = cloud_stamp_;
      if (hub_.listeners() == 0) continue;
      lock.unlock();
      if (image) publishImage(*image, stamp);
      if (cloud) {
        const json header = {
            {"channel", spec_.points}, {"t", seconds(scan_stamp)}, {"stamp_us", scan_stamp}};
        hub_.publish({true, pointsFrame(header, *cloud, decimateCloud(*cloud, kCloudPoints))});
      }
      lock.lock();
    }
  }

  void publishImage(const Image& image, Timestamp stamp) {
    Result<EncodedImage> jpeg = encodeJpeg(image, kImageWidth, kImageQuality);
    if (!jpeg) {
      hub_.publish({false, dump({{"type", "error"}, {"error", jpeg.status().message()}})});
      return;
    }
    json header = {{"type", "image"},
                   {"channel", spec_.camera},
                   {"t", seconds(stamp)},
                   {"stamp_us", stamp},
                   {"width", jpeg->width},
                   {"height", jpeg->height},
                   {"source_width", jpeg->source_width},
                   {"source_height", jpeg->source_height}};
    if (json contour = contourOver(image); !contour.is_null()) header["contour"] = contour;
    hub_.publish({true, binaryFrame(header, jpeg->jpeg)});
  }

  // The model the contour is drawn of: the graph's mesh_file, else the recording's first
  // TriangleMesh channel (the simulator's /truth/target_mesh); none (and why) when neither.
  void loadOutline() {
    Result<TriangleMesh> mesh = notFound(
        "the graph names no mesh_file and the recording has no "
        "TriangleMesh channel");
    if (!model_file_.empty()) {
      Result<egse::TargetModel> model = egse::loadModel(model_file_);
      mesh = model ? Result<TriangleMesh>(model->mesh) : Result<TriangleMesh>(model.status());
      outline_source_ = model_file_;
    } else {
      for (const ChannelSummary& c : recording_.channels())
        if (c.type == "TriangleMesh" && !c.times_ns.empty()) {
          mesh = recording_.mesh(c.topic);
          outline_source_ = c.topic;
          break;
        }
    }
    Result<MeshOutline> outline =
        mesh ? MeshOutline::of(*mesh) : Result<MeshOutline>(mesh.status());
    if (outline)
      outline_ = std::move(*outline);
    else
      contour_error_ = outline.status().message();
  }

  // The contour of the model at the latest estimated pose over `image` (the encoder thread's):
  // null without a model, a camera model or a pose; {"error"} when the pose's frame cannot be
  // brought into the image's.
  json contourOver(const Image& image) {
    std::optional<Transform> pose;
    {
      std::lock_guard lock(mutex_);
      pose = latest_pose_;
    }
    if (!outline_ || !image.camera || !pose) return json();
    Transform camera_T_parent = Transform::identity(image.frame_id, pose->parent_frame);
    if (pose->parent_frame != image.frame_id) {
      const auto key = std::pair(pose->parent_frame, image.frame_id);
      auto it = mountings_.find(key);
      if (it == mountings_.end())
        it = mountings_.emplace(key, recording_.mounting(key.first, key.second)).first;
      if (!it->second) return {{"error", it->second.status().message()}};
      camera_T_parent = it->second->inverse();
    }
    const Transform camera_T_model = Transform::fromIsometry(
        camera_T_parent.isometry() * pose->isometry(), image.frame_id, pose->child_frame);
    Result<std::vector<std::array<float, 4>>> segments =
        outline_->project(camera_T_model, *image.camera);
    if (!segments) return {{"error", segments.status().message()}};
    json j = contourJson(*segments);
    j["pose_t"] = seconds(pose->stamp);
    j["source"] = outline_source_;
    return j;
  }

  // The truth of the poses' transform in the recording (once, at the first pose): the /truth/
  // pose channel of the same parent and child frames, /truth/target_pose first, as `cdff eval`
  // pairs them.
  void findTruth(const Transform& pose) {
    truth_searched_ = true;
    std::vector<const ChannelSummary*> candidates;
    for (const ChannelSummary& c : recording_.channels())
      if (c.topic.starts_with("/truth/") && isPoseType(c.type) && !c.times_ns.empty())
        candidates.push_back(&c);
    std::stable_partition(candidates.begin(), candidates.end(),
                          [](const ChannelSummary* c) { return c->topic == "/truth/target_pose"; });
    for (const ChannelSummary* c : candidates) {
      Result<std::vector<Transform>> truth = recording_.transforms(c->topic);
      if (!truth || truth->empty() || truth->front().parent_frame != pose.parent_frame ||
          truth->front().child_frame != pose.child_frame)
        continue;
      truth_ = std::move(*truth);
      truth_channel_ = c->topic;
      return;
    }
  }

  // ---- the API's subscription thread ----
  void onPose(const Result<PoseWithCovariance>& pose) {
    if (!pose) return;  // no pose yet
    if (last_pose_ && *last_pose_ == pose->pose.stamp) return;
    last_pose_ = pose->pose.stamp;
    {
      std::lock_guard lock(mutex_);
      latest_pose_ = pose->pose;
    }
    json j = poseJson(pose->pose);
    j["type"] = "pose";
    j["run"] = id_;
    j["dfpc"] = dfpc_;
    j["t"] = seconds(pose->pose.stamp);
    j["stamp_us"] = pose->pose.stamp;
    std::vector<double> covariance(36);
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) covariance[r * 6 + c] = pose->covariance(r, c);
    j["covariance"] = covariance;
    if (!truth_searched_) findTruth(pose->pose);
    if (!truth_.empty()) {
      if (std::optional<Transform> truth = eval::truthAt(truth_, pose->pose.stamp, {})) {
        const PoseError e = poseError(pose->pose, *truth);
        j["truth"] = poseJson(*truth);
        j["truth"]["channel"] = truth_channel_;
        j["error"] = {
            {"range_m", e.range_m},
            {"position_error_m", e.position_error_m},
            {"angle_error_deg", e.angle_error_deg},
            {"position_threshold_m",
             e.position_threshold_m ? json(*e.position_threshold_m) : json()},
            {"angle_threshold_deg", e.angle_threshold_deg ? json(*e.angle_threshold_deg) : json()},
            {"requirement", e.requirement}};
      }
    }
    hub_.publish({false, dump(j)});
  }
  void onStatus(const Result<dfpc::DfpcStatus>& status) {
    json j =
        status ? statusJson(*status) : json{{"name", dfpc_}, {"error", status.status().message()}};
    j["type"] = "status";
    j["cdff_state"] = api::toString(cdff_->getCDFFState());
    {
      std::lock_guard lock(mutex_);
      j["input_ended"] = input_ended_;
    }
    hub_.publish({false, dump(j)});
  }

  // getDFPCStatus as JSON (dfpc::statusRecord), with each instance's latest DFN call time
  // (mutex_ not held).
  json statusJson(const dfpc::DfpcStatus& s) const {
    json j = dfpc::statusRecord(s);
    std::lock_guard lock(mutex_);
    for (json& instance : j["instances"])
      if (auto t = timings_.find(instance["name"].get<std::string>());
          t != timings_.end() && t->second.calls > 0)
        instance["last_wall_s"] = t->second.last_s;
    return j;
  }

  LiveHub& hub_;
  const std::uint64_t id_;  // the server's runs are numbered from 1
  const LiveSpec spec_;
  const Recording& recording_;
  const std::string dfpc_;
  const std::string model_file_;  // the graph's mesh_file, "" when it names none
  std::unique_ptr<api::Cdff> cdff_;
  std::vector<api::SubscriptionId> subscriptions_;
  std::string pose_error_;              // why there is no pose subscription ("" when there is one)
  std::optional<Timestamp> last_pose_;  // the subscription thread's only, as the truth:
  bool truth_searched_ = false;
  std::vector<Transform> truth_;
  std::string truth_channel_;

  mutable std::mutex mutex_;  // what follows
  std::condition_variable wake_;
  bool stop_ = false, input_ended_ = false;
  std::string input_error_;
  std::optional<Timestamp> last_stamp_;
  std::shared_ptr<const Image> image_;
  Timestamp image_stamp_ = 0;
  std::shared_ptr<const PointCloud> cloud_;
  Timestamp cloud_stamp_ = 0;
  std::optional<Transform> latest_pose_;  // the latest estimate, for the contour
  // The contour's model and the mountings found (the encoder thread's, after start).
  std::optional<MeshOutline> outline_;
  std::string outline_source_, contour_error_;
  std::map<std::pair<std::string, std::string>, Result<Transform>> mountings_;
  std::deque<json> events_;
  std::map<std::string, Timing> timings_;
  std::thread encoder_;
};

// ---- the hub -----------------------------------------------------------------------------------

LiveHub::LiveHub(const std::vector<std::unique_ptr<Recording>>& recordings,
                 std::vector<std::string> graphs)
    : recordings_(recordings), graphs_(std::move(graphs)) {}

Status LiveHub::checkGraph(const std::string& graph) const {
  if (std::find(graphs_.begin(), graphs_.end(), graph) != graphs_.end()) return Status::ok();
  const std::string list = graphs_.empty() ? std::string("none (cdff serve --graph FILE)")
                                           : fmt::format("one of {}", fmt::join(graphs_, ", "));
  if (graph.find("..") != std::string::npos || graph.find('\\') != std::string::npos)
    return invalidInput("\"graph\" = \"{}\" is a path, not a served graph; expected {}", graph,
                        list);
  return notFound("\"graph\" = \"{}\" is not a served graph; expected {}", graph, list);
}

LiveHub::~LiveHub() {
  (void)remove();
}
namespace {

/// The live run's `key` channel: the recording's first channel of `type` when `channel` is empty,
/// else `channel`, which must hold `type` (`expected` says so in the error).
Status chooseChannel(const Recording& recording, const char* key, const char* type,
                     const char* expected, std::string& channel) {
  if (channel.empty()) {
    for (const ChannelSummary& c : recording.channels())
      if (c.type == type) {
        channel = c.topic;
        break;
      }
    return Status::ok();
  }
  Result<const ChannelSummary*> c = recording.findChannel(channel);
  if (!c) return c.status();
  if ((*c)->type != type)
    return invalidInput("\"{}\" = \"{}\" holds {} messages; expected {}", key, channel,
                        (*c)->type.empty() ? (*c)->schema : (*c)->type, expected);
  return Status::ok();
}

}  // namespace

Status LiveHub::start(const LiveSpec& given, bool& conflict) {
  conflict = false;
  LiveSpec spec = given;
  CDFF_RETURN_IF_ERROR(checkGraph(spec.graph));
  if (spec.recording >= recordings_.size())
    return notFound("\"recording\" = {} does not exist; expected an index in [0, {})",
                    spec.recording, recordings_.size());
  if (!(spec.speed >= 1.0 / 16 && spec.speed <= 16))
    return invalidInput("\"speed\" = {}: expected a factor in [0.0625, 16]", spec.speed);
  const Recording& recording = *recordings_[spec.recording];
  CDFF_RETURN_IF_ERROR(
      chooseChannel(recording, "camera", "Image", "an Image channel", spec.camera));
  CDFF_RETURN_IF_ERROR(
      chooseChannel(recording, "points", "PointCloud", "a PointCloud channel", spec.points));
  Result<dfpc::GraphSpec> graph = dfpc::loadGraphFile(spec.graph);
  if (!graph) return graph.status();
  const std::string model_file = modelFileOf(*graph);
  {
    std::lock_guard lock(run_mutex_);
    if (run_) {
      conflict = true;
      return invalidInput(
          "a live run is already there; expected DELETE /api/live before starting another");
    }
    auto run = std::make_unique<Run>(*this, ++runs_, spec, recording, graph->name, model_file);
    CDFF_RETURN_IF_ERROR(run->start(spec.graph));
    run_ = std::move(run);
  }
  publish({false, dump([&] {
             json j = state();
             j["type"] = "state";
             return j;
           }())});
  return Status::ok();
}

json LiveHub::state() const {
  json j;
  {
    std::lock_guard lock(run_mutex_);
    if (run_) {
      j = run_->state();
    } else {
      j = {{"active", false}};
      if (!last_.is_null()) j["last"] = last_;
    }
  }
  j["browsers"] = json::array();
  std::lock_guard lock(listeners_mutex_);
  for (const auto& [id, l] : listeners_) j["browsers"].push_back({{"dropped", l.second()}});
  return j;
}

Status LiveHub::request(api::StateRequest request) {
  Status s;
  {
    std::lock_guard lock(run_mutex_);
    if (!run_) return notFound("no live run; expected POST /api/live first");
    s = run_->cdff().setCDFFState(request);
  }
  json j = state();
  j["type"] = "state";
  publish({false, dump(j)});
  return s;
}

Status LiveHub::dfpcRequest(const std::string& dfpc, bool init) {
  Status s;
  {
    std::lock_guard lock(run_mutex_);
    if (!run_) return notFound("no live run; expected POST /api/live first");
    s = init ? run_->cdff().initDFPC(dfpc) : run_->cdff().stopDFPC(dfpc);
  }
  json j = state();
  j["type"] = "state";
  publish({false, dump(j)});
  return s;
}

Result<json> LiveHub::designate(double x, double y, int width, int height, bool& no_run) {
  Result<json> d = [&]() -> Result<json> {
    std::lock_guard lock(run_mutex_);
    no_run = !run_;
    if (!run_) return notFound("no live run; expected POST /api/live first");
    return run_->designate(x, y, width, height);
  }();
  if (d) publish({false, dump(*d)});  // every browser draws it
  return d;
}

Status LiveHub::remove() {
  std::unique_ptr<Run> run;
  {
    std::lock_guard lock(run_mutex_);
    if (!run_) return notFound("no live run; expected POST /api/live first");
    const api::CdffState state = run_->cdff().getCDFFState();
    if (state == api::CdffState::kRunning || state == api::CdffState::kIdle)
      CDFF_RETURN_IF_ERROR(run_->cdff().setCDFFState(api::StateRequest::kStop));
    last_ = run_->state();
    last_["active"] = false;
    run = std::move(run_);
  }
  run.reset();  // joins the API's threads, which publish (not under run_mutex_)
  json j = state();
  j["type"] = "state";
  publish({false, dump(j)});
  return Status::ok();
}

Result<std::string> LiveHub::modelBody(const std::string& graph) const {
  CDFF_RETURN_IF_ERROR(checkGraph(graph));
  Result<dfpc::GraphSpec> spec = dfpc::loadGraphFile(graph);
  if (!spec) return spec.status();
  const std::string file = modelFileOf(*spec);
  if (file.empty())
    return notFound(
        "graph '{}' names no mesh_file; expected a graph with a mesh model (e.g. "
        "dfpcs/lidar_tracking.yaml), or the recording's TriangleMesh channel "
        "(GET /api/recordings/<id>/mesh)",
        graph);
  Result<egse::TargetModel> model = egse::loadModel(file);
  if (!model) return model.status().withContext(fmt::format("graph '{}', mesh_file", graph));
  return meshBody(model->mesh, {{"source", file}, {"graph", graph}});
}

std::uint64_t LiveHub::addListener(Listener listener, DroppedCount dropped) {
  json j = state();
  j["type"] = "state";
  listener({false, dump(j)});
  std::lock_guard lock(listeners_mutex_);
  const std::uint64_t id = next_listener_++;
  listeners_.emplace(id, std::pair(std::move(listener), std::move(dropped)));
  return id;
}

void LiveHub::removeListener(std::uint64_t id) {
  std::lock_guard lock(listeners_mutex_);
  listeners_.erase(id);
}

std::size_t LiveHub::listeners() const {
  std::lock_guard lock(listeners_mutex_);
  return listeners_.size();
}

void LiveHub::publish(const Frame& frame) const {
  std::vector<Listener> listeners;
  {
    std::lock_guard lock(listeners_mutex_);
    for (const auto& [id, l] : listeners_) listeners.push_back(l.first);
  }
  for (const Listener& l : listeners) l(frame);
}

}  // namespace cdff::serve
