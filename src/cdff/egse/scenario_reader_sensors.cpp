// The scenario's sensors: the built-in suite (defaultSensors) changed by name, new sensors added
// with a type. Each type has its table: the keys every sensor has, then its own.
#include <algorithm>
#include <cctype>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/egse/scenario_reader.hpp"

namespace cdff::egse::scenario_reader {

namespace {

using Sensor = SensorConfig;

const std::vector<std::pair<std::string, SensorType>> kSensorTypes = {
    {"camera", SensorType::kCamera}, {"lidar", SensorType::kLidar}, {"tof", SensorType::kTof},
    {"imu", SensorType::kImu},       {"radar", SensorType::kRadar}, {"ahrs", SensorType::kAhrs}};

/// The `type` row: read before the table, which it chooses (sensorFor).
Status sensorTypeRead(const Field&, Sensor&) {
  return Status::ok();
}

struct Pose {
  Eigen::Vector3d position;
  Eigen::Quaterniond rotation;
};

Status readMount(const Field& f, Sensor& s) {
  static const Table<Pose> table = Table<Pose>("a mounting {position, rpy_deg}")
                                       .optional("position", vec3(&Pose::position))
                                       .optional("rpy_deg", rpy(&Pose::rotation));
  Pose pose{s.servicer_T_mount.translation(), Eigen::Quaterniond(s.servicer_T_mount.linear())};
  CDFF_RETURN_IF_ERROR(table.read(f, pose));
  s.servicer_T_mount = mountAt(pose.position, pose.rotation);
  return Status::ok();
}

/// [min, max] m: the band of true range in which the sensor is on.
Status readActiveRange(const Field& f, Sensor& s) {
  std::vector<double> band;
  CDFF_RETURN_IF_ERROR(f.numbers(band, 2, 2, Range::closed(0, 1e9, "m")));
  if (!(band[0] < band[1]))
    return f.fail("[min, max] metres with min < max", "min is not below max");
  s.min_active_range = band[0];
  s.max_active_range = band[1];
  return Status::ok();
}

/// The keys of every sensor.
Table<Sensor> sensorKeys(std::string what) {
  Table<Sensor> table(std::move(what));
  table.optional("type", sensorTypeRead)
      .optional("enabled", schema::flag(&Sensor::enabled))
      .optional("rate", schema::number(&Sensor::rate, Range::leftOpen(0, 10000, "Hz")))
      .optional("phase", schema::number(&Sensor::phase, Range::closed(0, 1e6, "s")))
      .optional("latency", schema::number(&Sensor::latency, Range::closed(0, 10, "s")))
      .optional("mount", readMount)
      .optional("active_range", readActiveRange);
  return table;
}

// ----------------------------------------------------------------------- camera intrinsics

CameraModel& modelOf(Sensor& s) {
  return s.type == SensorType::kTof ? s.tof.model : s.camera.model;
}

template <typename Reader>
auto inModel(Reader reader) {
  return [reader = std::move(reader)](const Field& f, Sensor& s) { return reader(f, modelOf(s)); };
}

const Range kFocalLength = Range::leftOpen(0, 1, "m");
const Range kPixelPitch = Range::leftOpen(0, 1e-3, "m");

/// width, height, fx, fy, cx, cy, focal_length, pixel_pitch: a camera's or the ToF's.
void addIntrinsics(Table<Sensor>& table) {
  const Range focal = Range::leftOpen(0, 1e6, "px"), centre = Range::closed(-1e5, 1e5, "px");
  table.optional("width", inModel(schema::integer(&CameraModel::width, 8, 16384)))
      .optional("height", inModel(schema::integer(&CameraModel::height, 8, 16384)))
      .optional("fx", inModel(schema::number(&CameraModel::fx, focal)))
      .optional("fy", inModel(schema::number(&CameraModel::fy, focal)))
      .optional("cx", inModel(schema::number(&CameraModel::cx, centre)))
      .optional("cy", inModel(schema::number(&CameraModel::cy, centre)));
}

/// What the intrinsics' keys imply for each other: focal_length and pixel_pitch give fx = fy, a
/// new size moves the principal point to the centre; fx, fy, cx, cy given explicitly stay.
Status deriveIntrinsics(const Field& f, CameraModel& m) {
  if (f.has("focal_length") && f.has("pixel_pitch")) {
    double focal_length = 0, pixel_pitch = 0;
    CDFF_RETURN_IF_ERROR(f["focal_length"].read(focal_length, kFocalLength));
    CDFF_RETURN_IF_ERROR(f["pixel_pitch"].read(pixel_pitch, kPixelPitch));
    if (!f.has("fx")) m.fx = focal_length / pixel_pitch;
    if (!f.has("fy")) m.fy = focal_length / pixel_pitch;
  }
  if (f.has("width") || f.has("height")) {
    if (!f.has("cx")) m.cx = 0.5 * (m.width - 1);
    if (!f.has("cy")) m.cy = 0.5 * (m.height - 1);
  }
  return Status::ok();
}

Status readDistortionModel(const Field& f, CameraModel& m) {
  std::string model;
  CDFF_RETURN_IF_ERROR(f.choice(model, {"none", "radial_tangential", "equidistant"}));
  m.distortion_model = model == "none"          ? DistortionModel::kNone
                       : model == "equidistant" ? DistortionModel::kEquidistant
                                                : DistortionModel::kRadialTangential;
  if (m.distortion_model == DistortionModel::kNone) m.distortion.clear();
  return Status::ok();
}

/// 4 coefficients for the equidistant model, 4 to 8 for the radial-tangential one (coefficients
/// without a model are radial-tangential).
Status readDistortion(const Field& f, CameraModel& m) {
  const std::size_t n_max = m.distortion_model == DistortionModel::kEquidistant ? 4 : 8;
  CDFF_RETURN_IF_ERROR(f.numbers(m.distortion, 4, n_max));
  if (m.distortion_model == DistortionModel::kNone)
    m.distortion_model = DistortionModel::kRadialTangential;
  return Status::ok();
}

// ---------------------------------------------------------------------------- the types

template <typename Reader>
auto inCamera(Reader reader) {
  return via(&Sensor::camera, std::move(reader));
}

const Table<Sensor>& cameraTable() {
  using C = CameraSpec;
  static const Table<Sensor> table = [] {
    Table<Sensor> t = sensorKeys("a camera's settings");
    addIntrinsics(t);
    t.optional("focal_length", inCamera(schema::number(&C::focal_length, kFocalLength)))
        .optional("pixel_pitch", inCamera(schema::number(&C::pixel_pitch, kPixelPitch)))
        .optional("distortion_model", inModel(readDistortionModel))
        .optional("distortion", inModel(readDistortion))
        .optional("format", inCamera(schema::named(&C::format, {{"mono8", PixelFormat::kGray8},
                                                                {"bgr8", PixelFormat::kBgr8}})))
        .optional("exposure_time",
                  inCamera(schema::number(&C::exposure_time, Range::leftOpen(0, 10, "s"))))
        .optional("gain_db", inCamera(schema::number(&C::gain_db, Range::closed(-20, 40, "dB"))))
        .optional("full_well",
                  inCamera(schema::number(&C::full_well, Range::leftOpen(0, 1e7, "electrons"))))
        .optional("read_noise",
                  inCamera(schema::number(&C::read_noise, Range::closed(0, 1e4, "electrons"))))
        .optional("sensitivity", inCamera(schema::number(&C::sensitivity,
                                                         Range::leftOpen(0, 1e15, "electrons/s"))))
        .optional("noise", inCamera(schema::flag(&C::noise)))
        .optional("psf_sigma", inCamera(schema::number(&C::psf_sigma, Range::closed(0, 20, "px"))))
        .optional("f_number", inCamera(schema::number(&C::f_number, Range::closed(0, 100))))
        .optional("focus_distance",
                  inCamera(schema::number(&C::focus_distance, Range::closed(0, 1e6, "m"))))
        .optional("supersampling", inCamera(schema::integer(&C::supersampling, 1, 8)))
        .optional("motion_blur_samples", inCamera(schema::integer(&C::motion_blur_samples, 1, 32)))
        .optional("stars", inCamera(schema::flag(&C::stars)))
        .optional("star_gain", inCamera(schema::number(&C::star_gain, Range::closed(0, 1e9))))
        .optional("glare_strength",
                  inCamera(schema::number(&C::glare_strength, Range::closed(0, 1e6))))
        .optional("glare_width_deg",
                  inCamera(degrees(&C::glare_width, Range::leftOpen(0, 90, "deg"))))
        .optional("glare_decay_deg",
                  inCamera(degrees(&C::glare_decay, Range::leftOpen(0, 90, "deg"))))
        .optional("shadow_map_size", inCamera(schema::integer(&C::shadow_map_size, 64, 8192)));
    return t;
  }();
  return table;
}

/// Elevations within (-90, 90) deg, stored in radians.
Status readElevations(const Field& f, LidarSpec& l) {
  std::vector<double> elevations;
  CDFF_RETURN_IF_ERROR(f.numbers(elevations, 1, 256, Range{-90, 90, true, true, "deg"}));
  for (double& e : elevations) e *= kDeg;
  l.elevations = std::move(elevations);
  return Status::ok();
}

const Table<Sensor>& lidarTable() {
  using L = LidarSpec;
  const auto lidar = [](auto reader) { return via(&Sensor::lidar, std::move(reader)); };
  static const Table<Sensor> table =
      sensorKeys("a LIDAR's settings")
          .optional("elevations_deg", lidar(readElevations))
          .optional("firing_cycle",
                    lidar(schema::number(&L::firing_cycle, Range::leftOpen(0, 1, "s"))))
          .optional("laser_interval",
                    lidar(schema::number(&L::laser_interval, Range::closed(0, 1, "s"))))
          .optional("min_range", lidar(schema::number(&L::min_range, Range::closed(0, 1e5, "m"))))
          .optional("max_range", lidar(schema::number(&L::max_range, Range::leftOpen(0, 1e5, "m"))))
          .optional("range_noise",
                    lidar(schema::number(&L::range_noise, Range::closed(0, 100, "m"))))
          .optional("dropout_probability",
                    lidar(schema::number(&L::dropout_probability, Range::closed(0, 1))))
          .optional(
              "spurious_rate",
              lidar(schema::number(&L::spurious_rate, Range::closed(0, 1e6, "returns per scan"))))
          .optional("motion_during_scan", lidar(schema::flag(&L::motion_during_scan)));
  return table;
}

const Table<Sensor>& tofTable() {
  using T = TofSpec;
  const auto tof = [](auto reader) { return via(&Sensor::tof, std::move(reader)); };
  // focal_length and pixel_pitch are read by deriveIntrinsics.
  const auto checked = [](Range range) {
    return [range](const Field& f, Sensor&) {
      double v = 0;
      return f.read(v, range);
    };
  };
  static const Table<Sensor> table = [&] {
    Table<Sensor> t = sensorKeys("a ToF camera's settings");
    addIntrinsics(t);
    t.optional("focal_length", checked(kFocalLength))
        .optional("pixel_pitch", checked(kPixelPitch))
        .optional("min_range", tof(schema::number(&T::min_range, Range::closed(0, 1e4, "m"))))
        .optional("max_range", tof(schema::number(&T::max_range, Range::leftOpen(0, 1e4, "m"))))
        .optional("noise_constant",
                  tof(schema::number(&T::noise_constant, Range::closed(0, 10, "m"))))
        .optional("noise_quadratic",
                  tof(schema::number(&T::noise_quadratic, Range::closed(0, 10, "m/m^2"))))
        .optional("min_amplitude", tof(schema::number(&T::min_amplitude, Range::closed(0, 1e6))))
        .optional("dropout_probability",
                  tof(schema::number(&T::dropout_probability, Range::closed(0, 1))));
    return t;
  }();
  return table;
}

const Table<Sensor>& imuTable() {
  using I = ImuSpec;
  const auto imu = [](auto reader) { return via(&Sensor::imu, std::move(reader)); };
  const auto bias = [](std::optional<Eigen::Vector3d> I::*member) {
    return [member](const Field& f, Sensor& s) -> Status {
      Eigen::Vector3d b;
      CDFF_RETURN_IF_ERROR(readVec3(f, b));
      s.imu.*member = b;
      return Status::ok();
    };
  };
  static const Table<Sensor> table =
      sensorKeys("an IMU's settings")
          .optional(
              "gyro_noise_density",
              imu(schema::number(&I::gyro_noise_density, Range::closed(0, 1, "rad/s/sqrt(Hz)"))))
          .optional(
              "accel_noise_density",
              imu(schema::number(&I::accel_noise_density, Range::closed(0, 10, "m/s^2/sqrt(Hz)"))))
          .optional("gyro_bias_sigma",
                    imu(schema::number(&I::gyro_bias_sigma, Range::closed(0, 10, "rad/s"))))
          .optional("accel_bias_sigma",
                    imu(schema::number(&I::accel_bias_sigma, Range::closed(0, 100, "m/s^2"))))
          .optional(
              "gyro_bias_random_walk",
              imu(schema::number(&I::gyro_bias_random_walk, Range::closed(0, 1, "rad/s/sqrt(s)"))))
          .optional("accel_bias_random_walk",
                    imu(schema::number(&I::accel_bias_random_walk,
                                       Range::closed(0, 10, "m/s^2/sqrt(s)"))))
          .optional("gyro_bias", bias(&I::gyro_bias))
          .optional("accel_bias", bias(&I::accel_bias))
          .optional("gyro_range",
                    imu(schema::number(&I::gyro_range, Range::leftOpen(0, 1000, "rad/s"))))
          .optional("accel_range",
                    imu(schema::number(&I::accel_range, Range::leftOpen(0, 10000, "m/s^2"))))
          .optional("noise", imu(schema::flag(&I::noise)));
  return table;
}

const Table<Sensor>& radarTable() {
  using R = RadarSpec;
  const auto radar = [](auto reader) { return via(&Sensor::radar, std::move(reader)); };
  static const Table<Sensor> table =
      sensorKeys("a radar's settings")
          .optional("min_range", radar(schema::number(&R::min_range, Range::closed(0, 1e8, "m"))))
          .optional("max_range", radar(schema::number(&R::max_range, Range::leftOpen(0, 1e8, "m"))))
          .optional("beam_half_angle_deg",
                    radar(degrees(&R::beam_half_angle, Range::leftOpen(0, 180, "deg"))))
          .optional("range_noise",
                    radar(schema::number(&R::range_noise, Range::closed(0, 1e4, "m"))))
          .optional("range_rate_noise",
                    radar(schema::number(&R::range_rate_noise, Range::closed(0, 1e3, "m/s"))))
          .optional("angle_noise_deg", radar(degrees(&R::angle_noise, Range::closed(0, 90, "deg"))))
          .optional("dropout_probability",
                    radar(schema::number(&R::dropout_probability, Range::closed(0, 1, ""))));
  return table;
}

const Table<Sensor>& ahrsTable() {
  static const Table<Sensor> table =
      sensorKeys("an AHRS's settings")
          .optional("attitude_sigma",
                    via(&Sensor::ahrs,
                        schema::number(&AhrsSpec::attitude_sigma, Range::closed(0, M_PI, "rad"))))
          .optional("noise", via(&Sensor::ahrs, schema::flag(&AhrsSpec::noise)))
          .optional("frame",
                    via(&Sensor::ahrs, schema::named(&AhrsSpec::lvlh_frame,
                                                     {{"inertial", false}, {"lvlh", true}})));
  return table;
}

const Table<Sensor>& tableOf(SensorType type) {
  switch (type) {
    case SensorType::kCamera:
      return cameraTable();
    case SensorType::kLidar:
      return lidarTable();
    case SensorType::kTof:
      return tofTable();
    case SensorType::kImu:
      return imuTable();
    case SensorType::kRadar:
      return radarTable();
    case SensorType::kAhrs:
      return ahrsTable();
  }
  return cameraTable();
}

Status validate(const Sensor& s) {
  switch (s.type) {
    case SensorType::kCamera:
      return s.camera.validate(s.name);
    case SensorType::kLidar:
      return s.lidar.validate(s.name);
    case SensorType::kTof:
      return s.tof.validate(s.name);
    case SensorType::kImu:
      return s.imu.validate(s.name);
    case SensorType::kRadar:
      return s.radar.validate(s.name);
    case SensorType::kAhrs:
      return s.ahrs.validate(s.name);
  }
  return Status::ok();
}

Status readSensor(const Field& f, Sensor& s, int shadow_map_size) {
  if (s.type == SensorType::kCamera) s.camera.shadow_map_size = shadow_map_size;
  CDFF_RETURN_IF_ERROR(tableOf(s.type).read(f, s));
  if (s.type == SensorType::kCamera || s.type == SensorType::kTof)
    CDFF_RETURN_IF_ERROR(deriveIntrinsics(f, modelOf(s)));
  // The LIDAR turns, and the IMU samples, at the sensor's rate.
  if (s.type == SensorType::kLidar) s.lidar.rotation_rate = s.rate;
  if (s.type == SensorType::kImu) s.imu.rate = s.rate;
  return validate(s).withContext(f.path()).at(f.location());
}

// ------------------------------------------------------------------------ built-in or new

bool isSensorName(const std::string& name) {
  bool valid = !name.empty();
  for (char c : name) valid = valid && (std::isalnum(static_cast<unsigned char>(c)) || c == '_');
  return valid;
}

/// A new sensor: the first built-in one of its type, renamed and enabled.
Result<Sensor> newSensor(const Field::Entry& entry, const std::vector<Sensor>& sensors,
                         int shadow_map_size) {
  const Field& f = entry.value;
  std::vector<std::string> types, names;
  for (const auto& [word, type] : kSensorTypes) types.push_back(word);
  for (const Sensor& s : sensors) names.push_back(s.name);
  if (!f.has("type"))
    return f.missing("type",
                     fmt::format("a new sensor's type: one of {{{}}}; or the name of a "
                                 "built-in sensor{}",
                                 fmt::join(types, ", "), schema::didYouMean(entry.key, names)));
  if (!isSensorName(entry.key))
    return entry.key_field.fail("a sensor name of letters, digits and '_'");
  Sensor s;
  s.name = entry.key;
  CDFF_RETURN_IF_ERROR(schema::named(&Sensor::type, kSensorTypes)(f["type"], s));
  for (const Sensor& d : defaultSensors())
    if (d.type == s.type) {
      const std::string keep = s.name;
      s = d;
      s.name = keep;
      s.enabled = true;
      break;
    }
  if (s.type == SensorType::kCamera) s.camera.shadow_map_size = shadow_map_size;
  return s;
}

/// The sensor `entry` changes: a built-in one (whose type, if given, must be its own) or a new one.
Result<Sensor*> sensorFor(const Field::Entry& entry, ScenarioDraft& d) {
  const Field& f = entry.value;
  if (!f.isMap()) return f.fail("a map of the sensor's settings");
  std::vector<Sensor>& sensors = d.scenario.sensors;
  for (Sensor& s : sensors) {
    if (s.name != entry.key) continue;
    if (f.has("type")) {
      std::string type;
      CDFF_RETURN_IF_ERROR(f["type"].read(type));
      if (type != toString(s.type))
        return f["type"].fail(
            fmt::format("'{}'", toString(s.type)),
            fmt::format("the built-in sensor '{}' is a {}", s.name, toString(s.type)));
    }
    return &s;
  }
  Result<Sensor> added = newSensor(entry, sensors, d.shadow_map_size);
  if (!added) return added.status();
  sensors.push_back(std::move(added).value());
  return &sensors.back();
}

}  // namespace

Status readSensors(const Field& f, ScenarioDraft& d) {
  if (!f.isMap()) return f.fail("a map of sensor name: settings");
  std::vector<std::string> seen;
  for (const Field::Entry& entry : f.entries()) {
    if (std::find(seen.begin(), seen.end(), entry.key) != seen.end())
      return entry.key_field.fail("each sensor once", "given twice");
    seen.push_back(entry.key);
    Result<Sensor*> sensor = sensorFor(entry, d);
    if (!sensor) return sensor.status();
    CDFF_RETURN_IF_ERROR(readSensor(entry.value, **sensor, d.shadow_map_size));
  }
  return Status::ok();
}

}  // namespace cdff::egse::scenario_reader
