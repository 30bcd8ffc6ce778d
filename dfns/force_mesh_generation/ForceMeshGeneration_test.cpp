// ForceMeshGeneration/TangentDelaunay on synthetic truth: contacts drawn on a known plane, sphere
// cap and box edge, with the errors the contact goals allow (point within 1 mm, normal within 3
// deg); the mesh must lie within the mesh goal (2 mm) of the true surface and cover the touched
// area within it (Hausdorff both ways), face outwards and never join two faces of an edge. Bad
// contacts are faults that leave the outputs as they were.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "ForceMeshGeneration.gen.hpp"
#include "cdff/types/codec/codec.hpp"
#include "support/dfn_testing.hpp"
#include "support/mesh_distance.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kPointError = 1e-3;       // m, the contact goal's bound
constexpr double kNormalError = 3 * kDeg;  // the contact goal's bound
constexpr double kMeshGoal = 2e-3;         // m, Hausdorff to the true surface

/// The DFI with its normal tolerance at the test contacts' normal error.
std::unique_ptr<ForceMeshGeneration> make(const std::string& yaml = "{normal_tolerance: 3}") {
  return testing::makeDfn<ForceMeshGeneration>("ForceMeshGeneration", "TangentDelaunay", yaml);
}

struct Truth {
  std::vector<Eigen::Vector3d> points, normals;
};

/// Contacts at the true points, each moved by up to kPointError and its normal turned by up to
/// kNormalError (uniform in the ball and the cone), with forces of 5-15 N, in frame "target".
PointCloud contactsFrom(const Truth& truth, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  auto in_ball = [&] {
    Eigen::Vector3d v;
    do v = {u(rng), u(rng), u(rng)};
    while (v.norm() > 1);
    return v;
  };
  std::vector<Eigen::Vector3f> xyz;
  std::vector<Point4f> normals;
  std::vector<float> forces;
  for (std::size_t i = 0; i < truth.points.size(); ++i) {
    xyz.push_back((truth.points[i] + kPointError * in_ball()).cast<float>());
    const Eigen::Vector3d axis = truth.normals[i].cross(in_ball()).normalized();
    const Eigen::Vector3f n =
        (Eigen::AngleAxisd(kNormalError * std::abs(u(rng)), axis) * truth.normals[i])
            .normalized()
            .cast<float>();
    normals.emplace_back(n.x(), n.y(), n.z());
    forces.push_back(static_cast<float>(10 + 5 * u(rng)));
  }
  PointCloud cloud = PointCloud::fromXyz(xyz, "target", 1'000'000);
  cloud.normals = Buffer<Point4f>::fromVector(std::move(normals));
  cloud.intensity = Buffer<float>::fromVector(std::move(forces));
  return cloud;
}

using SurfaceDistance = std::function<double(const Eigen::Vector3d&)>;

/// Hausdorff over the touched area: the farthest of 4000 points sampled on the mesh from the true
/// surface, and of the true surface's points in the touched area (`inner`) from the mesh.
double hausdorff(const TriangleMesh& mesh, const SurfaceDistance& to_surface,
                 const std::vector<Eigen::Vector3d>& inner) {
  Result<PointCloud> samples = sampleSurface(mesh, 4000, 7, SampleNormals::kFace);
  EXPECT_TRUE(samples.isOk()) << samples.status().toString();
  double worst = 0;
  for (std::size_t i = 0; samples.isOk() && i < samples->size(); ++i)
    worst = std::max(worst, to_surface(samples->points[i].vec().cast<double>()));
  double covered = 0;
  for (const Eigen::Vector3d& p : inner)
    covered = std::max(covered, testing::distanceToMesh(mesh, p));
  std::printf("mesh to surface %.3f mm, touched area to mesh %.3f mm\n", worst * 1e3,
              covered * 1e3);
  return std::max(worst, covered);
}

/// Every triangle faces along the true normal at its centroid, as far as the contacts' errors
/// allow: a sliver whose height is within the points' errors (1 mm each way) may stand on edge
/// and tip over, so its area projected on the true normal may be negative by up to
/// 2 kPointError times its longest edge.
void expectFacingOut(const TriangleMesh& mesh,
                     const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& normal_at) {
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>(),
                          b = mesh.vertices[t[1]].cast<double>(),
                          c = mesh.vertices[t[2]].cast<double>();
    const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    // (b - a) x (c - a) is twice the area: the projected area >= -kPointError * longest.
    EXPECT_GT((b - a).cross(c - a).dot(normal_at((a + b + c) / 3)), -2 * kPointError * longest);
  }
}

/// A point uniform in the disc of radius r about `centre` in the plane across `normal`.
Eigen::Vector3d inDisc(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal, double r,
                       std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  const Eigen::Vector3d e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
  const double rho = r * std::sqrt(u(rng)), phi = 2 * M_PI * u(rng);
  return centre + rho * (std::cos(phi) * e1 + std::sin(phi) * e2);
}

