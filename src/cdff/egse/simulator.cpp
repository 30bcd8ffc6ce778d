#include "cdff/egse/simulator.hpp"

#include <cmath>
#include <limits>

#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include "cdff/egse/imu.hpp"
#include "cdff/egse/model_io.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/range_sensors.hpp"

namespace cdff::egse {

struct Simulator::SensorState {
  const SensorConfig* config = nullptr;
  std::uint64_t index = 0;  // measurements so far
  Eigen::Isometry3d servicer_T_frame = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d frame_T_servicer = Eigen::Isometry3d::Identity();
  // The calibration error drawn for this sensor (zero without `calibration_error`): what its
  // published mounting and intrinsics differ by from the true ones.
  SensorCalibrationError calibration_error;
  std::optional<CameraSensor> camera;
  std::optional<LidarSensor> lidar;
  std::optional<TofSensor> tof;
  std::optional<ImuSensor> imu;
  std::vector<RenderOutput> renders;

  double nextTime() const { return config->phase + static_cast<double>(index) / config->rate; }
};

Simulator::~Simulator() = default;

namespace {

Timestamp micros(double t) {
  return fromSeconds(t);
}

Transform toTransform(const Eigen::Isometry3d& T, const std::string& parent,
                      const std::string& child, Timestamp stamp) {
  return Transform::fromIsometry(T, parent, child, stamp);
}

}  // namespace

namespace {

Result<std::unique_ptr<Translation>> makeTranslation(const Scenario& sc, double duration) {
  const Orbit& orbit = sc.orbit;
  std::unique_ptr<Translation> translation;
  switch (sc.translation) {
    case TranslationKind::kHold:
      translation = holdTranslation(sc.start);
      break;
    case TranslationKind::kLine:
      translation = lineTranslation(sc.start, sc.end, sc.start_time,
                                    sc.end_time < 0 ? duration : sc.end_time, sc.smooth);
      break;
    case TranslationKind::kWaypoints: {
      auto spline = sc.waypoint_legs ? legsTranslation(sc.waypoint_times, sc.waypoints)
                                     : splineTranslation(sc.waypoint_times, sc.waypoints);
      if (!spline) return spline.status();
      translation = std::move(spline).value();
      break;
    }
    case TranslationKind::kFlyAround:
      translation = flyAroundTranslation(sc.centre, sc.axis, sc.reference, sc.radius,
                                         sc.radial_rate, sc.angular_rate, sc.phase);
      break;
    case TranslationKind::kCw:
      translation = cwTranslation(orbit, sc.start, sc.velocity);
      break;
  }
  return translation;
}

std::unique_ptr<Attitude> makeServicerAttitude(const Scenario& sc, const Translation* translation,
                                               std::uint64_t seed) {
  const Orbit& orbit = sc.orbit;
  std::unique_ptr<Attitude> servicer_attitude;
  switch (sc.servicer_attitude) {
    case ServicerAttitudeKind::kTargetPointing:
      servicer_attitude =
          pointingAttitude(orbit, translation, nullptr, sc.up, sc.yaw_offset, sc.pitch_offset);
      break;
    case ServicerAttitudeKind::kLvlh:
      servicer_attitude = lvlhFixedAttitude(orbit, sc.servicer_orientation);
      break;
    case ServicerAttitudeKind::kInertial:
      servicer_attitude = inertialAttitude(orbit, sc.servicer_orientation);
      break;
  }
  if (sc.servicer_jitter > 0)
    servicer_attitude =
        jitteredAttitude(orbit, std::move(servicer_attitude), sc.servicer_jitter, seed);
  return servicer_attitude;
}

std::unique_ptr<Attitude> makeTargetAttitude(const Scenario& sc, double duration) {
  const Orbit& orbit = sc.orbit;
  std::unique_ptr<Attitude> target_attitude;
  switch (sc.target_attitude) {
    case TargetAttitudeKind::kLvlh:
      target_attitude = lvlhFixedAttitude(orbit, sc.target_initial);
      break;
    case TargetAttitudeKind::kInertial:
      target_attitude = inertialAttitude(orbit, sc.target_initial);
      break;
    case TargetAttitudeKind::kTumbling:
      target_attitude = tumblingAttitude(orbit, sc.target_initial, sc.target_rate,
                                         sc.target_inertia, duration + 2.0);
      break;
  }
  return target_attitude;
}

}  // namespace

Result<std::unique_ptr<Simulator>> Simulator::create(const Scenario& scenario,
                                                     std::optional<std::uint64_t> seed,
                                                     std::optional<double> duration) {
  std::unique_ptr<Simulator> sim(new Simulator());
  sim->scenario_ = scenario;
  const Scenario& sc = sim->scenario_;
  sim->seed_ = seed.value_or(sc.seed);
  sim->duration_ = duration.value_or(sc.duration);
  if (!(sim->duration_ > 0))
    return invalidParameter("duration = {} s; expected > 0", sim->duration_);
  CDFF_RETURN_IF_ERROR(sim->loadModels());
  // World.
  auto translation = makeTranslation(sc, sim->duration_);
  if (!translation) return translation.status();
  std::unique_ptr<Attitude> servicer_attitude =
      makeServicerAttitude(sc, translation->get(), sim->seed_);
  std::unique_ptr<Attitude> target_attitude = makeTargetAttitude(sc, sim->duration_);
  sim->world_ =
      std::make_unique<World>(sc.orbit, std::move(translation).value(),
                              std::move(servicer_attitude), std::move(target_attitude), sc.sun);
  bool cameras = false, rays = false;
  CDFF_RETURN_IF_ERROR(sim->createSensors(cameras, rays));
  CDFF_RETURN_IF_ERROR(sim->createArm());
  CDFF_RETURN_IF_ERROR(sim->prepareRendering(cameras, rays));
  sim->fault_started_.assign(sc.faults.size(), false);
  sim->fault_ended_.assign(sc.faults.size(), false);
  return sim;
}

Result<TargetModel> makeScenarioTarget(const Scenario& sc) {
  if (sc.procedural_target) return makeProceduralTarget(sc.target_spec);
  auto model = loadModel(sc.target_mesh, sc.mesh_options);
  if (!model) return model.status();
  Eigen::Isometry3d R = Eigen::Isometry3d::Identity();
  R.linear() = sc.mesh_rotation.toRotationMatrix();
  TargetModel target = transformModel(*model, R);
  target.mesh.frame_id = "target";
  return target;
}

Status Simulator::loadModels() {
  const Scenario& sc = scenario_;
  auto target = makeScenarioTarget(sc);
  if (!target) return target.status();
  target_ = std::move(target).value();
  if (sc.servicer_mockup) {
    auto mockup = makeServicerMockup(sc.servicer_spec);
    if (!mockup) return mockup.status();
    servicer_model_ = std::move(mockup).value();
  }
  return Status::ok();
}

Status Simulator::createSensors(bool& cameras, bool& rays) {
  for (const SensorConfig& s : scenario_.sensors) {
    if (!s.enabled) continue;
    auto state = std::make_unique<SensorState>();
    state->config = &s;
    state->servicer_T_frame = s.servicerTframe();
    state->frame_T_servicer = state->servicer_T_frame.inverse();
    state->calibration_error = drawCalibrationError(scenario_.calibration_error, seed_, s.name);
    switch (s.type) {
      case SensorType::kCamera: {
        auto camera = CameraSensor::create(s.camera, s.name);
        if (!camera) return camera.status();
        state->camera = std::move(camera).value();
        state->renders.resize(s.camera.motion_blur_samples);
        cameras = true;
        break;
      }
      case SensorType::kLidar: {
        LidarSpec spec = s.lidar;
        spec.rotation_rate = s.rate;
        auto lidar = LidarSensor::create(spec, s.name);
        if (!lidar) return lidar.status();
        state->lidar = std::move(lidar).value();
        rays = true;
        break;
      }
      case SensorType::kTof: {
        auto tof = TofSensor::create(s.tof, s.name);
        if (!tof) return tof.status();
        state->tof = std::move(tof).value();
        rays = true;
        break;
      }
      case SensorType::kImu: {
        ImuSpec spec = s.imu;
        spec.rate = s.rate;
        auto imu = ImuSensor::create(spec, s.name, state->servicer_T_frame, seed_);
        if (!imu) return imu.status();
        state->imu = std::move(imu).value();
        break;
      }
      case SensorType::kRadar:
        CDFF_RETURN_IF_ERROR(s.radar.validate(s.name));
        rays = true;
        break;
      case SensorType::kAhrs:
        CDFF_RETURN_IF_ERROR(s.ahrs.validate(s.name));
        break;
    }
    sensors_.push_back(std::move(state));
  }
  return Status::ok();
}

Status Simulator::prepareRendering(bool cameras, bool rays) {
  if (rays) {
    auto caster = RayCaster::create(target_);
    if (!caster) return caster.status();
    caster_ = std::move(caster).value();
  }
  if (cameras) {
    auto renderer = createRenderer(scenario_.renderer);
    if (!renderer) return renderer.status();
    renderer_ = std::move(renderer).value();
    auto handle = renderer_->addModel(target_);
    if (!handle) return handle.status();
    target_handle_ = *handle;
    if (servicer_model_) {
      auto s = renderer_->addModel(*servicer_model_);
      if (!s) return s.status();
      servicer_handle_ = *s;
    }
  }
  return Status::ok();
}

std::string Simulator::rendererDescription() const {
  return renderer_ ? renderer_->description() : "none";
}

Eigen::Isometry3d Simulator::sensorTtarget(const SensorConfig& sensor, double t) const {
  return sensor.servicerTframe().inverse() * world_->servicerTtarget(t);
}

RigidBodyState Simulator::truthState(const std::string& frame,
                                     const Eigen::Isometry3d& frame_T_servicer, double t) const {
  RigidBodyState s;
  s.pose = toTransform(frame_T_servicer * world_->servicerTtarget(t), frame, "target", micros(t));
  const Twist twist = world_->targetTwistInServicer(t);
  // A sensor is rigidly mounted: the relative velocity in its frame is the servicer's rotated.
  s.twist.linear = frame_T_servicer.linear() * twist.linear;
  s.twist.angular = frame_T_servicer.linear() * twist.angular;
  return s;
}

void Simulator::queue(std::string channel, Timestamp log_time, SimPayload payload) {
  SimMessage m;
  m.channel = std::move(channel);
  m.log_time = log_time;
  m.payload = std::move(payload);
  queue_.emplace(std::make_pair(log_time, sequence_++), std::move(m));
}

Status Simulator::flush(SimulationSink& sink, Timestamp up_to) {
  while (!queue_.empty() && queue_.begin()->first.first <= up_to) {
    CDFF_RETURN_IF_ERROR(sink.write(queue_.begin()->second));
    queue_.erase(queue_.begin());
  }
  return Status::ok();
}

Status Simulator::begin(SimulationSink& sink) {
  const Scenario& sc = scenario_;
  SimulationMetadata m;
  m.scenario = sc.name;
  m.scenario_file = sc.file.string();
  m.scenario_yaml = sc.yaml;
  m.seed = seed_;
  m.duration = duration_;
  m.renderer = rendererDescription();
  std::vector<std::string> frames = {"eci -> lvlh", "lvlh -> servicer", "lvlh -> target"};
  std::vector<std::string> sensors;
  for (const auto& s : sensors_) {
    frames.push_back("servicer -> " + s->config->frame());
    sensors.push_back(
        fmt::format("{} ({}, {} Hz)", s->config->name, toString(s->config->type), s->config->rate));
  }
  CDFF_RETURN_IF_ERROR(beginArm(m, frames));
  m.values["frames"] = fmt::format("{}", fmt::join(frames, "; "));
  m.values["sensors"] = fmt::format("{}", fmt::join(sensors, "; "));
  m.values["target_model"] = target_.name;
  m.values["target_triangles"] = std::to_string(target_.mesh.triangleCount());
  m.values["orbit"] = sc.orbit.enabled ? fmt::format("circular, altitude {} m, n = {} rad/s",
                                                     sc.orbit.altitude, sc.orbit.meanMotion())
                                       : "none (free space)";
  CDFF_RETURN_IF_ERROR(sink.begin(m));
  // The target model, in its body frame, for model-based trackers and the evaluation.
  TriangleMesh mesh = target_.mesh;
  mesh.stamp = 0;
  mesh.frame_id = "target";
  queue("/truth/target_mesh", 0, std::move(mesh));
  // Static transforms: every sensor's mounting as calibrated (with the calibration error); with
  // a calibration error, the true mountings and intrinsics as truth.
  const bool calibration_error = scenario_.calibration_error.active();
  for (const auto& s : sensors_) {
    const std::string frame = s->config->frame();
    queue("/chaser/tf/" + frame, 0,
          toTransform(perturbedMounting(s->servicer_T_frame, s->calibration_error), "servicer",
                      frame, 0));
    if (!calibration_error) continue;
    queue("/truth/tf/" + frame, 0, toTransform(s->servicer_T_frame, "servicer", frame, 0));
    const SensorConfig& c = *s->config;
    if (c.type == SensorType::kCamera || c.type == SensorType::kTof)
      queue("/truth/" + c.name + "/calibration", 0,
            CameraInfo{0, frame, c.type == SensorType::kCamera ? c.camera.model : c.tof.model});
  }
  time_ = 0;
  done_ = false;
  return Status::ok();
}

Result<bool> Simulator::step(SimulationSink& sink, double until) {
  const double end = std::min(until, duration_);
  while (!done_) {
    // The next event: a sensor measurement or a truth record, earliest first (ties in sensor
    // order, truth last).
    double next = std::numeric_limits<double>::infinity();
    SensorState* chosen = nullptr;
    for (auto& s : sensors_) {
      const double t = s->nextTime();
      if (t < next) {
        next = t;
        chosen = s.get();
      }
    }
    const double truth_time = static_cast<double>(truth_index_) / scenario_.truth_rate;
    bool truth = truth_time < next;
    if (truth) next = truth_time;
    const double arm_time = nextArmTime();  // the arm's samples after all else at that time
    const bool arm = arm_time < next;
    if (arm) {
      next = arm_time;
      truth = false;
    }
    if (next > duration_) {
      done_ = true;
      break;
    }
    if (next > end) break;
    // Fault transitions, recorded as they happen.
    for (std::size_t f = 0; f < scenario_.faults.size(); ++f) {
      const FaultConfig& fault = scenario_.faults[f];
      if (!fault_started_[f] && fault.start <= next) {
        fault_started_[f] = true;
        queue("/truth/faults", micros(fault.start),
              FaultEvent{micros(fault.start), fault.sensor, toString(fault.type), "start"});
      }
      if (!fault_ended_[f] && fault.end <= next) {
        fault_ended_[f] = true;
        queue("/truth/faults", micros(fault.end),
              FaultEvent{micros(fault.end), fault.sensor, toString(fault.type), "end"});
      }
    }
    CDFF_RETURN_IF_ERROR(flush(sink, micros(next) - 1));
    time_ = next;
    if (arm) {
      CDFF_RETURN_IF_ERROR(processArm(next));
      ++arm_steps_;
    } else if (truth) {
      CDFF_RETURN_IF_ERROR(processTruth(next));
      ++truth_index_;
    } else {
      CDFF_RETURN_IF_ERROR(process(*chosen, next));
      ++chosen->index;
    }
  }
  CDFF_RETURN_IF_ERROR(flush(sink, micros(std::min(end, time_))));
  return !done_;
}

Status Simulator::finish(SimulationSink& sink) {
  CDFF_RETURN_IF_ERROR(flush(sink, std::numeric_limits<Timestamp>::max()));
  return sink.end();
}

Status Simulator::run(SimulationSink& sink, const ProgressCallback& progress) {
  CDFF_RETURN_IF_ERROR(begin(sink));
  const double slice = std::max(duration_ / 100.0, 1e-3);
  for (double until = slice;; until += slice) {
    auto more = step(sink, until);
    if (!more) return more.status();
    if (progress) progress(std::min(time_, duration_), duration_);
    if (!*more) break;
  }
  return finish(sink);
}

Status Simulator::processTruth(double t) {
  const Timestamp stamp = micros(t);
  RigidBodyState truth = truthState("servicer", Eigen::Isometry3d::Identity(), t);
  queue("/truth/target_pose", stamp, truth.poseWithCovariance());
  queue("/truth/target_state", stamp, truth);
  const BodyState servicer = world_->servicer(t), target = world_->target(t);
  queue("/truth/tf/servicer", stamp, toTransform(servicer.lvlh_T_body, "lvlh", "servicer", stamp));
  queue("/truth/tf/target", stamp, toTransform(target.lvlh_T_body, "lvlh", "target", stamp));
  if (scenario_.orbit.enabled) {
    Eigen::Isometry3d eci_T_lvlh = Eigen::Isometry3d::Identity();
    eci_T_lvlh.linear() = scenario_.orbit.eciRotationLvlh(t);
    eci_T_lvlh.translation() = scenario_.orbit.targetPositionEci(t);
    queue("/truth/tf/lvlh", stamp, toTransform(eci_T_lvlh, "eci", "lvlh", stamp));
  }
  armTruth(t);
  return Status::ok();
}

Status Simulator::renderCamera(SensorState& sensor, double t, std::vector<RenderOutput>& renders,
                               const CameraSensor& camera) {
  const SensorConfig& c = *sensor.config;
  const int samples = c.camera.motion_blur_samples;
  for (int i = 0; i < samples; ++i) {
    // Samples spread over the exposure, centred on the image's time stamp.
    const double ts = samples == 1 ? t : t + c.camera.exposure_time * ((i + 0.5) / samples - 0.5);
    const BodyState servicer = world_->servicer(ts);
    const Eigen::Isometry3d lvlh_T_camera = servicer.lvlh_T_body * sensor.servicer_T_frame;
    const Eigen::Isometry3d camera_T_lvlh = lvlh_T_camera.inverse();
    RenderScene scene;
    scene.objects.push_back(
        {target_handle_, camera_T_lvlh * world_->target(ts).lvlh_T_body, 1, true});
    if (servicer_handle_ >= 0)
      scene.objects.push_back({servicer_handle_, sensor.frame_T_servicer, 2, true});
    scene.sun_direction = camera_T_lvlh.linear() * world_->sunDirection(ts);
    scene.sun_irradiance =
        scenario_.eclipses && world_->inEclipse(ts) ? 0.0 : world_->sun().irradiance;
    scene.shadow_map_size = c.camera.shadow_map_size;
    CDFF_RETURN_IF_ERROR(
        renderer_->render(scene, camera.renderCamera(), renders[i]).withContext(c.name));
  }
  return Status::ok();
}

Status Simulator::process(SensorState& sensor, double t) {
  const SensorConfig& c = *sensor.config;
  const Timestamp stamp = micros(t);
  // Outside its band of range the sensor is off (the mission's timeline).
  if (c.min_active_range > 0 || std::isfinite(c.max_active_range)) {
    const double range = world_->servicerTtarget(t).translation().norm();
    if (range < c.min_active_range || range > c.max_active_range) return Status::ok();
  }
  const Timestamp latency = micros(c.latency);
  // Frame-level faults: dropped and late measurements (any sensor).
  Rng fault_rng = Rng::stream(seed_, c.name + "/faults", sensor.index);
  Timestamp delay = 0;
  for (const FaultConfig& f : scenario_.faults) {
    if (!f.appliesTo(c.name) || !f.activeAt(t)) continue;
    if (f.type == FaultType::kDroppedFrames && fault_rng.uniform() < f.probability) {
      queue("/truth/faults", stamp,
            FaultEvent{stamp, c.name, "dropped_frame",
                       fmt::format("measurement {} dropped", sensor.index)});
      return Status::ok();
    }
    if (f.type == FaultType::kLateFrames && fault_rng.uniform() < f.probability) {
      delay += micros(f.delay);
      queue("/truth/faults", stamp + delay,
            FaultEvent{stamp, c.name, "late_frame",
                       fmt::format("measurement {} delayed by {} s", sensor.index, f.delay)});
    }
  }
  const Timestamp available = stamp + latency + delay;
  Rng rng = Rng::stream(seed_, c.name, sensor.index);
  switch (c.type) {
    case SensorType::kCamera:
      return processCamera(sensor, t, available, rng);
    case SensorType::kLidar:
      return processLidar(sensor, t, available, rng);
    case SensorType::kTof:
      return processTof(sensor, t, available, rng);
    case SensorType::kImu:
      return processImu(sensor, t, available);
    case SensorType::kAhrs:
      return processAhrs(sensor, t, available, rng);
    case SensorType::kRadar:
      return processRadar(sensor, t, available, rng);
  }
  return Status::ok();
}

Status Simulator::processCamera(SensorState& sensor, double t, Timestamp available, Rng& rng) {
  const SensorConfig& c = *sensor.config;
  const Timestamp stamp = micros(t);
  const std::string prefix = c.channelPrefix();
  const CameraSensor& camera = *sensor.camera;
  const CameraFaults faults = cameraFaults(c.name, t);
  CDFF_RETURN_IF_ERROR(renderCamera(sensor, t, sensor.renders, camera));
  const BackgroundView view = backgroundView(sensor, t);
  auto frame = camera.expose(sensor.renders, view, faults, rng);
  if (!frame) return frame.status().withContext(c.name);
  frame->image.stamp = stamp;
  frame->image.frame_id = c.frame();
  // The image carries the calibration as published (with the calibration error).
  const CameraModel calibrated = perturbedIntrinsics(c.camera.model, sensor.calibration_error);
  frame->image.camera = calibrated;
  queue(prefix + "/image", available, frame->image);
  queue(prefix + "/calibration", available, CameraInfo{stamp, c.frame(), calibrated});
  if (scenario_.truth_camera_depth) {
    frame->depth.image.stamp = stamp;
    frame->depth.image.frame_id = c.frame();
    queue("/truth/" + c.name + "/depth", stamp, frame->depth);
  }
  if (faults.occlusion > 0)
    queue("/truth/faults", stamp,
          FaultEvent{stamp, c.name, "occlusion",
                     fmt::format(
                         "{:.3f} of the target's pixels hidden ({})", frame->occluded_fraction,
                         faults.occlusion_mode == OcclusionMode::kShadow ? "shadow" : "occluder")});
  queue("/truth/" + c.name + "/target_pose", stamp,
        truthState(c.frame(), sensor.frame_T_servicer, t).poseWithCovariance());
  return Status::ok();
}

CameraFaults Simulator::cameraFaults(const std::string& name, double t) const {
  CameraFaults faults;
  for (const FaultConfig& f : scenario_.faults) {
    if (!f.appliesTo(name) || !f.activeAt(t)) continue;
    if (f.type == FaultType::kCameraFailure) faults.dark = true;
    if (f.type == FaultType::kGlare) {
      faults.glare_gain *= f.gain;
      faults.extra_glare += f.veil;
    }
    if (f.type == FaultType::kOcclusion) {
      faults.occlusion = f.fraction;
      faults.occlusion_mode = f.mode;
    }
  }
  return faults;
}

BackgroundView Simulator::backgroundView(const SensorState& sensor, double t) const {
  const SensorConfig& c = *sensor.config;
  const BodyState servicer = world_->servicer(t);
  const Eigen::Isometry3d lvlh_T_camera = servicer.lvlh_T_body * sensor.servicer_T_frame;
  BackgroundView view;
  view.lvlh_R_camera = lvlh_T_camera.linear();
  view.camera_position = lvlh_T_camera.translation();
  view.eci_R_lvlh = scenario_.orbit.eciRotationLvlh(t);
  view.sun_direction = world_->sunDirection(t);
  view.sun_irradiance = scenario_.eclipses && world_->inEclipse(t) ? 0.0 : world_->sun().irradiance;
  view.earth = scenario_.orbit.enabled && scenario_.earth;
  view.earth_centre = scenario_.orbit.earthCentreLvlh();
  view.stars = scenario_.stars && c.camera.stars;
  view.star_gain = scenario_.star_gain * c.camera.star_gain;
  view.star_psf_sigma = std::max(0.5, c.camera.psf_sigma);
  return view;
}

Status Simulator::processLidar(SensorState& sensor, double t, Timestamp available, Rng& rng) {
  const SensorConfig& c = *sensor.config;
  const Timestamp stamp = micros(t);
  const std::string prefix = c.channelPrefix();
  LidarFaults faults;
  for (const FaultConfig& f : scenario_.faults) {
    if (!f.appliesTo(c.name) || !f.activeAt(t)) continue;
    if (f.type == FaultType::kLidarDropout) faults.extra_dropout += f.probability;
    if (f.type == FaultType::kLidarSpurious) faults.extra_spurious += f.rate;
  }
  const Eigen::Isometry3d frame_T_servicer = sensor.frame_T_servicer;
  const RelativePose pose = [this, frame_T_servicer](double s) {
    return frame_T_servicer * world_->servicerTtarget(s);
  };
  auto cloud = sensor.lidar->scan(*caster_, target_, pose, t, faults, rng);
  if (!cloud) return cloud.status().withContext(c.name);
  cloud->stamp = stamp;
  cloud->frame_id = c.frame();
  // A scan is complete (and published) one revolution after it started, just after the LIDAR's
  // description (as a camera's calibration comes with each image).
  const Timestamp published = available + micros(sensor.lidar->period());
  queue(prefix + "/info", published, sensor.lidar->spec().info(c.frame(), stamp));
  queue(prefix + "/points", published, std::move(cloud).value());
  queue("/truth/" + c.name + "/target_pose", stamp,
        truthState(c.frame(), sensor.frame_T_servicer, t).poseWithCovariance());
  return Status::ok();
}

Status Simulator::processTof(SensorState& sensor, double t, Timestamp available, Rng& rng) {
  const SensorConfig& c = *sensor.config;
  const Timestamp stamp = micros(t);
  const std::string prefix = c.channelPrefix();
  double dropout = 0;
  for (const FaultConfig& f : scenario_.faults)
    if (f.appliesTo(c.name) && f.activeAt(t) && f.type == FaultType::kLidarDropout)
      dropout += f.probability;
  auto depth = sensor.tof->capture(*caster_, target_, sensorTtarget(c, t), dropout, rng);
  if (!depth) return depth.status().withContext(c.name);
  depth->image.stamp = stamp;
  depth->image.frame_id = c.frame();
  const CameraModel calibrated = perturbedIntrinsics(c.tof.model, sensor.calibration_error);
  if (depth->image.camera) depth->image.camera = calibrated;
  queue(prefix + "/depth", available, std::move(depth).value());
  queue(prefix + "/calibration", available, CameraInfo{stamp, c.frame(), calibrated});
  queue("/truth/" + c.name + "/target_pose", stamp,
        truthState(c.frame(), sensor.frame_T_servicer, t).poseWithCovariance());
  return Status::ok();
}

Status Simulator::processImu(SensorState& sensor, double t, Timestamp available) {
  const SensorConfig& c = *sensor.config;
  const Timestamp stamp = micros(t);
  const std::string prefix = c.channelPrefix();
  std::vector<ImuBiasJump> jumps;
  for (const FaultConfig& f : scenario_.faults)
    if (f.appliesTo(c.name) && f.type == FaultType::kImuBiasJump)
      jumps.push_back({f.start, f.gyro, f.accel});
  auto sample = sensor.imu->sample(*world_, t, jumps);
  if (!sample) return sample.status();
  sample->stamp = stamp;
  sample->frame_id = c.frame();
  queue(prefix, available, std::move(sample).value());
  return Status::ok();
}

Status Simulator::processAhrs(SensorState& sensor, double t, Timestamp available, Rng& rng) {
  const SensorConfig& c = *sensor.config;
  const Timestamp stamp = micros(t);
  const std::string prefix = c.channelPrefix();
  // The servicer body's attitude (an AHRS reports its host's attitude, whatever its
  // mounting), inertial_T_servicer; only the attitude is measured: the translation is zero,
  // with a zero covariance block.
  Eigen::Quaterniond attitude(world_->servicer(t).lvlh_T_body.linear());
  std::string inertial = "lvlh";
  if (scenario_.orbit.enabled && !c.ahrs.lvlh_frame) {
    attitude = Eigen::Quaterniond(scenario_.orbit.eciRotationLvlh(t)) * attitude;
    inertial = "eci";
  }
  const double sigma = c.ahrs.noise ? c.ahrs.attitude_sigma : 0.0;
  const Eigen::Vector3d error(rng.normal(0, sigma), rng.normal(0, sigma), rng.normal(0, sigma));
  PoseWithCovariance m;
  m.pose.stamp = stamp;
  m.pose.parent_frame = inertial;
  m.pose.child_frame = "servicer";
  m.pose.translation.setZero();
  m.pose.rotation = (expSO3(error) * attitude).normalized();
  m.covariance.setZero();
  // Perturbation in the inertial frame, as the EstimationFilter expects.
  m.covariance.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity() * std::max(sigma * sigma, 1e-12);
  queue(prefix + "/attitude", available, std::move(m));
  return Status::ok();
}

Status Simulator::processRadar(SensorState& sensor, double t, Timestamp available, Rng& rng) {
  const SensorConfig& c = *sensor.config;
  const Timestamp stamp = micros(t);
  const std::string prefix = c.channelPrefix();
  const Eigen::Isometry3d frame_T_servicer = sensor.frame_T_servicer;
  const RelativePose pose = [this, frame_T_servicer](double s) {
    return frame_T_servicer * world_->servicerTtarget(s);
  };
  auto m = measureRadar(c.radar, *caster_, pose, t, rng);
  if (!m) return m.status().withContext(c.name);
  m->stamp = stamp;
  m->frame_id = c.frame();
  queue(prefix + "/range", available, std::move(m).value());
  return Status::ok();
}

}  // namespace cdff::egse
