// Model errors (model_perturbation.hpp), the targets' named parts and the second procedural
// target: a perturbed model differs from the simulated one exactly as asked (1 % larger, a part
// gone or added, the same surface in other triangles), and bad requests are refused with the
// value and what was expected.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "cdff/egse/model_io.hpp"
#include "cdff/egse/model_perturbation.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/egse/simulator.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

TargetModel satellite() {
  return std::move(makeTargetSatellite()).value();
}

std::size_t partIndex(const TargetModel& model, const std::string& name) {
  const auto it = std::find(model.parts.begin(), model.parts.end(), name);
  EXPECT_NE(it, model.parts.end()) << name;
  return static_cast<std::size_t>(it - model.parts.begin());
}

double partArea(const TargetModel& model, const std::string& name) {
  const std::size_t part = partIndex(model, name);
  double area = 0;
  for (std::size_t t = 0; t < model.mesh.triangles.size(); ++t) {
    if (model.triangle_part[t] != part) continue;
    const auto& tri = model.mesh.triangles[t];
    const Eigen::Vector3d a = model.mesh.vertices[tri[0]].cast<double>();
    area += 0.5 * (model.mesh.vertices[tri[1]].cast<double>() - a)
                      .cross(model.mesh.vertices[tri[2]].cast<double>() - a)
                      .norm();
  }
  return area;
}

// The signed volume the triangles enclose (divergence theorem): a function of the surface
// alone, whatever its triangulation.
double signedVolume(const TargetModel& model) {
  double volume = 0;
  for (const auto& t : model.mesh.triangles)
    volume +=
        model.mesh.vertices[t[0]].cast<double>().dot(model.mesh.vertices[t[1]].cast<double>().cross(
            model.mesh.vertices[t[2]].cast<double>())) /
        6.0;
  return volume;
}

// The length of the welded mesh's boundary edges: T-junctions (a split edge whose neighbour was
// not split) would add boundary.
double boundaryLength(const TargetModel& model) {
  double length = 0;
  for (const ModelEdge& e : extractEdges(model))
    if (e.boundary) length += (e.a - e.b).cast<double>().norm();
  return length;
}

using Triple = std::array<float, 9>;
std::set<Triple> trianglePositions(const TargetModel& model) {
  std::set<Triple> out;
  for (const auto& t : model.mesh.triangles) {
    Triple k;
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 3; ++i) k[3 * c + i] = model.mesh.vertices[t[c]][i];
    out.insert(k);
  }
  return out;
}

TEST(TargetParts, EveryTriangleOfBothTargetsBelongsToANamedPart) {
  const TargetModel sat = satellite();
  EXPECT_EQ(sat.parts, (std::vector<std::string>{"bus", "wing_right", "wing_left", "adapter_ring",
                                                 "launcher_brackets", "thrusters", "antenna"}));
  ASSERT_EQ(sat.triangle_part.size(), sat.mesh.triangles.size());
  for (const std::string& part : sat.parts) EXPECT_GT(partArea(sat, part), 0.0) << part;
  // The bus's box: 2 (1.2 x 1.0 + 1.2 x 1.0 + 1.0 x 1.0) m^2.
  EXPECT_NEAR(partArea(sat, "bus"), 2 * (1.2 + 1.2 + 1.0), 1e-5);

  auto hex = makeHexagonalSatellite();
  ASSERT_OK(hex.status());
  EXPECT_EQ(hex->parts,
            (std::vector<std::string>{"bus", "solar_wing", "boom", "nozzle", "star_tracker"}));
  ASSERT_OK(hex->validate());
}

TEST(TargetParts, SurviveAPlyRoundTrip) {
  const TargetModel sat = satellite();
  const auto path = std::filesystem::temp_directory_path() /
                    ("cdff_parts_" + std::to_string(::getpid()) + ".ply");
  ASSERT_OK(writePly(sat, path, true));
  auto loaded = loadModel(path);
  std::filesystem::remove(path);
  ASSERT_OK(loaded.status());
  EXPECT_EQ(loaded->parts, sat.parts);
  EXPECT_EQ(loaded->triangle_part, sat.triangle_part);
}

