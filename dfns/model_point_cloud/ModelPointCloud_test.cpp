// ModelPointCloud: the samples of a box lie on its faces with the faces' outward normals, every
// face gets its share of points by area, the model is reproducible from its seed and the same
// shared cloud is output until the mesh changes; meshes load from OBJ and PLY (ascii and binary)
// files; a missing or malformed file and a missing mesh are reported.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "ModelPointCloud.gen.hpp"
#include "cdff/dfn/registry.hpp"
#include "cdff/egse/model_io.hpp"
#include "cdff/egse/procedural.hpp"
#include "support/dfn_testing.hpp"
#include "support/lidar.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<ModelPointCloud> make(const std::string& yaml = "{}") {
  return testing::makeDfn<ModelPointCloud>("ModelPointCloud", "MeshSampler", yaml);
}

const Eigen::Vector3d kHalf(0.6, 0.5, 0.25);  // a 1.2 x 1.0 x 0.5 m box: 3.8 m^2

TEST(ModelPointCloudMeshSampler, SamplesLieOnTheBoxFacesWithOutwardNormalsAndFairShares) {
  auto sampler = make("{point_spacing: 0.01}");
  sampler->in.mesh.set(testing::boxMesh(kHalf));
  ASSERT_OK(sampler->process());
  const PointCloud& model = *sampler->out.model;
  const double area = 8 * (kHalf.x() * kHalf.y() + kHalf.y() * kHalf.z() + kHalf.x() * kHalf.z());
  EXPECT_EQ(model.size(), static_cast<std::size_t>(std::round(area / 1e-4)));
  ASSERT_EQ(model.normals.size(), model.size());
  EXPECT_EQ(model.frame_id, "target");
  std::array<int, 6> per_face{};  // -x, +x, -y, +y, -z, +z
  for (std::size_t i = 0; i < model.size(); ++i) {
    const Eigen::Vector3d p = model.points[i].vec().cast<double>();
    const Eigen::Vector3d n = model.normals[i].vec().cast<double>();
    // On the surface: on the face its normal points out of, within the box elsewhere.
    int axis;
    n.cwiseAbs().maxCoeff(&axis);
    ASSERT_NEAR(std::abs(n[axis]), 1.0, 1e-6) << "point " << i;
    const double side = n[axis] > 0 ? 1.0 : -1.0;
    ASSERT_NEAR(p[axis], side * kHalf[axis], 1e-6) << "point " << i;
    ASSERT_TRUE((p.cwiseAbs().array() <= kHalf.array() + 1e-6).all()) << "point " << i;
    ++per_face[2 * axis + (side > 0 ? 1 : 0)];
  }
  for (int f = 0; f < 6; ++f) {
    const int axis = f / 2;
    const double face_area = 4 * kHalf[(axis + 1) % 3] * kHalf[(axis + 2) % 3];
    EXPECT_NEAR(per_face[f], model.size() * face_area / area, 2.0) << "face " << f;
  }
}

TEST(ModelPointCloudMeshSampler, TheModelIsReproducibleAndSharedUntilTheMeshChanges) {
  auto a = make("{point_spacing: 0.05, seed: 3}"), b = make("{point_spacing: 0.05, seed: 3}");
  auto c = make("{point_spacing: 0.05, seed: 4}");
  for (auto* s : {a.get(), b.get(), c.get()}) {
    s->in.mesh.set(testing::satelliteMesh());
    ASSERT_OK(s->process());
  }
  ASSERT_EQ(a->out.model->size(), b->out.model->size());
  EXPECT_EQ(0, std::memcmp(a->out.model->points.data(), b->out.model->points.data(),
                           a->out.model->size() * sizeof(Point4f)));
  EXPECT_NE(0, std::memcmp(a->out.model->points.data(), c->out.model->points.data(),
                           a->out.model->size() * sizeof(Point4f)));

  const Buffer<Point4f> first = a->out.model->points;
  ASSERT_OK(a->process());  // no fresh mesh: the same cloud
  EXPECT_TRUE(a->out.model->points.sharesMemoryWith(first));
  a->in.mesh.set(testing::boxMesh(kHalf));
  ASSERT_OK(a->process());
  EXPECT_FALSE(a->out.model->points.sharesMemoryWith(first));
}

class MeshFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("cdff_model_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& content) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }
  double modelArea(const std::string& yaml, std::size_t* points = nullptr) {
    auto sampler = make(yaml);
    EXPECT_OK(sampler->process());
    if (!sampler->out.model.get()) return 0;
    if (points) *points = sampler->out.model->size();
    return static_cast<double>(sampler->out.model->size()) * 1e-4;  // spacing 0.01
  }
  std::filesystem::path dir_;
};

// A unit cube as quads (OBJ: 1-based, one face with negative indices and v/vt/vn corners).
const char* kCubeObj =
    "# unit cube\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "vn 0 0 1\n"
    "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf -4/1/1 -8/1/1 -5/1/1 -1/1/1\n";

TEST_F(MeshFiles, ObjAndPlyFilesLoadAsTheSameCube) {
  const std::string obj = write("cube.obj", kCubeObj);
  const std::string ascii = write("cube.ply",
                                  "ply\nformat ascii 1.0\ncomment a cube\nelement vertex 8\n"
                                  "property float x\nproperty float y\nproperty float z\n"
                                  "element face 6\nproperty list uchar int vertex_indices\n"
                                  "end_header\n"
                                  "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
                                  "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n"
                                  "4 3 0 4 7\n");
  // The same cube, binary little-endian, vertices as doubles, with an extra element to skip.
  std::string binary =
      "ply\nformat binary_little_endian 1.0\nelement vertex 8\nproperty double x\n"
      "property double y\nproperty double z\nproperty uchar red\nelement face 6\n"
      "property list uchar uint vertex_indices\nelement edge 1\nproperty int a\n"
      "end_header\n";
  const double v[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                          {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  for (const auto& vertex : v) {
    binary.append(reinterpret_cast<const char*>(vertex), sizeof(vertex));
    binary.push_back('\x7f');
  }
  const std::uint32_t faces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                     {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  for (const auto& f : faces) {
    binary.push_back('\x04');
    binary.append(reinterpret_cast<const char*>(f), sizeof(f));
  }
  binary.append(4, '\0');
  const std::string bin = write("cube_bin.PLY", binary);
  for (const std::string& path : {obj, ascii, bin}) {
    Result<egse::TargetModel> loaded = egse::loadModel(path);
    ASSERT_OK(loaded.status());
    const TriangleMesh* mesh = &loaded->mesh;
    EXPECT_EQ(mesh->triangleCount(), 12u) << path;
    EXPECT_NEAR(mesh->surfaceArea(), 6.0, 1e-6) << path;
    std::size_t points = 0;
    EXPECT_NEAR(modelArea(fmt::format("{{mesh_file: '{}', point_spacing: 0.01}}", path), &points),
                6.0, 1e-3)
        << path;
  }
  // Millimetres: 1000 mm cube at scale 0.001 is the unit cube again.
  const std::string mm =
      write("cube_mm.obj",
            "v 0 0 0\nv 1000 0 0\nv 1000 1000 0\nv 0 1000 0\nv 0 0 1000\n"
            "v 1000 0 1000\nv 1000 1000 1000\nv 0 1000 1000\n"
            "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n");
  EXPECT_NEAR(modelArea(fmt::format("{{mesh_file: '{}', scale: 0.001}}", mm)), 6.0, 1e-3);
}

// A model read from a file with materials carries each point's reflectivity (the LIDAR/ToF
// return of its triangle's material) as its intensity: the samples are uniform by area, so their
// mean is the model's area-weighted mean reflectivity (within the sampling's share rounding:
// one point per triangle at most, of tens of thousands). A mesh from the input has none.
TEST_F(MeshFiles, AModelFileWithMaterialsGivesThePointsTheirReflectivity) {
  const egse::TargetModel target = egse::makeTargetSatellite().value();
  const std::string path = (dir_ / "target.ply").string();
  ASSERT_OK(egse::writePly(target, path));
  const egse::TargetModel loaded = egse::loadModel(path).value();
  double weighted = 0, area = 0;
  for (std::size_t t = 0; t < loaded.mesh.triangleCount(); ++t) {
    const auto& tri = loaded.mesh.triangles[t];
    const Eigen::Vector3f a = loaded.mesh.vertices[tri[0]];
    const double s =
        0.5 * (loaded.mesh.vertices[tri[1]] - a).cross(loaded.mesh.vertices[tri[2]] - a).norm();
    weighted += s * loaded.triangleMaterial(t).lidar_reflectivity;
    area += s;
  }
  auto sampler = make(fmt::format("{{mesh_file: '{}', point_spacing: 0.02}}", path));
  ASSERT_OK(sampler->process());
  const PointCloud& model = *sampler->out.model;
  ASSERT_EQ(model.intensity.size(), model.size());
  double mean = 0;
  for (float r : model.intensity) {
    ASSERT_GE(r, 0.0f);
    ASSERT_LE(r, 1.0f);
    mean += r;
  }
  mean /= static_cast<double>(model.size());
  EXPECT_NEAR(mean, weighted / area, 0.01 * weighted / area);
  // The solar cells (0.12) and the MLI (0.55, 0.6) are both there: not one material throughout.
  EXPECT_LT(*std::min_element(model.intensity.begin(), model.intensity.end()), 0.2f);
  EXPECT_GT(*std::max_element(model.intensity.begin(), model.intensity.end()), 0.5f);

  auto from_input = make("{point_spacing: 0.02}");
  from_input->in.mesh.set(loaded.mesh);
  ASSERT_OK(from_input->process());
  EXPECT_TRUE(from_input->out.model->intensity.empty());
}

// A mesh file is read when the node is configured, so a missing or malformed file stops a graph
// from starting, with the file's name and what is wrong where.
TEST_F(MeshFiles, MissingAndMalformedFilesAreReportedAtConfiguration) {
  const auto rejected = [](const std::string& file, const std::string& fragment, StatusCode code) {
    auto node =
        dfn::Registry::instance().createAs<ModelPointCloud>("ModelPointCloud", "MeshSampler");
    ASSERT_TRUE(node.isOk()) << node.status().toString();
    const Status s = node.value()->configure(YAML::Load(fmt::format("{{mesh_file: '{}'}}", file)));
    EXPECT_EQ(s.code(), code) << s.toString();
    EXPECT_NE(s.message().find(fragment), std::string::npos)
        << "'" << fragment << "' not in: " << s.message();
    EXPECT_NE(s.message().find("parameter 'mesh_file'"), std::string::npos) << s.message();
  };
  rejected((dir_ / "nope.ply").string(), "nope.ply' does not exist", StatusCode::kNotFound);
  rejected(write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), "bad.obj:4",
           StatusCode::kCorruptData);
  rejected(write("short.ply",
                 "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                 "property float y\nproperty float z\nend_header\n\x01\x02"),
           "short.ply: byte 115: the file ends inside vertex 0", StatusCode::kCorruptData);
  rejected(write("model.dae", "<COLLADA/>\n"), "expected .obj, .ply, .stl, .gltf or .glb",
           StatusCode::kInvalidInput);
}

TEST(ModelPointCloudMeshSampler, BadInputsAndParametersAreReported) {
  auto sampler = make();
  testing::expectRejected(*sampler, "no mesh");

  TriangleMesh broken = testing::boxMesh(kHalf);
  std::vector<std::array<std::uint32_t, 3>> triangles(broken.triangles.begin(),
                                                      broken.triangles.end());
  triangles[2][1] = 99;
  broken.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
  sampler->in.mesh.set(broken);
  testing::expectRejected(*sampler, "uses vertex 99");

  auto fine = make("{point_spacing: 0.0001, max_points: 1000}");
  fine->in.mesh.set(testing::boxMesh(kHalf));
  testing::expectRejected(*fine, "more than max_points = 1000", StatusCode::kInvalidParameter);

  auto vertex = make("{normals: vertex}");
  vertex->in.mesh.set(testing::boxMesh(kHalf));
  testing::expectRejected(*vertex, "no vertex normals");

  auto node = Registry::instance().create("ModelPointCloud", "MeshSampler");
  ASSERT_TRUE(node.isOk());
  Status s = node.value()->configure(YAML::Load("{normals: smooth}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  s = node.value()->configure(YAML::Load("{point_spacing: 0}"));
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
}

}  // namespace
}  // namespace cdff::dfn
