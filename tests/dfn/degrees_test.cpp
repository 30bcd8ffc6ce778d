// Angles in YAML are degrees, in C++ radians (docs/conventions.md#units): a parameter declared
// `unit: deg` or `unit: deg/s` is range-checked and reported as written, in degrees, and held in
// radians; a C++ parameter struct is SI throughout.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "FrameworkProbe.gen.hpp"
#include "cdff/dfn/description.hpp"
#include "cdff/dfn/registry.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::unique_ptr<FrameworkProbeArithmeticBase> makeProbe() {
  auto node =
      Registry::instance().createAs<FrameworkProbeArithmeticBase>("FrameworkProbe", "Arithmetic");
  EXPECT_TRUE(node.isOk()) << node.status().toString();
  return std::move(node).value();
}

Status configureYaml(Node& node, const std::string& yaml) {
  return node.configure(YAML::Load(yaml), "params.yaml");
}

/// Radians that no double number of degrees times pi/180 gives back.
constexpr double kNoDegrees = 1.3943616755677566;

TEST(Degrees, TheFactorIsPiOver180ForDegreesOnly) {
  EXPECT_EQ(siPerUnit("deg"), M_PI / 180.0);
  EXPECT_EQ(siPerUnit("deg/s"), M_PI / 180.0);
  for (const char* unit : {"", "1", "m", "rad^2/s^3", "px", "degrees"}) {
    EXPECT_EQ(siPerUnit(unit), 1.0) << unit;
    EXPECT_EQ(siUnit(unit), unit);
  }
  EXPECT_EQ(siUnit("deg"), "rad");
  EXPECT_EQ(siUnit("deg/s"), "rad/s");
}

TEST(Degrees, DefaultsInDegreesAreHeldInRadians) {
  auto probe = makeProbe();
  ASSERT_OK(probe->configureDefaults());
  // The same product as the reader's, so a default and the same value written in YAML agree.
  EXPECT_EQ(probe->parameters().tilt, 10 * kRadiansPerDegree);
  EXPECT_NEAR(probe->parameters().tilt, 0.17453292519943295, 1e-16);
  EXPECT_EQ(probe->parameters().rates, (std::vector<double>{0, 5 * kRadiansPerDegree}));
  FrameworkProbeArithmeticParameters fresh;
  EXPECT_EQ(fresh.tilt, probe->parameters().tilt) << "the generated struct's default";
}

TEST(Degrees, YamlDegreesAreConvertedToRadians) {
  auto probe = makeProbe();
  ASSERT_OK(configureYaml(*probe, "tilt: 30\nrates: [90, -45.5]"));
  EXPECT_EQ(probe->parameters().tilt, 30 * kRadiansPerDegree);
  EXPECT_NEAR(probe->parameters().tilt, M_PI / 6, 1e-15);
  ASSERT_EQ(probe->parameters().rates.size(), 2u);
  EXPECT_NEAR(probe->parameters().rates[0], M_PI / 2, 1e-15);
  EXPECT_NEAR(probe->parameters().rates[1], -45.5 * M_PI / 180, 1e-15);
  // A value that looks like radians is read as degrees: 1.5 deg, not 86 deg.
  ASSERT_OK(configureYaml(*probe, "tilt: 1.5"));
  EXPECT_NEAR(probe->parameters().tilt, 0.02617993877991494, 1e-16);
  // The other kinds are not converted.
  ASSERT_OK(configureYaml(*probe, "gain: 3\noffsets: [0.5, -1, 1]"));
  EXPECT_EQ(probe->parameters().gain, 3.0);
  EXPECT_EQ(probe->parameters().offsets, (std::vector<double>{0.5, -1, 1}));
}

TEST(Degrees, RangesAreCheckedInDegreesAndErrorsShowTheValueAsWritten) {
  auto probe = makeProbe();
  ASSERT_OK(configureYaml(*probe, "tilt: 90"));
  EXPECT_EQ(probe->parameters().tilt, M_PI / 2);
  Status s = configureYaml(*probe, "\ntilt: 90.5");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("params.yaml:2:7"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("FrameworkProbe/Arithmetic: tilt = 90.5: out of range; expected a "
                             "number in [0, 90] deg"),
            std::string::npos)
      << s.message();
  EXPECT_EQ(probe->parameters().tilt, M_PI / 2) << "a failed configure keeps the parameters";
  s = configureYaml(*probe, "rates: [0, 400]");
  EXPECT_NE(s.message().find("rates.1 = 400: out of range; expected a number in [-360, 360] deg/s"),
            std::string::npos)
      << s.message();
  s = configureYaml(*probe, "tilt: -1.0e-3");
  EXPECT_NE(s.message().find("tilt = -1.0e-3: out of range"), std::string::npos) << s.message();
}

