// dfpcs/haptic_scanning.yaml end to end, as a user runs it: `cdff sim haptic_scanning` (the arm
// touching a 6 cm disc of the target's face along random collision paths while the target turns),
// `cdff run` with the truth's target pose, the products read back and compared with the truth:
// the contacts (each true contact found within the contact goal, 1 mm and 3 deg, no false one)
// and the mesh (within the mesh goal, 2 mm, of the target's true surface over the touched area:
// 4000 points sampled on the mesh against the true surface, and every press the mesh joins
// against the mesh).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>

#include "cdff/egse/raycaster.hpp"
#include "cdff/egse/simulator.hpp"
#include "cdff/io/replay.hpp"
#include "support/command.hpp"
#include "support/mesh_distance.hpp"
#include "support/synthetic.hpp"

namespace cdff {
namespace {

constexpr double kPointGoal = 1e-3;      // m, contact point error
constexpr double kNormalGoal = 3.0;      // deg, contact normal error
constexpr double kMeshGoal = 2e-3;       // m, Hausdorff to the true surface
constexpr Timestamp kSamePress = 1'500;  // us: consecutive 1 kHz contact samples, one press
const std::string kProducts = "/cdff/haptic_scanning/";

struct Recorded {
  std::vector<PointCloud> truth;  // /truth/arm/contact, one point each
  std::optional<PointCloud> map;  // the last contacts product
  std::optional<TriangleMesh> mesh;
};

Result<Recorded> read(const std::string& file) {
  io::Replay replay;
  CDFF_RETURN_IF_ERROR(replay.open({file}));
  Recorded r;
  while (replay.next()) {
    const io::ReplayMessage& m = replay.message();
    if (m.channel() == "/truth/arm/contact" || m.channel() == kProducts + "contacts") {
      auto c = m.decode<PointCloud>();
      if (!c) return c.status();
      if (m.channel() == "/truth/arm/contact")
        r.truth.push_back(**c);
      else
        r.map = **c;
    } else if (m.channel() == kProducts + "mesh") {
      auto mesh = m.decode<TriangleMesh>();
      if (!mesh) return mesh.status();
      r.mesh = **mesh;
    }
  }
  CDFF_RETURN_IF_ERROR(replay.status());
  return r;
}

/// One point per press: the sample of the largest normal force of each run of consecutive samples.
std::vector<std::size_t> presses(const std::vector<PointCloud>& truth) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const bool new_press = i == 0 || truth[i].stamp - truth[i - 1].stamp > kSamePress;
    if (new_press)
      out.push_back(i);
    else if (truth[i].intensity[0] > truth[out.back()].intensity[0])
      out.back() = i;
  }
  return out;
}

double nearest(const PointCloud& cloud, const Eigen::Vector3d& p, std::size_t* index = nullptr) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double d = (cloud.points[i].vec().cast<double>() - p).norm();
    if (d < best && index) *index = i;
    best = std::min(best, d);
  }
  return best;
}

class HapticScanning : public ::testing::Test {
 protected:
  void SetUp() override {
    // The graph names the arm's URDF relative to the repository root, as `cdff run` is run.
    std::filesystem::current_path(CDFF_SOURCE_DIR);
    const std::filesystem::path dir = testing::scratchDirectory("haptic");
    const std::string sim = (dir / "sim.mcap").string(), out = (dir / "out.mcap").string();
    // CDFF_HAPTIC_SIM adds `cdff sim` options (a longer scan: --duration 300; another --seed);
    // docs/haptic-scanning.md has the figures.
    const char* options = std::getenv("CDFF_HAPTIC_SIM");
    const testing::CommandResult s = testing::runCdff(
        fmt::format("sim haptic_scanning -q {} -o {}", options ? options : "", sim));
    ASSERT_EQ(s.status, 0) << s.output;
    const testing::CommandResult r =
        testing::runCdff(fmt::format("run dfpcs/haptic_scanning.yaml -q -i {} -o {}", sim, out));
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("0 faults"), std::string::npos) << r.output;
    Result<Recorded> recorded = read(out);
    ASSERT_OK(recorded.status());
    recorded_ = std::move(recorded).value();
    std::filesystem::remove_all(dir);
    auto scenario = egse::loadScenario(*egse::resolveScenario("haptic_scanning"));
    ASSERT_OK(scenario.status());
    auto target = egse::makeScenarioTarget(*scenario);
    ASSERT_OK(target.status());
    auto caster = egse::RayCaster::create(*target);
    ASSERT_OK(caster.status());
    caster_ = std::move(caster).value();
  }

  /// The distance from p to the target's true surface (searched within 5 cm).
  egse::SurfacePoint surface(const Eigen::Vector3d& p) const {
    return caster_->closestPoint(p, 0.05);
  }

  Recorded recorded_;
  std::unique_ptr<egse::RayCaster> caster_;
};