TEST(ForceMeshGenerationTangentDelaunay, PlanePatchWithinTheGoalAndCovered) {
  // 100 contacts over a disc of 5 cm on a tilted face: a spacing of about 9 mm.
  std::mt19937 rng(11);
  const Eigen::Vector3d normal = Eigen::Vector3d(1, 0.3, -0.2).normalized();
  const Eigen::Vector3d centre(0.6, 0.1, 0.2);
  const double radius = 0.05;
  Truth truth;
  for (int i = 0; i < 100; ++i) {
    truth.points.push_back(inDisc(centre, normal, radius, rng));
    truth.normals.push_back(normal);
  }
  auto dfn = make();
  dfn->in.contacts.set(contactsFrom(truth, rng));
  ASSERT_OK(dfn->process());
  ASSERT_TRUE(dfn->out.mesh.hasValue());
  const TriangleMesh& mesh = *dfn->out.mesh;
  EXPECT_OK(mesh.validate());
  EXPECT_EQ(mesh.frame_id, "target");
  EXPECT_EQ(mesh.stamp, 1'000'000);
  EXPECT_EQ(mesh.vertexCount(), 100u);
  EXPECT_EQ(*dfn->out.triangles, static_cast<int>(mesh.triangleCount()));
  // A Delaunay triangulation of n points has about 2n triangles less the hull's: at least n.
  EXPECT_GE(mesh.triangleCount(), 100u);
  // The touched area: the disc less a spacing and a half at its rim (the hull of random points
  // falls short of the disc by about one spacing).
  std::vector<Eigen::Vector3d> inner;
  for (int i = 0; i < 400; ++i) inner.push_back(inDisc(centre, normal, radius - 0.02, rng));
  const double h = hausdorff(
      mesh, [&](const Eigen::Vector3d& p) { return std::abs(normal.dot(p - centre)); }, inner);
  std::printf("plane: %zu triangles, Hausdorff %.3f mm\n", mesh.triangleCount(), h * 1e3);
  EXPECT_LE(h, kMeshGoal);
  expectFacingOut(mesh, [&](const Eigen::Vector3d&) { return normal; });
  // The forces: the contacts', per vertex.
  ASSERT_TRUE(dfn->out.forces.hasValue());
  EXPECT_EQ(dfn->out.forces->intensity.data(), dfn->in.contacts->intensity.data());
  // PLY export (the Data Product Manager's files): the mesh with its vertex normals, the forces
  // as the cloud's intensity, vertex for vertex.
  codec::ProductRecord mesh_ply, forces_ply;
  ASSERT_OK(codec::toPly(mesh, mesh_ply));
  ASSERT_OK(codec::toPly(*dfn->out.forces, forces_ply));
  TriangleMesh mesh_back;
  PointCloud forces_back;
  ASSERT_OK(codec::fromPly(mesh_ply, mesh_back));
  ASSERT_OK(codec::fromPly(forces_ply, forces_back));
  ASSERT_EQ(mesh_back.triangleCount(), mesh.triangleCount());
  ASSERT_EQ(mesh_back.vertex_normals.size(), mesh.vertexCount());
  ASSERT_EQ(forces_back.intensity.size(), mesh.vertexCount());
  for (std::size_t i = 0; i < mesh.vertexCount(); ++i) {
    EXPECT_EQ(mesh_back.vertices[i], forces_back.points[i].vec()) << i;
    EXPECT_EQ(forces_back.intensity[i], dfn->in.contacts->intensity[i]) << i;
  }
}

TEST(ForceMeshGenerationTangentDelaunay, SphereCapWithinTheGoalAndCovered) {
  // A sphere of 0.3 m (a tank's curvature), 120 contacts over a cap of 12 deg (6.3 cm).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  const Eigen::Vector3d centre(0.2, -0.1, 0.4), pole = Eigen::Vector3d(-1, 0.2, 0.5).normalized();
  const double radius = 0.3;
  auto on_cap = [&](double max_angle) {
    const double cos_a = 1 - u(rng) * (1 - std::cos(max_angle)), phi = 2 * M_PI * u(rng);
    const Eigen::Vector3d e1 = pole.unitOrthogonal(), e2 = pole.cross(e1);
    const double sin_a = std::sqrt(1 - cos_a * cos_a);
    return Eigen::Vector3d(cos_a * pole + sin_a * (std::cos(phi) * e1 + std::sin(phi) * e2));
  };
  Truth truth;
  for (int i = 0; i < 120; ++i) {
    const Eigen::Vector3d n = on_cap(12 * kDeg);
    truth.points.push_back(centre + radius * n);
    truth.normals.push_back(n);
  }
  auto dfn = make();
  dfn->in.contacts.set(contactsFrom(truth, rng));
  ASSERT_OK(dfn->process());
  ASSERT_TRUE(dfn->out.mesh.hasValue());
  const TriangleMesh& mesh = *dfn->out.mesh;
  EXPECT_GE(mesh.triangleCount(), 120u);
  std::vector<Eigen::Vector3d> inner;
  for (int i = 0; i < 400; ++i) inner.push_back(centre + radius * on_cap(8 * kDeg));
  const double h = hausdorff(
      mesh, [&](const Eigen::Vector3d& p) { return std::abs((p - centre).norm() - radius); },
      inner);
  std::printf("sphere: %zu triangles, Hausdorff %.3f mm\n", mesh.triangleCount(), h * 1e3);
  EXPECT_LE(h, kMeshGoal);
  expectFacingOut(mesh, [&](const Eigen::Vector3d& p) { return (p - centre).normalized(); });
}

