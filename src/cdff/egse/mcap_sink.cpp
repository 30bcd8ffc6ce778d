// The simulator's MCAP output (`cdff sim -o`, cdff.sim.run): every simulator message through
// cdff::io::Recorder, with the recording library's typed schemas (docs/recording.md), so that `cdff
// run` replays the sensor channels into DFPCs and `cdff eval` pairs their products with the /truth
// channels.
#include <nlohmann/json.hpp>

#include "cdff/egse/mcap_sink.hpp"

#include "cdff/io/recorder.hpp"

namespace cdff::egse {
namespace {

nlohmann::json vector3(const Eigen::Vector3d& v) {
  return {{"x", v.x()}, {"y", v.y()}, {"z", v.z()}};
}

class McapSink final : public egse::SimulationSink {
 public:
  Status open(const std::string& path) {
    path_ = path;
    io::McapWriterOptions options;  // lz4 chunks: deterministic bytes for a given input
    return recorder_.open(path, options);
  }

  Status begin(const egse::SimulationMetadata& m) override {
    std::map<std::string, std::string> values = m.values;
    values["scenario"] = m.scenario;
    values["scenario_file"] = m.scenario_file;
    values["seed"] = std::to_string(m.seed);
    values["duration_s"] = fmt::format("{}", m.duration);
    values["renderer"] = m.renderer;
    CDFF_RETURN_IF_ERROR(recorder_.writeMetadata("cdff.sim", values));
    // The effective scenario (overrides applied): the file alone reproduces the run.
    const std::string& yaml = m.scenario_yaml;
    return recorder_.writeAttachment(
        "scenario.yaml", "application/yaml", 0,
        io::Bytes(reinterpret_cast<const std::uint8_t*>(yaml.data()), yaml.size()));
  }

  Status write(const egse::SimMessage& message) override {
    const std::string& channel = message.channel;
    return std::visit(
        [&](const auto& v) -> Status {
          using T = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<T, egse::CameraInfo>) {
            return recorder_.writeCalibration(channel, v.model, v.stamp, v.frame_id);
          } else if constexpr (std::is_same_v<T, egse::RangeMeasurement>) {
            return writeRadar(channel, v);
          } else if constexpr (std::is_same_v<T, egse::FaultEvent>) {
            return recorder_.writeJson(
                channel, v.stamp, {{"sensor", v.sensor}, {"fault", v.fault}, {"detail", v.detail}});
          } else if constexpr (std::is_same_v<T, RigidBodyState>) {
            CDFF_RETURN_IF_ERROR(recorder_.write(channel, v));
            if (channel != "/truth/target_state") return Status::ok();
            // The relative twist on its own, for plots (the state carries it too).
            return recorder_.writeJson("/truth/target_twist", v.pose.stamp,
                                       {{"frame_id", v.pose.parent_frame},
                                        {"child_frame_id", v.pose.child_frame},
                                        {"linear", vector3(v.twist.linear)},
                                        {"angular", vector3(v.twist.angular)}});
          } else {
            return recorder_.write(channel, v);
          }
        },
        message.payload);
  }

  Status end() override { return recorder_.close(); }

 private:
  // A range, a range rate (NaN, written as null, without a detection) and the whole measurement.
  Status writeRadar(const std::string& channel, const egse::RangeMeasurement& m) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    CDFF_RETURN_IF_ERROR(recorder_.write(channel, m.valid ? m.range : nan, m.stamp));
    const std::string prefix = channel.substr(0, channel.rfind('/'));
    CDFF_RETURN_IF_ERROR(
        recorder_.write(prefix + "/range_rate", m.valid ? m.range_rate : nan, m.stamp));
    return recorder_.writeJson(prefix + "/measurement", m.stamp,
                               {{"frame_id", m.frame_id},
                                {"valid", m.valid},
                                {"range", m.range},
                                {"range_rate", m.range_rate},
                                {"direction", vector3(m.direction)},
                                {"range_sigma", m.range_sigma},
                                {"range_rate_sigma", m.range_rate_sigma},
                                {"angle_sigma", m.angle_sigma}});
  }

  std::string path_;
  io::Recorder recorder_;
};

}  // namespace

Result<std::unique_ptr<SimulationSink>> openMcapSink(const std::string& path) {
  if (path.empty())
    return Status(StatusCode::kInvalidInput,
                  "no output file: `cdff sim SCENARIO -o OUT.mcap` (or --check, --digest, "
                  "--snapshot DIR, --export-model DIR)");
  auto sink = std::make_unique<McapSink>();
  CDFF_RETURN_IF_ERROR(sink->open(path));
  return std::unique_ptr<egse::SimulationSink>(std::move(sink));
}

}  // namespace cdff::egse
