// The near-symmetries that PoseRefinement starts every candidate at (registration::
// nearSymmetries), on shapes whose symmetries are known: a box, a hexagonal prism whose axis is
// off the model's centroid (a one-sided appendage), and the two procedural targets.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>

#include <fmt/format.h>

#include "cdff/egse/procedural.hpp"
#include "cdff/registration/model_symmetry.hpp"
#include "cdff/types/mesh.hpp"

namespace cdff {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

/// Triangles being built: vertices and counter-clockwise (seen from outside) triangles.
struct Shape {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;

  /// A prism of `sides` sides (a square box for 4) along x, `length` long and `across` between
  /// opposite corners, centred on `centre`.
  void addPrism(int sides, double length, double across, const Eigen::Vector3d& centre) {
    const auto base = static_cast<std::uint32_t>(vertices.size());
    for (int end = 0; end < 2; ++end)
      for (int k = 0; k < sides; ++k) {
        const double a = 2 * M_PI * (k + 0.5) / sides;
        vertices.push_back((centre + Eigen::Vector3d((end - 0.5) * length, across / 2 * std::cos(a),
                                                     across / 2 * std::sin(a)))
                               .cast<float>());
      }
    for (int end = 0; end < 2; ++end) {
      const auto c = static_cast<std::uint32_t>(vertices.size());
      vertices.push_back((centre + Eigen::Vector3d((end - 0.5) * length, 0, 0)).cast<float>());
      for (int k = 0; k < sides; ++k) {
        const std::uint32_t a = base + end * sides + k, b = base + end * sides + (k + 1) % sides;
        triangles.push_back(end == 0 ? std::array<std::uint32_t, 3>{c, b, a}
                                     : std::array<std::uint32_t, 3>{c, a, b});
      }
    }
    for (int k = 0; k < sides; ++k) {
      const std::uint32_t a0 = base + k, b0 = base + (k + 1) % sides;
      const std::uint32_t a1 = a0 + sides, b1 = b0 + sides;
      triangles.push_back({a0, b0, b1});
      triangles.push_back({a0, b1, a1});
    }
  }