TEST(SecondTarget, IsClearlyDifferentFromTheFirst) {
  const TargetModel sat = satellite();
  const TargetModel hex = std::move(makeHexagonalSatellite()).value();
  const Eigen::Vector3d a = sat.bounds().sizes(), b = hex.bounds().sizes();
  // The bus: 1.4 m long and 1.6 m across its corners (the first: 1.2 x 1.0 x 1.0 m).
  EXPECT_NEAR(partArea(hex, "bus"), 6 * 0.8 * 1.4 + 2 * (3 * std::sqrt(3.0) / 2 * 0.8 * 0.8), 1e-4);
  // One wing: the model reaches far out on +y only (the first is symmetric).
  EXPECT_GT(hex.bounds().max().y(), 3.5);
  EXPECT_LT(hex.bounds().min().y(), -1.0);  // the boom
  EXPECT_GT(hex.bounds().max().y() + hex.bounds().min().y(), 1.5);
  EXPECT_NEAR(sat.bounds().max().y() + sat.bounds().min().y(), 0.0, 1e-5);
  EXPECT_GT((a - b).cwiseAbs().maxCoeff(), 0.5);
  // The nozzle on -x stands out of the bus's aft face.
  EXPECT_LT(hex.bounds().min().x(), -0.7 - 0.3);
}

// data/models/hexagonal_target.ply is the export of the generator's default (the command in
// data/models/README.md): the same geometry and parts.
TEST(SecondTarget, TheCommittedModelIsTheGeneratorsExport) {
  const TargetModel hex = std::move(makeHexagonalSatellite()).value();
  auto committed =
      loadModel(std::filesystem::path(CDFF_SOURCE_DIR) / "data/models/hexagonal_target.ply");
  ASSERT_OK(committed.status());
  EXPECT_EQ(committed->parts, hex.parts);
  EXPECT_EQ(committed->mesh.triangles.size(), hex.mesh.triangles.size());
  EXPECT_NEAR(committed->surfaceArea(), hex.surfaceArea(), 1e-6 * hex.surfaceArea());
  EXPECT_LT((committed->bounds().min() - hex.bounds().min()).norm(), 1e-6);
  EXPECT_LT((committed->bounds().max() - hex.bounds().max()).norm(), 1e-6);
}

TEST(SecondTarget, ItsSpecIsValidated) {
  HexagonalTargetSpec spec;
  spec.bus_length = -1;
  auto bad = makeHexagonalSatellite(spec);
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find("'bus_length' = -1"), std::string::npos)
      << bad.status().message();
  spec = {};
  spec.nozzle_exit_diameter = 2.0;
  bad = makeHexagonalSatellite(spec);
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find("does not fit"), std::string::npos)
      << bad.status().message();
}

TEST(SecondTarget, IsSelectedByTheScenario) {
  auto path = resolveScenario("mid_range_approach");
  ASSERT_OK(path.status());
  auto scenario = loadScenario(
      *path, {"target.procedural.kind=hexagonal", "target.procedural.hexagonal.boom_length=1.2"});
  ASSERT_OK(scenario.status());
  auto model = makeScenarioTarget(*scenario);
  ASSERT_OK(model.status());
  EXPECT_EQ(model->name, "hexagonal_satellite");
  // A key of the other kind is refused, naming it.
  auto wrong = loadScenario(
      *path, {"target.procedural.kind=hexagonal", "target.procedural.bus_size=[1,1,1]"});
  ASSERT_FALSE(wrong.isOk());
  EXPECT_NE(wrong.status().message().find("'bus_size' does not apply to kind hexagonal"),
            std::string::npos)
      << wrong.status().message();
  auto negative = loadScenario(
      *path, {"target.procedural.kind=hexagonal", "target.procedural.hexagonal.bus_diameter=-2"});
  ASSERT_FALSE(negative.isOk());
  EXPECT_NE(negative.status().message().find("bus_diameter"), std::string::npos)
      << negative.status().message();
}

TEST(ModelErrors, AScaleErrorMakesTheBoundingBoxThatMuchLarger) {
  const TargetModel sat = satellite();
  for (const Eigen::Vector3d& error :
       {Eigen::Vector3d(0.01, 0.01, 0.01), Eigen::Vector3d(0.01, 0.0, -0.01)}) {
    ModelPerturbation p;
    p.scale_error = error;
    auto out = perturbModel(sat, p);
    ASSERT_OK(out.status());
    const Eigen::Vector3d ratio = out->bounds().sizes().cwiseQuotient(sat.bounds().sizes());
    // float vertices: relative rounding 6e-8.
    EXPECT_LT((ratio - (Eigen::Vector3d::Ones() + error)).cwiseAbs().maxCoeff(), 1e-6)
        << ratio.transpose();
    EXPECT_EQ(out->mesh.triangles.size(), sat.mesh.triangles.size());
    EXPECT_EQ(out->polygons.size(), sat.polygons.size());
    // Normals stay unit and follow the faces: a box face's normal is still its axis.
    for (const auto& n : out->mesh.vertex_normals) EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
  }
}