TEST(ForceMeshGenerationTangentDelaunay, NeverJoinsTwoFacesOfAnEdge) {
  // Contacts on the two faces of a box's edge (x = 0.3 and y = 0.2), as close as 2 mm to it: no
  // triangle may cut the corner.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  Truth truth;
  for (int i = 0; i < 30; ++i) {
    const double z = 0.06 * u(rng), off = 0.002 + 0.04 * u(rng);
    truth.points.push_back(i % 2 ? Eigen::Vector3d(0.3, 0.2 - off, z)
                                 : Eigen::Vector3d(0.3 - off, 0.2, z));
    truth.normals.push_back(i % 2 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY());
  }
  auto dfn = make();
  dfn->in.contacts.set(contactsFrom(truth, rng));
  ASSERT_OK(dfn->process());
  ASSERT_TRUE(dfn->out.mesh.hasValue());
  const TriangleMesh& mesh = *dfn->out.mesh;
  for (const auto& t : mesh.triangles)
    EXPECT_TRUE(t[0] % 2 == t[1] % 2 && t[1] % 2 == t[2] % 2)
        << "a triangle joins both faces: " << t[0] << " " << t[1] << " " << t[2];
  const double h = hausdorff(mesh,
                             [](const Eigen::Vector3d& p) {
                               return std::min(std::abs(p.x() - 0.3), std::abs(p.y() - 0.2));
                             },
                             {});
  EXPECT_LE(h, kMeshGoal);
}

TEST(ForceMeshGenerationTangentDelaunay, NoMeshUntilThreeContactsJoin) {
  Truth truth{{{0, 0, 0}, {0.01, 0, 0}}, {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ()}};
  std::mt19937 rng(1);
  auto dfn = make();
  dfn->in.contacts.set(contactsFrom(truth, rng));
  ASSERT_OK(dfn->process());
  EXPECT_EQ(*dfn->out.triangles, 0);
  EXPECT_FALSE(dfn->out.mesh.hasValue());
  // Three contacts farther apart than max_edge_length: no triangle either.
  truth.points.push_back({0.2, 0.2, 0});
  truth.normals.push_back(Eigen::Vector3d::UnitZ());
  truth.points[1] = {0.2, 0, 0};
  dfn->in.contacts.set(contactsFrom(truth, rng));
  ASSERT_OK(dfn->process());
  EXPECT_EQ(*dfn->out.triangles, 0);
  EXPECT_FALSE(dfn->out.mesh.hasValue());
}

PointCloud threeContacts() {
  Truth truth{{{0, 0, 0}, {0.01, 0, 0}, {0, 0.01, 0}},
              {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ()}};
  std::mt19937 rng(2);
  return contactsFrom(truth, rng);
}

TEST(ForceMeshGenerationTangentDelaunay, BadContactsAreFaults) {
  auto dfn = make();
  dfn->in.contacts.set(threeContacts());
  ASSERT_OK(dfn->process());  // outputs set: a rejected call must leave them
  PointCloud c = threeContacts();
  c.normals = {};
  dfn->in.contacts.set(c);
  testing::expectRejected(*dfn, "has no normals; expected each contact's normal");
  c = threeContacts();
  c.intensity = {};
  dfn->in.contacts.set(c);
  testing::expectRejected(*dfn, "has no intensity");
  c = threeContacts();
  std::vector<Point4f> normals(c.normals.begin(), c.normals.end());
  normals[1] = Point4f(0, 0, 2);
  c.normals = Buffer<Point4f>::fromVector(std::move(normals));
  dfn->in.contacts.set(c);
  testing::expectRejected(*dfn, "point 1 at 1000000 us has a normal of norm 2");
  c = threeContacts();
  c.intensity = Buffer<float>::copyOf(std::vector<float>{5, -1, 5});
  dfn->in.contacts.set(c);
  testing::expectRejected(*dfn, "point 1 at 1000000 us has a normal force (intensity) of -1 N");
  c = threeContacts();
  std::vector<Point4f> points(c.points.begin(), c.points.end());
  points[2].y = std::numeric_limits<float>::quiet_NaN();
  c.points = Buffer<Point4f>::fromVector(std::move(points));
  dfn->in.contacts.set(c);
  testing::expectRejected(*dfn, "input 'contacts'");
}

TEST(ForceMeshGenerationTangentDelaunay, BadParametersAreRefused) {
  auto node =
      Registry::instance().createAs<ForceMeshGeneration>("ForceMeshGeneration", "TangentDelaunay");
  ASSERT_OK(node.status());
  const Status s = (*node)->configure(YAML::Load("{max_neighbours: 2}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter) << s.toString();
  EXPECT_NE(s.message().find("max_neighbours"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace cdff::dfn
