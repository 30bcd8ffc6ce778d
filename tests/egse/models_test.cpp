// Procedural models, sampling, edges, exports, and the simulator's random numbers.
#include <cmath>
#include <filesystem>
#include <map>
#include <numeric>

#include <gtest/gtest.h>

#include "cdff/egse/model_io.hpp"
#include "cdff/egse/procedural.hpp"
#include "cdff/egse/rng.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

std::filesystem::path tempDir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() /
             ("cdff_egse_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(Rng, SameSeedSameNumbersAndStreamsAreIndependent) {
  Rng a(42), b(42);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(a.next(), b.next());
  // The standard fixes mt19937_64's output: its 10000th value from the default seed.
  Rng standard(5489u);
  std::uint64_t v = 0;
  for (int i = 0; i < 10000; ++i) v = standard.next();
  EXPECT_EQ(v, 9981545732273789042ULL);
  Rng s1 = Rng::stream(1, "camera_left", 0), s2 = Rng::stream(1, "camera_right", 0);
  Rng s3 = Rng::stream(1, "camera_left", 1), s4 = Rng::stream(1, "camera_left", 0);
  const std::uint64_t x1 = s1.next(), x2 = s2.next(), x3 = s3.next(), x4 = s4.next();
  EXPECT_NE(x1, x2);
  EXPECT_NE(x1, x3);
  EXPECT_EQ(x1, x4);
}

TEST(Rng, NormalHasTheMomentsAndTailsOfAStandardNormal) {
  Rng rng(7);
  const int n = 400000;
  double sum = 0, sum2 = 0, sum4 = 0;
  int beyond3 = 0, beyond1 = 0;
  for (int i = 0; i < n; ++i) {
    const double x = rng.normal();
    sum += x;
    sum2 += x * x;
    sum4 += x * x * x * x;
    beyond3 += std::abs(x) > 3.0;
    beyond1 += std::abs(x) > 1.0;
  }
  const double mean = sum / n, var = sum2 / n - mean * mean;
  EXPECT_NEAR(mean, 0.0, 5.0 / std::sqrt(n));
  EXPECT_NEAR(var, 1.0, 5.0 * std::sqrt(2.0 / n));
  EXPECT_NEAR(sum4 / n, 3.0, 0.05);  // kurtosis of a normal
  EXPECT_NEAR(static_cast<double>(beyond1) / n, 0.3173, 0.004);
  EXPECT_NEAR(static_cast<double>(beyond3) / n, 0.0027, 0.0004);
}

TEST(Rng, UniformBelowAndPoisson) {
  Rng rng(3);
  std::vector<int> counts(7, 0);
  const int n = 70000;
  for (int i = 0; i < n; ++i) counts[rng.below(7)]++;
  for (int c : counts) EXPECT_NEAR(c, n / 7.0, 5 * std::sqrt(n / 7.0));
  for (double lambda : {3.5, 80.0}) {
    double sum = 0, sum2 = 0;
    for (int i = 0; i < 50000; ++i) {
      const double k = static_cast<double>(rng.poisson(lambda));
      sum += k;
      sum2 += k * k;
    }
    const double mean = sum / 50000, var = sum2 / 50000 - mean * mean;
    EXPECT_NEAR(mean, lambda, 0.05 * lambda);
    EXPECT_NEAR(var, lambda, 0.08 * lambda);
  }
}

TEST(ProceduralTarget, HasTheSeedsPartsWithTheConfiguredSizes) {
  TargetSpec spec;
  auto model = makeTargetSatellite(spec);
  ASSERT_OK(model.status());
  ASSERT_OK(model->validate());
  std::map<std::string, double> area_by_material;
  for (std::size_t t = 0; t < model->mesh.triangles.size(); ++t) {
    const auto& tri = model->mesh.triangles[t];
    const Eigen::Vector3d a = model->mesh.vertices[tri[0]].cast<double>();
    const double area = 0.5 * (model->mesh.vertices[tri[1]].cast<double>() - a)
                                  .cross(model->mesh.vertices[tri[2]].cast<double>() - a)
                                  .norm();
    area_by_material[model->triangleMaterial(t).name] += area;
  }
  // Solar cells: 2 wings x 2 panels of 1.0 x 0.8 m.
  EXPECT_NEAR(area_by_material["solar_cell"], 4 * 1.0 * 0.8, 1e-4);
  EXPECT_GT(area_by_material["mli_gold"], 2.0);
  EXPECT_GT(area_by_material["adapter_ring"], 0.1);
  EXPECT_GT(area_by_material["radiator"], 1.9);
  EXPECT_GT(area_by_material["antenna"], 0.2);
  EXPECT_GT(area_by_material["thruster"], 0.0);
  // Extents: wings along y, the ring and thrusters beyond the -x face, the dish above +z.
  const Eigen::AlignedBox3d box = model->bounds();
  const double wing_tip = 0.5 + 0.35 + 0.03 + 2 * 1.0 + 0.03;
  EXPECT_NEAR(box.max().y(), wing_tip, 1e-5);
  EXPECT_NEAR(box.min().y(), -wing_tip, 1e-5);
  EXPECT_NEAR(box.min().x(), -0.6 - 0.12, 1e-5);
  EXPECT_NEAR(box.max().z(), 0.5 + 0.25 + 0.09, 1e-5);
}

