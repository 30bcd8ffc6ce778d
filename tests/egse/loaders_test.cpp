// Mesh loaders: every supported format on a known cube, and malformed files reported with their
// line or byte.
#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "cdff/egse/model_io.hpp"
#include "support/synthetic.hpp"

namespace cdff::egse {
namespace {

class Loaders : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("cdff_loaders_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path write(const std::string& name, const std::string& content) {
    const auto path = dir_ / name;
    std::ofstream(path, std::ios::binary) << content;
    return path;
  }
  std::filesystem::path dir_;
};

// The unit cube [0, 1]^3: 8 corners, 6 faces counter-clockwise seen from outside.
const float kCorners[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                              {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
const int kQuads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                          {2, 3, 7, 6}, {1, 2, 6, 5}, {0, 4, 7, 3}};

std::vector<std::array<int, 3>> cubeTriangles() {
  std::vector<std::array<int, 3>> t;
  for (const auto& q : kQuads) {
    t.push_back({q[0], q[1], q[2]});
    t.push_back({q[0], q[2], q[3]});
  }
  return t;
}

void expectUnitCube(const Result<TargetModel>& model, double scale = 1.0) {
  ASSERT_OK(model.status());
  EXPECT_EQ(model->mesh.triangleCount(), 12u);
  EXPECT_NEAR(model->surfaceArea(), 6.0 * scale * scale, 1e-5);
  const Eigen::AlignedBox3d box = model->bounds();
  EXPECT_TRUE(box.min().isApprox(Eigen::Vector3d::Zero(), 1e-6) || box.min().norm() < 1e-6);
  EXPECT_TRUE(box.max().isApprox(Eigen::Vector3d::Constant(scale), 1e-6));
  // Flat faces (90 degree creases are sharper than the smoothing angle): every vertex normal is
  // the outward normal of its face.
  const Eigen::Vector3d centre = Eigen::Vector3d::Constant(0.5 * scale);
  for (const auto& t : model->mesh.triangles) {
    const Eigen::Vector3d a = model->mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = model->mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = model->mesh.vertices[t[2]].cast<double>();
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    EXPECT_GT(n.dot((a + b + c) / 3 - centre), 0.0);
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(model->mesh.vertex_normals[t[k]].cast<double>().dot(n), 1.0, 1e-6);
  }
}

TEST_F(Loaders, ObjWithQuadsNegativeIndicesAndMaterials) {
  std::string obj = "# cube\nmtllib cube.mtl\n";
  for (const auto& c : kCorners) obj += fmt::format("v {} {} {}\n", c[0], c[1], c[2]);
  obj += "vn 0 0 1\nusemtl solar_cell\n";
  // Faces as quads with mixed index styles; the last one with negative (relative) indices.
  for (int f = 0; f < 5; ++f)
    obj += fmt::format("f {}/1/1 {}//1 {} {}\n", kQuads[f][0] + 1, kQuads[f][1] + 1,
                       kQuads[f][2] + 1, kQuads[f][3] + 1);
  obj += "usemtl red_paint\n";
  obj += fmt::format("f {} {} {} {}\n", kQuads[5][0] - 8, kQuads[5][1] - 8, kQuads[5][2] - 8,
                     kQuads[5][3] - 8);
  write("cube.mtl", "newmtl red_paint\nKd 0.8 0.1 0.1\nKs 0.2 0.2 0.2\nNs 50\n");
  auto model = loadObj(write("cube.obj", obj));
  expectUnitCube(model);
  ASSERT_EQ(model->materials.size(), 2u);
  EXPECT_EQ(model->materials[0].name, "solar_cell");  // the built-in one
  EXPECT_EQ(model->materials[0].pattern, SurfacePattern::kSolarCell);
  EXPECT_EQ(model->materials[1].name, "red_paint");  // from the MTL
  EXPECT_FLOAT_EQ(model->materials[1].diffuse.x(), 0.8f);
  EXPECT_FLOAT_EQ(model->materials[1].shininess, 50.0f);
}

TEST_F(Loaders, ScaleAndRecentre) {
  std::string obj;
  for (const auto& c : kCorners)
    obj += fmt::format("v {} {} {}\n", 1000 * c[0], 1000 * c[1], 1000 * c[2]);
  for (const auto& q : kQuads)
    obj += fmt::format("f {} {} {} {}\n", q[0] + 1, q[1] + 1, q[2] + 1, q[3] + 1);
  MeshLoadOptions options;
  options.scale = 0.001;
  expectUnitCube(loadObj(write("mm.obj", obj), options));
  options.recentre = true;
  auto centred = loadObj(write("mm.obj", obj), options);
  ASSERT_OK(centred.status());
  EXPECT_LT(centred->boundingCentre().norm(), 1e-6);
  options.scale = -1;
  EXPECT_EQ(loadObj(write("mm.obj", obj), options).status().code(), StatusCode::kInvalidParameter);
}

TEST_F(Loaders, PlyAsciiAndBinaryBothEndians) {
  auto header = [](const std::string& format) {
    return "ply\nformat " + format +
           " 1.0\ncomment a cube\nelement vertex 8\nproperty float x\nproperty float y\n"
           "property float z\nproperty uchar red\nelement face 6\nproperty list uchar int "
           "vertex_indices\nelement extra 1\nproperty list uchar float junk\nend_header\n";
  };
  std::string ascii = header("ascii");
  for (const auto& c : kCorners) ascii += fmt::format("{} {} {} 255\n", c[0], c[1], c[2]);
  for (const auto& q : kQuads) ascii += fmt::format("4 {} {} {} {}\n", q[0], q[1], q[2], q[3]);
  ascii += "2 0.5 0.25\n";
  expectUnitCube(loadPly(write("ascii.ply", ascii)));

  for (bool big : {false, true}) {
    std::string bin = header(big ? "binary_big_endian" : "binary_little_endian");
    auto put = [&](const void* p, std::size_t n) {
      std::string bytes(static_cast<const char*>(p), n);
      if (big) std::reverse(bytes.begin(), bytes.end());
      bin += bytes;
    };
    for (const auto& c : kCorners) {
      for (float v : c) put(&v, 4);
      const std::uint8_t red = 255;
      put(&red, 1);
    }
    for (const auto& q : kQuads) {
      const std::uint8_t n = 4;
      put(&n, 1);
      for (int i : q) {
        const std::int32_t v = i;
        put(&v, 4);
      }
    }
    const std::uint8_t n = 2;
    put(&n, 1);
    const float junk[2] = {1, 2};
    put(&junk[0], 4);
    put(&junk[1], 4);
    expectUnitCube(loadPly(write(big ? "big.ply" : "little.ply", bin)));
  }
}

TEST_F(Loaders, StlAsciiAndBinary) {
  std::string ascii = "solid cube\n";
  for (const auto& t : cubeTriangles()) {
    ascii += "  facet normal 0 0 0\n    outer loop\n";
    for (int i : t)
      ascii +=
          fmt::format("      vertex {} {} {}\n", kCorners[i][0], kCorners[i][1], kCorners[i][2]);
    ascii += "    endloop\n  endfacet\n";
  }
  ascii += "endsolid cube\n";
  expectUnitCube(loadStl(write("ascii.stl", ascii)));

  // Binary, with a header that starts with "solid" as some exporters write.
  std::string bin(80, ' ');
  bin.replace(0, 11, "solid cube!");
  const std::uint32_t count = 12;
  bin.append(reinterpret_cast<const char*>(&count), 4);
  for (const auto& t : cubeTriangles()) {
    const float normal[3] = {0, 0, 0};
    bin.append(reinterpret_cast<const char*>(normal), 12);
    for (int i : t) bin.append(reinterpret_cast<const char*>(kCorners[i]), 12);
    bin.append(2, '\0');
  }
  expectUnitCube(loadStl(write("binary.stl", bin)));
}

std::string base64(const std::string& in) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  int val = 0, bits = -6;
  for (unsigned char c : in) {
    val = (val << 8) + c;
    bits += 8;
    while (bits >= 0) {
      out.push_back(table[(val >> bits) & 0x3F]);
      bits -= 6;
    }
  }
  if (bits > -6) out.push_back(table[((val << 8) >> (bits + 8)) & 0x3F]);
  while (out.size() % 4) out.push_back('=');
  return out;
}

// A cube as glTF buffers: 8 float positions then 36 uint16 indices. Placed by a node that
// translates it by (2, 0, 0) and scales it by 0.5, under a parent node translating by (0, 1, 0).
struct GltfCube {
  std::string bin;
  std::string json(const std::string& buffer) const {
    return fmt::format(R"({{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"translation": [0, 1, 0], "children": [1]}},
            {{"mesh": 0, "translation": [2, 0, 0], "scale": [0.5, 0.5, 0.5]}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{{"name": "gold", "pbrMetallicRoughness": {{"baseColorFactor": [1, 0.8, 0.3, 1],
                 "metallicFactor": 1.0, "roughnessFactor": 0.3}}}}],
  "buffers": [{}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 96}},
                  {{"buffer": 0, "byteOffset": 96, "byteLength": 72}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
                  "min": [0, 0, 0], "max": [1, 1, 1]}},
                {{"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}}]
}})",
                       buffer);
  }
  GltfCube() {
    for (const auto& c : kCorners) bin.append(reinterpret_cast<const char*>(c), 12);
    for (const auto& t : cubeTriangles())
      for (int i : t) {
        const std::uint16_t v = static_cast<std::uint16_t>(i);
        bin.append(reinterpret_cast<const char*>(&v), 2);
      }
  }
};

