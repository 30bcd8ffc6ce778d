#pragma once
// The simulator: runs a scenario and hands every sensor measurement and ground-truth record to a
// sink, in log-time order.
//
//   auto scenario = loadScenario(resolveScenario("mid_range_approach").value());
//   auto sim = Simulator::create(*scenario, /*seed=*/7);
//   MemorySink sink;
//   CDFF_RETURN_IF_ERROR((*sim)->run(sink));
//
// Channels (docs/simulator.md): /chaser/camera/<side>/image and .../calibration,
// /chaser/lidar/points and .../info, /chaser/tof/depth and .../calibration, /chaser/imu,
// /chaser/radar/range, /chaser/tf/<sensor frame> (mountings), /truth/target_pose
// (servicer_T_target), /truth/target_state (the same with the relative twist),
// /truth/<sensor>/target_pose (<sensor frame>_T_target), /truth/tf/{servicer,target,lvlh},
// /truth/target_mesh, /truth/<camera>/depth (optional), /truth/faults; with an arm,
// /chaser/arm/joints, /chaser/arm/wrench, /chaser/tf/<arm base>, /truth/arm/contact,
// /truth/arm/contact_force, /truth/arm/target_pose.
//
// Determinism: every random draw comes from a stream named after the run's seed, the sensor and
// the measurement index; rendering and ray casting run on one thread. The same scenario, seed and
// build give the same messages, bit for bit.

#include <functional>
#include <map>
#include <memory>
#include <optional>

#include "cdff/egse/camera_sensor.hpp"
#include "cdff/egse/raycaster.hpp"
#include "cdff/egse/render.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/egse/sink.hpp"

namespace cdff::egse {

/// The scenario's target model as the simulator uses it: the procedural target its spec selects,
/// or its mesh file loaded and turned by `target.mesh.rpy_deg`.
Result<TargetModel> makeScenarioTarget(const Scenario& scenario);

/// Called as simulated time advances (about every 1 % of the run).
using ProgressCallback = std::function<void(double time, double duration)>;

class Simulator {
 public:
  ~Simulator();

  /// Builds the models, the world, the renderer and the sensors. `seed` and `duration`
  /// override the scenario's.
  static Result<std::unique_ptr<Simulator>> create(const Scenario& scenario,
                                                   std::optional<std::uint64_t> seed = std::nullopt,
                                                   std::optional<double> duration = std::nullopt);

  /// begin(), step() until the end, finish().
  Status run(SimulationSink& sink, const ProgressCallback& progress = {});
  /// Writes the metadata and the static transforms.
  Status begin(SimulationSink& sink);
  /// Simulates up to `until` (s) and writes what became available by then. Returns false once
  /// the run's duration is reached.
  Result<bool> step(SimulationSink& sink, double until);
  /// Writes what is still queued (late frames, the last LIDAR scan) and ends the sink.
  Status finish(SimulationSink& sink);

  const Scenario& scenario() const { return scenario_; }
  std::uint64_t seed() const { return seed_; }
  double duration() const { return duration_; }
  const World& world() const { return *world_; }
  const TargetModel& target() const { return target_; }
  /// Which renderer runs ("cpu: ..." or "opengl: ..."), or "none" without cameras.
  std::string rendererDescription() const;
  /// <sensor frame>_T_target at time t.
  Eigen::Isometry3d sensorTtarget(const SensorConfig& sensor, double t) const;

 private:
  Simulator() = default;
  struct SensorState;
  // The steps of create().
  Status loadModels();
  Status createSensors(bool& cameras, bool& rays);  // says which need a renderer, a ray caster
  Status prepareRendering(bool cameras, bool rays);
  // A measurement of `sensor` at time t, with its frame-level faults; then, by sensor type, the
  // measurement made available at `available` with this measurement's noise stream `rng`.
  Status process(SensorState& sensor, double t);
  Status processCamera(SensorState& sensor, double t, Timestamp available, Rng& rng);
  Status processLidar(SensorState& sensor, double t, Timestamp available, Rng& rng);
  Status processTof(SensorState& sensor, double t, Timestamp available, Rng& rng);
  Status processImu(SensorState& sensor, double t, Timestamp available);
  Status processAhrs(SensorState& sensor, double t, Timestamp available, Rng& rng);
  Status processRadar(SensorState& sensor, double t, Timestamp available, Rng& rng);
  CameraFaults cameraFaults(const std::string& name, double t) const;  // active at t
  BackgroundView backgroundView(const SensorState& sensor, double t) const;
  Status processTruth(double t);
  // The manipulator (scenario.arm, simulator_arm.cpp): created with the sensors, stepped at its
  // rate as an event of its own.
  Status createArm();
  double nextArmTime() const;  // infinity without an arm
  Status processArm(double t);
  Status beginArm(SimulationMetadata& metadata, std::vector<std::string>& frames);
  void armTruth(double t);
  Status renderCamera(SensorState& sensor, double t, std::vector<RenderOutput>& renders,
                      const CameraSensor& camera);
  void queue(std::string channel, Timestamp log_time, SimPayload payload);
  Status flush(SimulationSink& sink, Timestamp up_to);
  RigidBodyState truthState(const std::string& frame, const Eigen::Isometry3d& frame_T_servicer,
                            double t) const;

  Scenario scenario_;
  std::uint64_t seed_ = 1;
  double duration_ = 0;
  TargetModel target_;
  std::optional<TargetModel> servicer_model_;
  std::unique_ptr<World> world_;
  std::unique_ptr<RayCaster> caster_;
  std::unique_ptr<Renderer> renderer_;
  int target_handle_ = -1, servicer_handle_ = -1;
  std::vector<std::unique_ptr<SensorState>> sensors_;
  std::unique_ptr<ArmSimulator> arm_;
  std::uint64_t arm_steps_ = 0;
  std::uint64_t truth_index_ = 0;
  std::vector<bool> fault_started_, fault_ended_;
  std::map<std::pair<Timestamp, std::uint64_t>, SimMessage> queue_;
  std::uint64_t sequence_ = 0;
  double time_ = 0;
  bool done_ = false;
};

}  // namespace cdff::egse