  TriangleMesh mesh() {
    TriangleMesh m;
    m.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
    m.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
    return m;
  }
};

std::vector<registration::NearSymmetry> symmetriesOf(const TriangleMesh& mesh, double spacing) {
  const auto points = static_cast<std::size_t>(mesh.surfaceArea() / (spacing * spacing));
  Result<PointCloud> cloud = sampleSurface(mesh, points, 5);
  EXPECT_TRUE(cloud.isOk()) << cloud.status().toString();
  registration::ModelIndex index;
  EXPECT_TRUE(index.update(*cloud).isOk());
  std::vector<registration::NearSymmetry> found = registration::nearSymmetries(index);
  for (const registration::NearSymmetry& s : found) {
    const Eigen::AngleAxisd r(s.motion.linear());
    std::cout << fmt::format(
        "  {:6.1f} deg about ({:+.2f} {:+.2f} {:+.2f}), t ({:+.2f} {:+.2f} "
        "{:+.2f}), overlap {:.2f}\n",
        r.angle() / kDeg, r.axis().x(), r.axis().y(), r.axis().z(), s.motion.translation().x(),
        s.motion.translation().y(), s.motion.translation().z(), s.overlap);
  }
  return found;
}

/// Whether `found` holds the turn by `angle` about the line through `point` along `axis`, within
/// 2 degrees and `tolerance` at `probe`.
bool holds(const std::vector<registration::NearSymmetry>& found, const Eigen::Vector3d& axis,
           const Eigen::Vector3d& point, double angle, const Eigen::Vector3d& probe,
           double tolerance) {
  Eigen::Isometry3d expected = Eigen::Isometry3d::Identity();
  expected.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  expected.translation() = point - expected.linear() * point;
  return std::any_of(found.begin(), found.end(), [&](const registration::NearSymmetry& s) {
    const Eigen::Isometry3d d = expected.inverse() * s.motion;
    return Eigen::AngleAxisd(d.linear()).angle() < 2 * kDeg &&
           (s.motion * probe - expected * probe).norm() < tolerance;
  });
}

TEST(NearSymmetries, OfASquarePrismAreItsTurns) {
  const Eigen::Vector3d c(0.3, -0.2, 0.1);
  Shape shape;
  shape.addPrism(4, 1.6, 1.2, c);
  const auto found = symmetriesOf(shape.mesh(), 0.02);
  // A 1.6 x 0.85 x 0.85 m box: the half turns about its three axes and about the square's
  // diagonals, the quarter turns about its long axis; nothing else.
  EXPECT_TRUE(holds(found, Eigen::Vector3d::UnitX(), c, M_PI, c, 0.02));
  EXPECT_TRUE(holds(found, Eigen::Vector3d::UnitY(), c, M_PI, c, 0.02));
  EXPECT_TRUE(holds(found, Eigen::Vector3d::UnitZ(), c, M_PI, c, 0.02));
  EXPECT_TRUE(holds(found, Eigen::Vector3d::UnitX(), c, M_PI / 2, c, 0.02));
  EXPECT_TRUE(holds(found, Eigen::Vector3d::UnitX(), c, -M_PI / 2, c, 0.02));
  EXPECT_TRUE(holds(found, Eigen::Vector3d(0, 1, 1), c, M_PI, c, 0.02));
  EXPECT_TRUE(holds(found, Eigen::Vector3d(0, 1, -1), c, M_PI, c, 0.02));
  EXPECT_EQ(found.size(), 7u);
  for (const auto& s : found) EXPECT_GT(s.overlap, 0.9);
}

TEST(NearSymmetries, OfAHexagonalBusWithAPlateOnOneSideAreTheTurnsAboutTheBusAxis) {
  // A hexagonal prism along x (its axis through the origin) with a square plate on its +y side,
  // 28 % of the surface, which moves the centroid half a metre off the axis.
  Shape shape;
  shape.addPrism(6, 1.4, 1.6, Eigen::Vector3d::Zero());
  Shape plate;
  plate.addPrism(4, 0.03, 2.0, Eigen::Vector3d(0, 1.75, 0));
  const auto offset = static_cast<std::uint32_t>(shape.vertices.size());
  shape.vertices.insert(shape.vertices.end(), plate.vertices.begin(), plate.vertices.end());
  for (const auto& t : plate.triangles)
    shape.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  const auto found = symmetriesOf(shape.mesh(), 0.02);
  const Eigen::Vector3d probe(0, 0.8, 0);
  for (int k = 1; k < 6; ++k)
    EXPECT_TRUE(
        holds(found, Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero(), k * M_PI / 3, probe, 0.03))
        << k * 60 << " deg about the bus axis";
  // The half turn about the plate's axis (y) maps the plate too.
  EXPECT_TRUE(holds(found, Eigen::Vector3d::UnitY(), Eigen::Vector3d::Zero(), M_PI, probe, 0.03));
}

TEST(NearSymmetries, OfTheBoxSatelliteAreItsThreeHalfTurns) {
  // Two wings along y, the adapter ring on -x, antenna and thrusters: the half turns about the
  // three axes through the bus centre map nine tenths of it onto itself, nothing else half.
  // The same from a model sampled 2 and 5 cm apart.
  for (double spacing : {0.02, 0.05}) {
    const auto found = symmetriesOf(egse::makeTargetSatellite().value().mesh, spacing);
    const Eigen::Vector3d centre = Eigen::Vector3d::Zero(), probe(0.6, 0.5, 0.5);
    for (int axis = 0; axis < 3; ++axis)
      EXPECT_TRUE(holds(found, Eigen::Vector3d::Unit(axis), centre, M_PI, probe, 0.03)) << axis;
    EXPECT_EQ(found.size(), 3u) << spacing;
    for (const auto& s : found) EXPECT_GT(s.overlap, 0.85);
  }
}

TEST(NearSymmetries, OfTheHexagonalSatelliteAreItsBusTurns) {
  // Its wing (+y) is a third of the surface: the turns by 60 degrees about the bus axis (x) and
  // the half turns across it map the bus, three fifths of the surface; the half turn about the
  // wing's axis maps nearly all of it.
  for (double spacing : {0.02, 0.05}) {
    const auto found = symmetriesOf(egse::makeHexagonalSatellite().value().mesh, spacing);
    const Eigen::Vector3d origin = Eigen::Vector3d::Zero(), probe(0.7, 0.8, 0);
    for (int k = 1; k < 6; ++k)
      EXPECT_TRUE(holds(found, Eigen::Vector3d::UnitX(), origin, k * M_PI / 3, probe, 0.03)) << k;
    for (int k = 0; k < 6; ++k)
      EXPECT_TRUE(holds(found, Eigen::Vector3d(0, std::cos(k * M_PI / 6), std::sin(k * M_PI / 6)),
                        origin, M_PI, probe, 0.03))
          << k * 30 << " deg from y";
    // Nothing else: a plate turned a little about its normal stays on its plane, which is no
    // symmetry.
    EXPECT_EQ(found.size(), 11u) << spacing;
  }
}

}  // namespace
}  // namespace cdff
