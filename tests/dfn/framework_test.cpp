// The DFN framework: parameters from YAML, input checks, error handling, diagnostics.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "FrameworkProbe.gen.hpp"
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

TEST(Parameters, DefaultsComeFromTheDescription) {
  auto probe = makeProbe();
  ASSERT_OK(probe->configureDefaults());
  const auto& p = probe->parameters();
  EXPECT_EQ(p.gain, 2.0);
  EXPECT_EQ(p.iterations, 1);
  EXPECT_EQ(p.mode, "multiply");
  EXPECT_TRUE(p.enabled);
  EXPECT_EQ(p.offsets, (std::vector<double>{0, 0, 0}));
}

TEST(Parameters, YamlValuesOfEveryKindAreApplied) {
  auto probe = makeProbe();
  ASSERT_OK(configureYaml(
      *probe, "gain: 3\niterations: 2\nmode: add\nenabled: false\noffsets: [0.5, -1, 1]"));
  const auto& p = probe->parameters();
  EXPECT_EQ(p.gain, 3.0);
  EXPECT_EQ(p.iterations, 2);
  EXPECT_EQ(p.mode, "add");
  EXPECT_FALSE(p.enabled);
  EXPECT_EQ(p.offsets, (std::vector<double>{0.5, -1, 1}));
}

TEST(Parameters, UnknownKeyNamesFileLineKeyAndSuggestion) {
  auto probe = makeProbe();
  Status s = configureYaml(*probe, "gain: 1\ngian: 2\n");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("params.yaml:2:1"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("gian: unknown key; expected one of"), std::string::npos)
      << s.message();
  EXPECT_NE(s.message().find(
                "{gain, iterations, mode, enabled, offsets, tilt, rates} (did you mean 'gain'?)"),
            std::string::npos)
      << s.message();
}

TEST(Parameters, WrongTypeNamesKeyValueAndExpectation) {
  auto probe = makeProbe();
  Status s = configureYaml(*probe, "iterations: 2.5");
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("iterations = 2.5: not an integer; expected an integer in [1, 100]"),
            std::string::npos)
      << s.message();
  s = configureYaml(*probe, "gain: fast");
  EXPECT_NE(s.message().find("gain = fast: not a number; expected a number in [0, 10]"),
            std::string::npos)
      << s.message();
  s = configureYaml(*probe, "enabled: maybe");
  EXPECT_NE(s.message().find("enabled = maybe: not a bool; expected true or false"),
            std::string::npos)
      << s.message();
  s = configureYaml(*probe, "offsets: 3");
  EXPECT_NE(s.message().find("offsets = 3: not a list; expected a list of 3 numbers"),
            std::string::npos)
      << s.message();
  s = configureYaml(*probe, "gain: [1, 2]");
  EXPECT_NE(s.message().find("gain = [1, 2]: a list, not a number"), std::string::npos)
      << s.message();
  s = configureYaml(*probe, "- 1\n- 2");
  EXPECT_NE(s.message().find("[1, 2]: parameters are a list; expected a map"), std::string::npos)
      << s.message();
}