TEST(ModelErrors, ARemovedPartIsGoneAndNothingElse) {
  const TargetModel sat = satellite();
  ModelPerturbation p;
  p.remove_parts = {"antenna"};
  auto out = perturbModel(sat, p);
  ASSERT_OK(out.status());
  EXPECT_EQ(std::find(out->parts.begin(), out->parts.end(), "antenna"), out->parts.end());
  EXPECT_EQ(out->parts.size(), sat.parts.size() - 1);
  EXPECT_NEAR(out->surfaceArea(), sat.surfaceArea() - partArea(sat, "antenna"), 1e-6);
  for (const std::string& part : out->parts)
    EXPECT_NEAR(partArea(*out, part), partArea(sat, part), 1e-9) << part;
  // The dish was the highest point: the model is lower now (the bus's top at 0.5 m).
  EXPECT_LT(out->bounds().max().z(), sat.bounds().max().z() - 0.3);
  EXPECT_NEAR(out->bounds().max().z(), 0.5, 1e-6);
  // Unused vertices are dropped.
  std::vector<bool> used(out->mesh.vertices.size(), false);
  for (const auto& t : out->mesh.triangles)
    for (auto v : t) used[v] = true;
  EXPECT_EQ(std::count(used.begin(), used.end(), false), 0);
}

TEST(ModelErrors, AnAddedBoxIsANewPart) {
  const TargetModel sat = satellite();
  ModelPerturbation p;
  p.add_boxes = {{"payload", {0.3, 0.0, 0.6}, {0.1, 0.15, 0.1}}};
  auto out = perturbModel(sat, p);
  ASSERT_OK(out.status());
  EXPECT_EQ(out->parts.back(), "payload");
  EXPECT_NEAR(partArea(*out, "payload"), 8 * (0.1 * 0.15 + 0.15 * 0.1 + 0.1 * 0.1), 1e-6);
  EXPECT_NEAR(out->surfaceArea(), sat.surfaceArea() + partArea(*out, "payload"), 1e-6);
  EXPECT_EQ(out->polygons.size(), sat.polygons.size() + 6);
}

TEST(ModelErrors, ARetriangulatedMeshHasTheSameSurfaceInOtherTriangles) {
  const TargetModel sat = satellite();
  constexpr double kMaxEdge = 0.1;
  ModelPerturbation p;
  p.flip_diagonals = true;
  p.max_edge = kMaxEdge;
  auto out = perturbModel(sat, p);
  ASSERT_OK(out.status());
  ASSERT_OK(out->validate());
  // The same surface: area and enclosed volume within float rounding, no T-junction (the
  // boundary of the welded mesh has the same length), the same bounding box.
  EXPECT_NEAR(out->surfaceArea() / sat.surfaceArea(), 1.0, 1e-6);
  EXPECT_NEAR(signedVolume(*out) / signedVolume(sat), 1.0, 1e-6);
  EXPECT_NEAR(boundaryLength(*out), boundaryLength(sat), 1e-4 * boundaryLength(sat));
  EXPECT_LT((out->bounds().sizes() - sat.bounds().sizes()).norm(), 1e-6);
  // Other triangles: every edge now at most max_edge, most of the old triangles gone.
  for (const auto& t : out->mesh.triangles)
    for (int k = 0; k < 3; ++k)
      EXPECT_LE((out->mesh.vertices[t[k]] - out->mesh.vertices[t[(k + 1) % 3]]).norm(),
                kMaxEdge * (1 + 1e-6));
  const std::set<Triple> before = trianglePositions(sat), after = trianglePositions(*out);
  std::size_t kept = 0;
  for (const Triple& t : before) kept += after.count(t);
  EXPECT_LT(kept, before.size() / 2) << kept << " of " << before.size() << " triangles kept";
  EXPECT_GT(out->mesh.triangles.size(), 2 * sat.mesh.triangles.size());
  // Materials and parts follow: the same area per part.
  for (const std::string& part : sat.parts)
    EXPECT_NEAR(partArea(*out, part) / partArea(sat, part), 1.0, 1e-5) << part;
}

