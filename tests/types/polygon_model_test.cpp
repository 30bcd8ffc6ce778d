// PolygonModel and the ViSP .cao reader/writer: every primitive parses, malformed files are
// rejected with the file, the line and what was expected, and writing then reading gives the
// model back.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "cdff/types/polygon_model.hpp"
#include "support/synthetic.hpp"

namespace cdff {
namespace {

const char* kAllPrimitives = R"(V1
# a comment line
# 3D points
8
0 0 0      # 0
1 0 0      # 1
1 1 0
0 1 0
0 0 1
1 0 1
0.5 0.5 2
0.5 0.5 3
# 3D lines
5
0 1
1 2
2 3
3 0 name=closing_line
4 5 name=antenna
# faces from lines
1
4 0 1 2 3 name=bottom
# faces from points
1
3 4 5 6 name=tilted
# cylinders
1
6 7 0.25 name=mast
# circles
1
0.1 6 4 5 name=ring
)";

Status errorOf(const std::string& text) {
  Result<PolygonModel> m = parseCao(text, "model.cao");
  return m.status();
}

void expectError(const std::string& text, const std::string& fragment) {
  const Status s = errorOf(text);
  EXPECT_FALSE(s.isOk()) << "accepted:\n" << text;
  EXPECT_NE(s.message().find(fragment), std::string::npos)
      << "'" << fragment << "' not in: " << s.message();
}

TEST(CaoParser, ReadsEveryPrimitive) {
  Result<PolygonModel> m = parseCao(kAllPrimitives, "all.cao");
  ASSERT_TRUE(m.isOk()) << m.status().toString();
  EXPECT_EQ(m->points.size(), 8u);
  ASSERT_EQ(m->faces.size(), 2u);
  EXPECT_EQ(m->faces[0].name, "bottom");
  // The face from lines follows the lines' chain: 0 1 2 3.
  EXPECT_EQ(m->faces[0].points, (std::vector<std::uint32_t>{0, 1, 2, 3}));
  EXPECT_EQ(m->faces[1].points, (std::vector<std::uint32_t>{4, 5, 6}));
  // Lines that bound a face are face edges; the others stay explicit lines.
  ASSERT_EQ(m->lines.size(), 1u);
  EXPECT_EQ(m->lines[0].name, "antenna");
  ASSERT_EQ(m->cylinders.size(), 1u);
  EXPECT_DOUBLE_EQ(m->cylinders[0].radius, 0.25);
  EXPECT_EQ(m->cylinders[0].name, "mast");
  ASSERT_EQ(m->circles.size(), 1u);
  EXPECT_DOUBLE_EQ(m->circles[0].radius, 0.1);
  EXPECT_EQ(m->circles[0].centre, 6u);
  EXPECT_OK(m->validate());
}

TEST(CaoParser, ReadsTheCastleModelWithItsIncludes) {
  const std::string path =
      "/usr/share/visp-images-data/ViSP-images/mbt-depth/Castle-simu/Models/chateau.cao";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "visp-images-data is not installed";
  Result<PolygonModel> m = loadCao(path);
  ASSERT_TRUE(m.isOk()) << m.status().toString();
  EXPECT_EQ(m->points.size(), 14u);  // 6 floor + 8 tower points
  ASSERT_EQ(m->faces.size(), 5u);
  EXPECT_EQ(m->faces[0].name, "floor");
  EXPECT_EQ(m->faces[1].name, "tower_front");
  EXPECT_EQ(m->faces[1].points, (std::vector<std::uint32_t>{6, 7, 8, 9}));  // offset by the floor
  EXPECT_OK(m->validate());
}

TEST(CaoParser, OlderFilesWithoutVersionOrTrailingSectionsAreRead) {
  Result<PolygonModel> m = parseCao("3\n0 0 0\n1 0 0\n0 1 0\n0\n0\n1\n3 0 1 2\n", "old.cao");
  ASSERT_TRUE(m.isOk()) << m.status().toString();
  EXPECT_EQ(m->faces.size(), 1u);
}

TEST(CaoParser, ErrorsNameTheFileTheLineAndWhatWasExpected) {
  expectError("V1\n3\n0 0 0\n1 x 0\n0 1 0\n0\n0\n0\n",
              "model.cao:4: record 1 of 3 in the 3D points "
              "section: 'x' is not a number");
  expectError("V1\n3\n0 0 0\n1 0\n0 1 0\n0\n0\n0\n",
              "model.cao:4: record 1 of 3 in the 3D points "
              "section has 2 numbers; expected 3");
  expectError("V1\n3\n0 0 0\n1 0 0\n0 1 0\n0\n0\n1\n3 0 1 7\n",
              "model.cao:9: record 0 of 1 in the faces from 3D points section refers to point 7; "
              "expected an index in [0, 2]");
  expectError("V1\n3\n0 0 0\n1 0 0\n0 1 0\n0\n0\n1\n4 0 1 2\n",
              "lists 3 point indices; expected 4");
  expectError("V1\n3\n0 0 0\n1 0 0\n", "the file ends at record 2 of 3 in the 3D points section");
  expectError("V1\n2\n0 0 0\n1 0 0\n", "the file ends before the 3D lines section");
  expectError("V1\nthree\n", "model.cao:2: expected the number of 3D points");
  expectError("V3\n0\n", "model.cao:1: unsupported .cao version 'V3'");
  expectError("V1\n3\n0 0 0\n1 0 0\n0 1 0\n0\n0\n1\n3 0 1 2 colour=red\n",
              "model.cao:9: unknown option 'colour'");
  expectError("V1\n3\n0 0 0\n1 0 0\n0 1 0\n0\n0\n1\n3 0 1 2 oops\n",
              "model.cao:9: unexpected 'oops'");
  expectError("V1\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3\n0 1\n2 3\n3 0\n1\n3 0 1 2\n0\n",
              "face from lines: line 1 does not start where line 0 ends");
  expectError("V1\n3\n0 0 0\n1 0 0\n0 1 0\n0\n0\n0\n1\n0 1 -0.5\n",
              "cylinder 0 of 1 has radius -0.5");
  expectError("V1\n3\n0 0 0\n1 0 0\n0 1 0\n0\n0\n0\n0\n0\nextra\n", "after the last section");
  expectError("V1\nload(\"missing_part.cao\")\n0\n0\n0\n0\n", "cannot open the included model");
  expectError("V1\n0\n0\n0\n0\n0\n0\n", "has no face, line, cylinder or circle");
}

TEST(CaoParser, IncludedFilesReportTheirOwnPathAndLine) {
  const auto dir = std::filesystem::temp_directory_path() / "cdff_cao_include_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "part.cao") << "V1\n2\n0 0 0\nnope 1 1\n0\n0\n0\n";
  std::ofstream(dir / "main.cao") << "V1\nload(\"part.cao\")\n0\n0\n0\n0\n";
  const Status s = loadCao((dir / "main.cao").string()).status();
  EXPECT_NE(s.message().find("part.cao:4:"), std::string::npos) << s.toString();
  std::filesystem::remove_all(dir);
}

TEST(CaoParser, AMissingFileIsNotFound) {
  const Status s = loadCao("/nonexistent/model.cao").status();
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_NE(s.message().find("/nonexistent/model.cao"), std::string::npos);
}

TEST(CaoWriter, WritingThenReadingGivesTheModelBack) {
  Result<PolygonModel> m = parseCao(kAllPrimitives, "all.cao");
  ASSERT_TRUE(m.isOk());
  Result<PolygonModel> again = parseCao(toCao(*m), "again.cao");
  ASSERT_TRUE(again.isOk()) << again.status().toString() << "\n" << toCao(*m);
  ASSERT_EQ(again->points.size(), m->points.size());
  for (std::size_t i = 0; i < m->points.size(); ++i)
    EXPECT_LT((again->points[i] - m->points[i]).norm(), 1e-9);
  ASSERT_EQ(again->faces.size(), m->faces.size());
  for (std::size_t i = 0; i < m->faces.size(); ++i) {
    EXPECT_EQ(again->faces[i].points, m->faces[i].points);
    EXPECT_EQ(again->faces[i].name, m->faces[i].name);
  }
  EXPECT_EQ(again->lines.size(), m->lines.size());
  EXPECT_EQ(again->cylinders.size(), m->cylinders.size());
  EXPECT_EQ(again->circles.size(), m->circles.size());
}

TEST(PolygonModel, ValidationRejectsBrokenGeometry) {
  PolygonModel m;
  m.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0.5}};
  m.faces = {{{0, 1, 2, 3}, "warped"}};
  Status s = m.validate();
  EXPECT_NE(s.message().find("face 0 ('warped') is not planar"), std::string::npos) << s.toString();
  m.faces = {{{0, 1, 1}, "repeated"}};
  EXPECT_NE(m.validate().message().find("distinct"), std::string::npos);
  m.faces = {{{0, 1, 9}, "outside"}};
  EXPECT_NE(m.validate().message().find("refers to point 9"), std::string::npos);
  m.faces.clear();
  m.cylinders = {{0, 1, 0.0, "flat"}};
  EXPECT_NE(m.validate().message().find("radius 0"), std::string::npos);
  m.cylinders.clear();
  m.circles = {{0, 1, 1, 0.1, "line"}};
  EXPECT_NE(m.validate().message().find("collinear"), std::string::npos);
}

TEST(PolygonModel, AppendMapsThePointsAndOffsetsTheIndices) {
  PolygonModel a;
  a.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  a.faces = {{{0, 1, 2}, "a"}};
  PolygonModel b = a;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() << 0, 0, 2;
  a.append(b, t);
  ASSERT_EQ(a.faces.size(), 2u);
  EXPECT_EQ(a.faces[1].points, (std::vector<std::uint32_t>{3, 4, 5}));
  EXPECT_DOUBLE_EQ(a.points[4].z(), 2.0);
  EXPECT_OK(a.validate());
}

}  // namespace
}  // namespace cdff