TEST_F(HapticScanning, EveryContactFoundOnTheTrueSurfaceAndTheMeshWithinTwoMillimetres) {
  ASSERT_TRUE(recorded_.map.has_value()) << "no contacts product";
  ASSERT_TRUE(recorded_.mesh.has_value()) << "no mesh product";
  const PointCloud& map = *recorded_.map;
  const TriangleMesh& mesh = *recorded_.mesh;
  EXPECT_EQ(map.frame_id, "target");
  EXPECT_EQ(mesh.frame_id, "target");
  // Every voxel of the map on the true surface, with its normal.
  double worst_point = 0, worst_angle = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const egse::SurfacePoint s = surface(map.points[i].vec().cast<double>());
    ASSERT_TRUE(s.found) << "map point " << i << " is more than 5 cm off the target";
    worst_point = std::max(worst_point, s.distance);
    const double cosine =
        std::clamp(map.normals[i].vec().cast<double>().dot(s.face_normal), -1.0, 1.0);
    worst_angle = std::max(worst_angle, std::acos(cosine) * 180 / M_PI);
  }
  // Every press found: a voxel within the point goal of the true contact; no voxel farther than
  // the goal from every true contact sample (a false contact).
  const std::vector<std::size_t> truth = presses(recorded_.truth);
  int found = 0;
  for (std::size_t k : truth)
    found += nearest(map, recorded_.truth[k].points[0].vec().cast<double>()) <= kPointGoal;
  int false_contacts = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (const PointCloud& t : recorded_.truth)
      best = std::min(best, (t.points[0].vec() - map.points[i].vec()).cast<double>().norm());
    false_contacts += best > kPointGoal;
  }
  // The mesh: 4000 points sampled on it against the true surface, and every press whose voxel is
  // a vertex of a triangle (the touched area the mesh spans) against the mesh.
  Result<PointCloud> samples = sampleSurface(mesh, 4000, 3, SampleNormals::kFace);
  ASSERT_OK(samples.status());
  double mesh_to_surface = 0;
  for (std::size_t i = 0; i < samples->size(); ++i) {
    const egse::SurfacePoint s = surface(samples->points[i].vec().cast<double>());
    mesh_to_surface = std::max(mesh_to_surface, s.found ? s.distance : 0.05);
  }
  std::vector<bool> in_triangle(mesh.vertexCount(), false);
  for (const auto& t : mesh.triangles)
    for (std::uint32_t v : t) in_triangle[v] = true;
  double touched_to_mesh = 0;
  int joined = 0;
  for (std::size_t k : truth) {
    const Eigen::Vector3d p = recorded_.truth[k].points[0].vec().cast<double>();
    std::size_t voxel = 0;
    if (nearest(map, p, &voxel) > kPointGoal || voxel >= in_triangle.size() || !in_triangle[voxel])
      continue;
    ++joined;
    touched_to_mesh = std::max(touched_to_mesh, testing::distanceToMesh(mesh, p));
  }
  std::printf(
      "%zu presses, %d found (point goal %.1f mm), %zu voxels, %d false; voxel point error max "
      "%.3f mm, normal max %.2f deg; mesh %zu triangles joining %d presses, mesh to surface "
      "%.3f mm, touched presses to mesh %.3f mm\n",
      truth.size(), found, kPointGoal * 1e3, map.size(), false_contacts, worst_point * 1e3,
      worst_angle, mesh.triangleCount(), joined, mesh_to_surface * 1e3, touched_to_mesh * 1e3);
  ASSERT_GE(truth.size(), 10u) << "the scenario's 30 s should hold a press every 2 s or so";
  EXPECT_GE(found, static_cast<int>(truth.size()) * 99 / 100);
  EXPECT_EQ(false_contacts, 0);
  EXPECT_LE(worst_point, kPointGoal);
  EXPECT_LE(worst_angle, kNormalGoal);
  EXPECT_GE(joined, static_cast<int>(truth.size()) / 2) << "most presses should be meshed";
  EXPECT_LE(mesh_to_surface, kMeshGoal);
  EXPECT_LE(touched_to_mesh, kMeshGoal);
}

}  // namespace
}  // namespace cdff