TEST(ModelErrors, FlippedDiagonalsKeepTheVerticesAndChangeMostTriangles) {
  const TargetModel sat = satellite();
  const TargetModel out = flipDiagonals(sat);
  ASSERT_OK(out.validate());
  EXPECT_EQ(out.mesh.vertices.size(), sat.mesh.vertices.size());
  EXPECT_EQ(out.mesh.triangles.size(), sat.mesh.triangles.size());
  EXPECT_NEAR(out.surfaceArea() / sat.surfaceArea(), 1.0, 1e-6);
  EXPECT_NEAR(signedVolume(out) / signedVolume(sat), 1.0, 1e-6);
  EXPECT_NEAR(boundaryLength(out), boundaryLength(sat), 1e-4 * boundaryLength(sat));
  const std::set<Triple> before = trianglePositions(sat), after = trianglePositions(out);
  std::size_t kept = 0;
  for (const Triple& t : before) kept += after.count(t);
  EXPECT_LT(kept, before.size() / 4) << kept << " of " << before.size() << " triangles kept";
  // Every triangle still faces out: its normal agrees with its vertices' normals.
  for (const auto& t : out.mesh.triangles) {
    const Eigen::Vector3f n = (out.mesh.vertices[t[1]] - out.mesh.vertices[t[0]])
                                  .cross(out.mesh.vertices[t[2]] - out.mesh.vertices[t[0]]);
    if (n.norm() > 1e-8f) {
      EXPECT_GT(n.dot(out.mesh.vertex_normals[t[0]]), 0.0f);
    }
  }
}

TEST(ModelErrors, ThePerturbedModelExportsInEveryFormat) {
  ModelPerturbation p;
  p.scale_error = Eigen::Vector3d::Constant(0.01);
  p.remove_parts = {"antenna"};
  p.add_boxes = {{"payload", {0.3, 0.0, 0.6}, {0.1, 0.1, 0.1}}};
  p.flip_diagonals = true;
  p.max_edge = 0.25;
  auto out = perturbModel(satellite(), p);
  ASSERT_OK(out.status());
  const auto dir =
      std::filesystem::temp_directory_path() / ("cdff_perturbed_" + std::to_string(::getpid()));
  auto files = exportModel(*out, dir, "target", 1000);
  ASSERT_OK(files.status());
  auto loaded = loadModel(files->ply);
  ASSERT_OK(loaded.status());
  EXPECT_EQ(loaded->parts, out->parts);
  EXPECT_NEAR(loaded->surfaceArea(), out->surfaceArea(), 1e-6 * out->surfaceArea());
  auto edges = readEdges(files->edges);
  ASSERT_OK(edges.status());
  EXPECT_FALSE(edges->empty());
  EXPECT_TRUE(std::filesystem::file_size(files->cao) > 0);
  std::filesystem::remove_all(dir);
}

TEST(ModelErrors, BadRequestsAreRefusedWithTheValue) {
  const TargetModel sat = satellite();
  auto refused = [&](const ModelPerturbation& p, const std::string& fragment) {
    auto out = perturbModel(sat, p);
    ASSERT_FALSE(out.isOk()) << fragment;
    EXPECT_NE(out.status().message().find(fragment), std::string::npos) << out.status().message();
  };
  ModelPerturbation p;
  p.remove_parts = {"dish"};
  refused(p, "has no part 'dish'; expected one of: bus, wing_right, wing_left");
  p = {};
  p.scale_error = {std::nan(""), 0, 0};
  refused(p, "scale error along x = nan");
  p = {};
  p.scale_error = {0, -0.7, 0};
  refused(p, "scale error along y = -0.7");
  p = {};
  p.add_boxes = {{"payload", {0, 0, 1}, {0.1, -0.1, 0.1}}};
  refused(p, "box 'payload' half extent along y = -0.1");
  p = {};
  p.add_boxes = {{"antenna", {0, 0, 1}, {0.1, 0.1, 0.1}}};
  refused(p, "already has a part 'antenna'");
  p = {};
  p.max_edge = -0.1;
  refused(p, "max_edge = -0.1");
  p = {};
  p.remove_parts = {"bus",       "wing_left", "wing_right", "adapter_ring", "launcher_brackets",
                    "thrusters", "antenna"};
  refused(p, "leaves nothing");
  // A mesh without named parts.
  TargetModel plain = sat;
  plain.parts.clear();
  plain.triangle_part.clear();
  p = {};
  p.remove_parts = {"antenna"};
  auto out = perturbModel(plain, p);
  ASSERT_FALSE(out.isOk());
  EXPECT_NE(out.status().message().find("has no named parts"), std::string::npos);
}

}  // namespace
}  // namespace cdff::egse