void expectPlacedCube(const Result<TargetModel>& model) {
  ASSERT_OK(model.status());
  EXPECT_EQ(model->mesh.triangleCount(), 12u);
  EXPECT_NEAR(model->surfaceArea(), 6 * 0.25, 1e-6);
  EXPECT_TRUE(model->bounds().min().isApprox(Eigen::Vector3d(2, 1, 0), 1e-6));
  EXPECT_TRUE(model->bounds().max().isApprox(Eigen::Vector3d(2.5, 1.5, 0.5), 1e-6));
  ASSERT_EQ(model->materials.size(), 1u);
  EXPECT_EQ(model->materials[0].name, "gold");
  EXPECT_GT(model->materials[0].specular.x(), 0.9f);  // metallic: the colour goes specular
}

TEST_F(Loaders, GltfEmbeddedExternalAndGlb) {
  GltfCube cube;
  const std::string embedded =
      fmt::format(R"({{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}})",
                  cube.bin.size(), base64(cube.bin));
  expectPlacedCube(loadGltf(write("embedded.gltf", cube.json(embedded))));

  write("cube.bin", cube.bin);
  const std::string external =
      fmt::format(R"({{"byteLength": {}, "uri": "cube.bin"}})", cube.bin.size());
  expectPlacedCube(loadModel(write("external.gltf", cube.json(external))));

  std::string json = cube.json(fmt::format(R"({{"byteLength": {}}})", cube.bin.size()));
  while (json.size() % 4) json.push_back(' ');
  std::string bin = cube.bin;
  while (bin.size() % 4) bin.push_back('\0');
  std::string glb = "glTF";
  auto u32 = [&](std::uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
  u32(2);
  u32(static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  u32(static_cast<std::uint32_t>(json.size()));
  u32(0x4E4F534Au);
  glb += json;
  u32(static_cast<std::uint32_t>(bin.size()));
  u32(0x004E4942u);
  glb += bin;
  expectPlacedCube(loadModel(write("cube.glb", glb)));
}

void expectError(const Result<TargetModel>& model, StatusCode code, const std::string& fragment) {
  ASSERT_FALSE(model.isOk()) << "expected an error containing '" << fragment << "'";
  EXPECT_EQ(model.status().code(), code) << model.status().toString();
  EXPECT_NE(model.status().message().find(fragment), std::string::npos)
      << "message: " << model.status().message() << "\nexpected to contain: " << fragment;
}

TEST_F(Loaders, BadObjFilesNameTheLine) {
  expectError(loadObj(write("a.obj", "v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n")),
              StatusCode::kCorruptData, "a.obj:3: vertex coordinate 'zero' is not a finite number");
  expectError(loadObj(write("b.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")),
              StatusCode::kCorruptData,
              "b.obj:4: face vertex 4 refers to a vertex not defined yet (3 so far)");
  expectError(loadObj(write("c.obj", "v 0 0 0\nf 1 1\n")), StatusCode::kCorruptData,
              "c.obj:2: face has 2 vertices; expected at least 3");
  expectError(loadObj(write("d.obj", "v 0 0 0\n")), StatusCode::kCorruptData, "holds no triangles");
  expectError(loadModel(dir_ / "missing.obj"), StatusCode::kNotFound,
              "missing.obj' does not exist");
  expectError(loadModel(write("e.xyz", "1 2 3\n")), StatusCode::kInvalidInput,
              "expected .obj, .ply, .stl, .gltf or .glb");
}

TEST_F(Loaders, BadPlyFilesNameTheLineOrByte) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  expectError(loadPly(write("a.ply", header + "0 0 0\n1 0 0\n0 one 0\n3 0 1 2\n")),
              StatusCode::kCorruptData, "a.ply:12: 'one' in vertex 2 is not a number");
  expectError(loadPly(write("b.ply", header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")),
              StatusCode::kCorruptData, "face 0 uses vertex 7; expected an index < 3");
  expectError(loadPly(write("c.ply", "plx\n")), StatusCode::kCorruptData,
              "c.ply:1: not a PLY file");
  expectError(
      loadPly(write("d.ply",
                    "ply\nformat ascii 1.0\nelement vertex 1\nproperty flaot x\nend_header\n")),
      StatusCode::kCorruptData, "d.ply:4: unknown property type 'flaot'");
  // Binary, truncated in the third vertex: 3 x 12 bytes expected, 30 present.
  const std::string bin_header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float "
      "y\nproperty float z\nend_header\n";
  expectError(loadPly(write("e.ply", bin_header + std::string(30, '\0'))), StatusCode::kCorruptData,
              fmt::format("e.ply: byte {}: the file ends inside vertex 2", bin_header.size() + 28));
}

TEST_F(Loaders, BadStlAndGltfFiles) {
  expectError(loadStl(write("a.stl", "solid x\n vertex 0 0 0\n")), StatusCode::kCorruptData,
              "a.stl:2: 'vertex' outside 'outer loop'");
  expectError(
      loadStl(
          write("b.stl",
                "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n")),
      StatusCode::kCorruptData, "b.stl:6: a facet has 2 vertices; expected 3");
  expectError(loadStl(write("c.stl", std::string(100, 'x'))), StatusCode::kCorruptData,
              "not an STL file: 100 bytes");
  expectError(loadGltf(write("a.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [")),
              StatusCode::kCorruptData, "a.gltf: byte 41: invalid JSON");
  expectError(loadGltf(write("b.gltf", R"({"asset": {"version": "1.0"}})")),
              StatusCode::kCorruptData, "asset.version is '1.0'; expected glTF 2.x");
  GltfCube cube;
  std::string short_buffer = cube.json(
      fmt::format(R"({{"byteLength": 96, "uri": "data:application/octet-stream;base64,{}"}})",
                  base64(cube.bin.substr(0, 96))));
  expectError(loadGltf(write("c.gltf", short_buffer)), StatusCode::kCorruptData,
              "bufferViews[1] spans bytes 96..168 of buffer 0, which has 96 bytes");
  expectError(
      loadGltf(write("d.glb", std::string("glTF\x01\0\0\0\x20\0\0\0", 12) + std::string(8, '\0'))),
      StatusCode::kCorruptData, "d.glb: byte 4: GLB version 1; expected 2");
}

}  // namespace
}  // namespace cdff::egse