TEST(Parameters, OutOfRangeValuesNameTheAcceptedRange) {
  auto probe = makeProbe();
  Status s = configureYaml(*probe, "\n\ngain: 11");
  EXPECT_NE(s.message().find("params.yaml:3:7"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("gain = 11: out of range; expected a number in [0, 10]"),
            std::string::npos)
      << s.message();
  s = configureYaml(*probe, "gain: .nan");
  EXPECT_NE(s.message().find("gain = .nan: not a finite number"), std::string::npos) << s.message();
  s = configureYaml(*probe, "mode: divide");
  EXPECT_NE(s.message().find("expected one of {multiply, add}"), std::string::npos) << s.message();
  s = configureYaml(*probe, "offsets: [0, 0]");
  EXPECT_NE(s.message().find("offsets = [0, 0]: has 2 values; expected a list of 3 numbers"),
            std::string::npos)
      << s.message();
  s = configureYaml(*probe, "offsets: [0, 2, 0]");
  EXPECT_NE(s.message().find("offsets.1 = 2: out of range; expected a number in [-1, 1]"),
            std::string::npos)
      << s.message();
}

TEST(Parameters, AFailedConfigureKeepsThePreviousParameters) {
  auto probe = makeProbe();
  ASSERT_OK(configureYaml(*probe, "gain: 4"));
  EXPECT_FALSE(configureYaml(*probe, "gain: 5\niterations: 0").isOk());
  EXPECT_EQ(probe->parameters().gain, 4.0);
  EXPECT_FALSE(probe->isConfigured());
}

TEST(Parameters, CppStructsAreCheckedLikeYaml) {
  auto probe = makeProbe();
  FrameworkProbeArithmeticParameters p;
  p.gain = 5;
  p.offsets = {0.1, 0.2, 0.3};
  ASSERT_OK(probe->configure(p));
  EXPECT_EQ(probe->parameters().gain, 5.0);
  EXPECT_EQ(probe->parameters().offsets[2], 0.3);
  p.gain = -1;
  Status s = probe->configure(p);
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find("gain = -1: out of range"), std::string::npos) << s.message();
}

TEST(Parameters, FilesReportMissingFilesAndSyntaxErrorsWithLocation) {
  auto probe = makeProbe();
  Status s = probe->configureFromFile("/nonexistent/params.yaml");
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_NE(s.message().find("/nonexistent/params.yaml"), std::string::npos);

  const auto path = std::filesystem::temp_directory_path() / "cdff_probe_bad.yaml";
  std::ofstream(path) << "gain: 1\nmode: [add\n";
  s = probe->configureFromFile(path.string());
  EXPECT_EQ(s.code(), StatusCode::kInvalidParameter);
  EXPECT_NE(s.message().find(path.string() + ":"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("YAML syntax error"), std::string::npos) << s.message();

  std::ofstream(path) << "gain: 1\n\niterations: 500\n";
  s = probe->configureFromFile(path.string());
  EXPECT_NE(s.message().find(path.string() + ":3:"), std::string::npos) << s.message();
  std::filesystem::remove(path);
}

TEST(Process, ComputesFromInputsAndParameters) {
  auto probe = makeProbe();
  ASSERT_OK(configureYaml(*probe, "gain: 3\niterations: 2\noffsets: [0.5, 0, 0]"));
  probe->in.value.set(2.0);
  ASSERT_OK(probe->process());
  EXPECT_DOUBLE_EQ(*probe->out.result, 2.0 * 9 + 0.5);
  probe->in.scale.set(10.0);
  ASSERT_OK(probe->process());
  EXPECT_DOUBLE_EQ(*probe->out.result, 2.0 * 9 * 10 + 0.5);
  EXPECT_EQ(*probe->out.calls, 2);
}

TEST(Process, UnconfiguredNodeUsesDefaults) {
  auto probe = makeProbe();
  probe->in.value.set(1.5);
  ASSERT_OK(probe->process());
  EXPECT_DOUBLE_EQ(*probe->out.result, 3.0);
}

TEST(Process, MissingRequiredInputIsAnErrorNamingThePort) {
  auto probe = makeProbe();
  probe->in.scale.set(2.0);
  Status s = probe->process();
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("required input 'value' (Double) is not set"), std::string::npos)
      << s.message();
}

TEST(Process, AFailedCallLeavesOutputsUntouched) {
  auto probe = makeProbe();
  probe->in.value.set(1.0);
  ASSERT_OK(probe->process());
  const double* before = probe->out.result.get();
  probe->in.value.set(-1.0);
  Status s = probe->process();
  EXPECT_EQ(s.code(), StatusCode::kNumericalFailure);
  EXPECT_NE(s.message().find("FrameworkProbe/Arithmetic: value -1 is negative"), std::string::npos)
      << s.message();
  EXPECT_EQ(probe->out.result.get(), before);
  EXPECT_DOUBLE_EQ(*probe->out.result, 2.0);
}