TEST(ProceduralTarget, PolygonsArePlanarAndCounterClockwiseSeenFromOutside) {
  auto model = makeTargetSatellite();
  ASSERT_OK(model.status());
  ASSERT_FALSE(model->polygons.empty());
  for (std::size_t p = 0; p < model->polygons.size(); ++p) {
    const auto& poly = model->polygons[p];
    const auto& V = model->mesh.vertices;
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < poly.vertices.size(); ++i) {
      const Eigen::Vector3d a = V[poly.vertices[i]].cast<double>();
      const Eigen::Vector3d b = V[poly.vertices[(i + 1) % poly.vertices.size()]].cast<double>();
      n += a.cross(b);
    }
    ASSERT_GT(n.norm(), 0.0) << "polygon " << p;
    n.normalize();
    const Eigen::Vector3d o = V[poly.vertices[0]].cast<double>();
    for (std::uint32_t v : poly.vertices) {
      EXPECT_LT(std::abs((V[v].cast<double>() - o).dot(n)), 1e-5)
          << "polygon " << p << " is not planar";
      // The shading normal is on the same side as the polygon's right-hand normal.
      EXPECT_GT(model->mesh.vertex_normals[v].cast<double>().dot(n), 0.0) << "polygon " << p;
    }
  }
  // The bus faces (the first six polygons) point away from the bus centre.
  for (int f = 0; f < 6; ++f) {
    const auto& poly = model->polygons[f];
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (std::uint32_t v : poly.vertices) centroid += model->mesh.vertices[v].cast<double>();
    centroid /= static_cast<double>(poly.vertices.size());
    EXPECT_GT(model->mesh.vertex_normals[poly.vertices[0]].cast<double>().dot(centroid), 0.0);
  }
}

TEST(ProceduralTarget, RejectsBadSpecificationsNamingTheKey) {
  TargetSpec spec;
  spec.bus_size.y() = -1;
  auto model = makeTargetSatellite(spec);
  ASSERT_FALSE(model.isOk());
  EXPECT_NE(model.status().message().find("bus_size[1]"), std::string::npos)
      << model.status().message();
  spec = TargetSpec{};
  spec.ring_diameter = 3.0;
  model = makeTargetSatellite(spec);
  ASSERT_FALSE(model.isOk());
  EXPECT_NE(model.status().message().find("ring_diameter"), std::string::npos);
  spec = TargetSpec{};
  spec.segments = 3;
  EXPECT_FALSE(makeTargetSatellite(spec).isOk());
}

TEST(ProceduralTarget, ServicerMockupIsValid) {
  auto servicer = makeServicerMockup();
  ASSERT_OK(servicer.status());
  EXPECT_EQ(servicer->mesh.frame_id, "servicer");
  EXPECT_NEAR(servicer->bounds().max().x(), 0.4 + 0.5, 1e-5);
  ServicerSpec bad;
  bad.probe_length = -1;
  EXPECT_FALSE(makeServicerMockup(bad).isOk());
}

double pointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  // Closest point by projection onto the plane, then onto the edges if outside.
  const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
  const Eigen::Vector3d q = p - n * (p - a).dot(n);
  auto inside = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
    return (y - x).cross(q - x).dot(n) >= -1e-12;
  };
  if (inside(a, b) && inside(b, c) && inside(c, a)) return (p - q).norm();
  auto segment = [&](const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
    const double t = std::clamp((p - x).dot(y - x) / (y - x).squaredNorm(), 0.0, 1.0);
    return (p - (x + t * (y - x))).norm();
  };
  return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