TEST(Degrees, CppStructsAreSiAndKeptExactly) {
  auto probe = makeProbe();
  FrameworkProbeArithmeticParameters p;
  const double degrees = kNoDegrees / kRadiansPerDegree;
  for (double d : {std::nextafter(degrees, 0.0), degrees, std::nextafter(degrees, 360.0)})
    ASSERT_NE(d * kRadiansPerDegree, kNoDegrees) << "through degrees it would change";
  p.tilt = kNoDegrees;
  p.rates = {-0.5, M_PI};
  ASSERT_OK(probe->configure(p));
  EXPECT_EQ(probe->parameters().tilt, p.tilt);
  EXPECT_EQ(probe->parameters().rates, p.rates);
  p.tilt = M_PI / 2;  // the upper bound, 90 deg
  ASSERT_OK(probe->configure(p));
  p.tilt = 2.0;  // rad: 115 deg
  const Status s = probe->configure(p);
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("tilt = 2: out of range; expected a number in [0, "
                             "1.5707963267948966] rad"),
            std::string::npos)
      << s.message();
}

TEST(Degrees, ParametersAsYamlAreInDegrees) {
  auto probe = makeProbe();
  ASSERT_OK(configureYaml(*probe, "tilt: 30\nrates: [90, -45]"));
  const YAML::Node yaml = probe->parametersAsYaml();
  // As written: 30 * (pi/180) / (pi/180) is 29.999999999999996, which the YAML does not show.
  EXPECT_EQ(yaml["tilt"].Scalar(), "30");
  EXPECT_EQ(yaml["rates"][0].as<double>(), 90);
  EXPECT_EQ(yaml["rates"][1].as<double>(), -45);
  EXPECT_EQ(yaml["gain"].as<double>(), 2.0);
  const YAML::Node si =
      FrameworkProbeArithmeticBase::toYaml(probe->parameters(), ParameterUnits::kSi);
  EXPECT_EQ(si["tilt"].as<double>(), probe->parameters().tilt);
  auto copy = makeProbe();
  ASSERT_OK(copy->configure(yaml, "<round trip>"));
  EXPECT_EQ(copy->parameters().tilt, probe->parameters().tilt);
  EXPECT_EQ(copy->parameters().rates, probe->parameters().rates);
  // No number of degrees reads back as these radians: the nearest is written.
  EXPECT_EQ(inUnits(kNoDegrees, "deg", ParameterUnits::kYaml), kNoDegrees / kRadiansPerDegree);
  EXPECT_EQ(inUnits(kNoDegrees, "m", ParameterUnits::kYaml), kNoDegrees);
  EXPECT_EQ(inUnits(kNoDegrees, "deg", ParameterUnits::kSi), kNoDegrees);
}

/// loadDescription() on a description whose only parameter is `parameter` (flow YAML).
Status describe(const std::string& parameter) {
  const auto path = std::filesystem::temp_directory_path() / "DegreesProbe.yaml";
  std::ofstream(path) << "name: DegreesProbe\ndoc: A test description.\ninputs: []\n"
                         "outputs: []\nimplementations:\n  - name: Only\n    doc: The one.\n"
                         "    parameters:\n      - "
                      << parameter << "\n";
  Result<DfnDescription> d = loadDescription(path.string(), "test", "DegreesProbe.yaml");
  std::filesystem::remove(path);
  return d.status();
}

TEST(Degrees, DescriptionsRefuseRadiansAndDegreesOnNonReals) {
  ASSERT_OK(
      describe("{name: turn, type: double, default: 10, unit: deg, range: [0, 180], "
               "doc: d.}"));
  Status s = describe("{name: turn, type: double, default: 0.17, unit: rad, doc: d.}");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("DegreesProbe.yaml:9:"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("unit = rad: a unit in radians; expected deg (angles in YAML are "
                             "degrees; the C++ field holds rad)"),
            std::string::npos)
      << s.message();
  s = describe("{name: rate, type: double, default: 0.1, unit: rad/s, doc: d.}");
  EXPECT_NE(s.message().find("unit = rad/s: a unit in radians; expected deg/s"), std::string::npos)
      << s.message();
  s = describe("{name: steps, type: int, default: 10, unit: deg, doc: d.}");
  EXPECT_NE(s.message().find("unit = deg: degrees on the int parameter 'steps'; expected deg and "
                             "deg/s on double and double[] parameters only"),
            std::string::npos)
      << s.message();
  // Out of range defaults are reported in degrees, as written.
  s = describe("{name: turn, type: double, default: 200, unit: deg, range: [0, 180], doc: d.}");
  EXPECT_NE(s.message().find("default = 200: out of range; expected a number in [0, 180]"),
            std::string::npos)
      << s.message();
}

}  // namespace
}  // namespace cdff::dfn