TEST(Process, ExceptionsBecomeInternalErrors) {
  auto probe = makeProbe();
  probe->in.value.set(13.0);
  Status s = probe->process();
  EXPECT_EQ(s.code(), StatusCode::kInternal);
  EXPECT_NE(s.message().find("unlucky value"), std::string::npos) << s.message();
  EXPECT_FALSE(probe->out.result.hasValue());
}

TEST(Process, InputsAreFreshUntilProcessed) {
  auto probe = makeProbe();
  EXPECT_FALSE(probe->in.value.isFresh());
  probe->in.value.set(1.0);
  EXPECT_TRUE(probe->in.value.isFresh());
  ASSERT_OK(probe->process());
  EXPECT_FALSE(probe->in.value.isFresh());
  EXPECT_TRUE(probe->in.value.hasValue());  // the value stays for the next call
}

TEST(Diagnostics, CountCallsErrorsWarningsAndTime) {
  auto probe = makeProbe();
  probe->setName("probe_1");
  probe->in.value.set(200.0);
  ASSERT_OK(probe->process());
  probe->in.value.set(-5.0);
  EXPECT_FALSE(probe->process().isOk());
  probe->in.value.set(1.0);
  ASSERT_OK(probe->process());

  const Diagnostics& d = probe->diagnostics();
  EXPECT_EQ(d.call_count, 3u);
  EXPECT_EQ(d.error_count, 1u);
  EXPECT_EQ(d.warning_count, 1u);
  ASSERT_EQ(d.warnings.size(), 1u);
  EXPECT_EQ(d.warnings.front(), "value above 100");
  EXPECT_TRUE(d.last_status.isOk());
  EXPECT_NE(d.last_error.find("probe_1: value -5 is negative"), std::string::npos) << d.last_error;
  EXPECT_GT(d.total_wall_s, 0.0);
  EXPECT_GE(d.max_wall_s, d.last_wall_s);
  EXPECT_GE(d.total_cpu_s, 0.0);
}

TEST(Ports, TypeErasedAccessChecksTheType) {
  auto probe = makeProbe();
  InputPortBase* value = probe->findInput("value");
  ASSERT_NE(value, nullptr);
  EXPECT_EQ(value->type().name(), "Double");
  Status s = value->setAny(Value::of(3));
  EXPECT_EQ(s.code(), StatusCode::kInvalidInput);
  EXPECT_NE(s.message().find("port 'value' has type Double; got a value of type Int"),
            std::string::npos)
      << s.message();
  ASSERT_OK(value->setAny(Value::of(4.0)));
  EXPECT_TRUE(value->isFresh());
  ASSERT_OK(probe->process());
  EXPECT_DOUBLE_EQ(*probe->out.result, 8.0);
  EXPECT_EQ(probe->findInput("nope"), nullptr);
  EXPECT_NE(probe->findOutput("calls"), nullptr);
}

TEST(Registry, UnknownNamesListTheKnownOnes) {
  auto r = Registry::instance().create("NoSuchDfn", "X");
  EXPECT_EQ(r.status().code(), StatusCode::kNotFound);
  EXPECT_NE(r.status().message().find("FrameworkProbe"), std::string::npos);
  r = Registry::instance().create("FrameworkProbe", "Quantum");
  EXPECT_NE(r.status().message().find("expected one of {Arithmetic}"), std::string::npos)
      << r.status().message();
}

TEST(Registry, CreateAsRefusesAClassTheInstanceIsNot) {
  auto typed = Registry::instance().createAs<FrameworkProbe>("FrameworkProbe", "Arithmetic");
  ASSERT_TRUE(typed.isOk()) << typed.status().toString();
  EXPECT_EQ(typed.value()->name(), "FrameworkProbe/Arithmetic");
  struct Unrelated : Node {};
  auto wrong = Registry::instance().createAs<Unrelated>("FrameworkProbe", "Arithmetic");
  EXPECT_FALSE(wrong.isOk());
  EXPECT_NE(wrong.status().message().find("not an instance"), std::string::npos)
      << wrong.status().message();
}

}  // namespace
}  // namespace cdff::dfn