TEST(ModelSampling, PointsLieOnTheSurfaceUniformlyByArea) {
  auto model = makeTargetSatellite();
  ASSERT_OK(model.status());
  const std::size_t n = 60000;
  const PointCloud cloud = samplePointCloud(*model, n, 5);
  ASSERT_EQ(cloud.size(), n);
  ASSERT_TRUE(cloud.hasNormals());
  // A subset against every triangle (brute force): on the surface within float precision.
  const auto& V = model->mesh.vertices;
  for (std::size_t i = 0; i < n; i += 600) {
    const Eigen::Vector3d p = cloud.points[i].vec().cast<double>();
    double best = 1e9;
    for (const auto& t : model->mesh.triangles)
      best = std::min(best, pointTriangleDistance(p, V[t[0]].cast<double>(), V[t[1]].cast<double>(),
                                                  V[t[2]].cast<double>()));
    EXPECT_LT(best, 1e-5) << "point " << i;
  }
  // The fraction of points on solar cells matches their share of the area (binomial 5 sigma).
  double cell_area = 0;
  for (std::size_t t = 0; t < model->mesh.triangles.size(); ++t) {
    if (model->triangleMaterial(t).name != "solar_cell") continue;
    const auto& tri = model->mesh.triangles[t];
    cell_area += 0.5 * (V[tri[1]] - V[tri[0]]).cross(V[tri[2]] - V[tri[0]]).norm();
  }
  const double share = cell_area / model->surfaceArea();
  const float cell_reflectivity = builtinMaterial(MaterialId::kSolarCell).lidar_reflectivity;
  std::size_t on_cells = 0;
  for (std::size_t i = 0; i < n; ++i) {
    // Cell points are on the panels' +z faces (cells face +z with wing_angle 0) at |y| > 0.88 m.
    const Eigen::Vector3f p = cloud.points[i].vec();
    if (std::abs(p.y()) > 0.88f && cloud.normals[i].z > 0.99f &&
        cloud.intensity[i] == cell_reflectivity)
      ++on_cells;
  }
  EXPECT_NEAR(static_cast<double>(on_cells) / n, share, 5 * std::sqrt(share * (1 - share) / n));
  // Same seed, same cloud.
  const PointCloud again = samplePointCloud(*model, 100, 5);
  for (std::size_t i = 0; i < 100; ++i) EXPECT_EQ(again.points[i].vec(), cloud.points[i].vec());
}

TEST(ModelEdges, ABoxHasTwelveRightAngledCreases) {
  ModelBuilder b("box");
  b.addBox(Eigen::Isometry3d::Identity(), {0.5, 0.4, 0.3}, b.material(MaterialId::kStructure));
  const TargetModel box = b.build();
  const auto edges = extractEdges(box);
  ASSERT_EQ(edges.size(), 12u);
  for (const ModelEdge& e : edges) {
    EXPECT_TRUE(e.crease);
    EXPECT_FALSE(e.boundary);
    EXPECT_NEAR(e.dihedral_angle, M_PI / 2, 1e-5);
    EXPECT_NEAR(e.normal_left.dot(e.normal_right), 0.0, 1e-6);
    // Both faces' normals are perpendicular to the edge.
    EXPECT_NEAR(e.normal_left.dot((e.b - e.a).normalized()), 0.0, 1e-6);
  }
}

TEST(ModelExport, WritesEveryFormatAndReadsItBack) {
  auto model = makeTargetSatellite();
  ASSERT_OK(model.status());
  const auto dir = tempDir("export");
  auto files = exportModel(*model, dir, "target", 5000, 3);
  ASSERT_OK(files.status());
  for (const auto& path :
       {files->obj, files->mtl, files->ply, files->points_ply, files->cao, files->edges})
    EXPECT_GT(std::filesystem::file_size(path), 100u) << path;

  auto ply = loadPly(files->ply);
  ASSERT_OK(ply.status());
  EXPECT_EQ(ply->mesh.triangleCount(), model->mesh.triangleCount());
  EXPECT_NEAR(ply->surfaceArea(), model->surfaceArea(), 1e-6 * model->surfaceArea());
  EXPECT_TRUE(ply->bounds().isApprox(model->bounds(), 1e-6));
  // Material names survive (as PLY comments).
  std::set<std::string> names;
  for (const auto& m : ply->materials) names.insert(m.name);
  EXPECT_TRUE(names.count("solar_cell") && names.count("mli_gold"));

  auto obj = loadObj(files->obj);
  ASSERT_OK(obj.status());
  EXPECT_EQ(obj->mesh.triangleCount(), model->mesh.triangleCount());
  EXPECT_NEAR(obj->surfaceArea(), model->surfaceArea(), 1e-5 * model->surfaceArea());
  std::size_t cells_in = 0, cells_out = 0;
  for (std::size_t t = 0; t < model->mesh.triangleCount(); ++t) {
    cells_in += model->triangleMaterial(t).name == "solar_cell";
    cells_out += obj->triangleMaterial(t).name == "solar_cell";
  }
  EXPECT_EQ(cells_in, cells_out);

  auto cloud = readPointCloudPly(files->points_ply);
  ASSERT_OK(cloud.status());
  const PointCloud expected = samplePointCloud(*model, 5000, 3);
  ASSERT_EQ(cloud->size(), expected.size());
  ASSERT_TRUE(cloud->hasNormals());
  for (std::size_t i = 0; i < expected.size(); i += 97) {
    EXPECT_EQ(cloud->points[i].vec(), expected.points[i].vec());
    EXPECT_EQ(cloud->normals[i].vec(), expected.normals[i].vec());
  }

  auto edges = readEdges(files->edges);
  ASSERT_OK(edges.status());
  const auto expected_edges = extractEdges(*model);
  ASSERT_EQ(edges->size(), expected_edges.size());
  for (std::size_t i = 0; i < edges->size(); i += 37) {
    EXPECT_TRUE((*edges)[i].a.isApprox(expected_edges[i].a, 1e-6f));
    EXPECT_EQ((*edges)[i].crease, expected_edges[i].crease);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cdff::egse
