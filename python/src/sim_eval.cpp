// The simulator (cdff.sim) and the evaluation (cdff.eval) from Python: run a scenario of the
// trajectory library into an MCAP recording, as `cdff sim -o` does, and evaluate a run's
// recording against its ground truth, returning what `cdff eval --json` writes.

#include <cmath>
#include <optional>

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <nlohmann/json.hpp>

#include "cdff/egse/mcap_sink.hpp"
#include "cdff/egse/scenario.hpp"
#include "cdff/egse/simulator.hpp"
#include "cdff/eval/recording_evaluation.hpp"
#include "cdff/eval/report.hpp"
#include "common.hpp"

namespace cdff::python {
namespace {

py::object fromJson(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

py::dict runScenario(const std::string& scenario_name, const std::string& output,
                     std::optional<std::uint64_t> seed, std::optional<double> duration,
                     const std::vector<std::string>& overrides) {
  py::dict result;
  Status status;
  egse::SimulationMetadata metadata;
  {
    py::gil_scoped_release release;
    status = [&]() -> Status {
      Result<std::filesystem::path> path = egse::resolveScenario(scenario_name);
      if (!path) return path.status();
      Result<egse::Scenario> scenario = egse::loadScenario(*path, overrides);
      if (!scenario) return scenario.status();
      auto sim = egse::Simulator::create(*scenario, seed, duration);
      if (!sim) return sim.status();
      auto sink = egse::openMcapSink(output);
      if (!sink) return sink.status();
      metadata.scenario = scenario->name;
      metadata.scenario_file = path->string();
      metadata.seed = (*sim)->seed();
      metadata.duration = (*sim)->duration();
      metadata.renderer = (*sim)->rendererDescription();
      return (*sim)->run(**sink);
    }();
  }
  check(status);
  result["scenario"] = metadata.scenario;
  result["scenario_file"] = metadata.scenario_file;
  result["seed"] = metadata.seed;
  result["duration"] = metadata.duration;
  result["renderer"] = metadata.renderer;
  result["output"] = output;
  return result;
}

py::list scenarios() {
  py::list out;
  for (const egse::ScenarioInfo& s : egse::listScenarios()) {
    py::dict d;
    d["name"] = s.name;
    d["file"] = s.file.string();
    d["description"] = s.description;
    d["duration"] = s.duration;
    out.append(d);
  }
  return out;
}

eval::Statistic statisticNamed(const std::string& name) {
  if (name == "p95") return eval::Statistic::kP95;
  if (name == "max") return eval::Statistic::kMax;
  if (name == "rmse") return eval::Statistic::kRmse;
  raise(invalidParameter("cdff.eval.evaluate: statistic '{}' is not one of p95, max, rmse", name));
}

py::object evaluate(const std::vector<std::string>& paths, const std::string& statistic,
                    double max_truth_gap_s, const std::vector<std::string>& products,
                    const std::map<std::string, std::string>& pairs,
                    const std::optional<double>& focal_px, const std::string& camera) {
  eval::RecordingEvaluationOptions options;
  options.statistic = statisticNamed(statistic);
  if (!(max_truth_gap_s > 0))
    raise(
        invalidParameter("cdff.eval.evaluate: max_truth_gap_s = {}; expected a positive "
                         "number of seconds",
                         max_truth_gap_s));
  options.pose.max_truth_gap_s = max_truth_gap_s;
  options.products = products;
  options.pairs = pairs;
  if (focal_px) {
    if (!(*focal_px > 0) || !std::isfinite(*focal_px))
      raise(invalidParameter(
          "cdff.eval.evaluate: focal_px = {}; expected a positive number of pixels", *focal_px));
    options.focal_px = *focal_px;
  }
  options.camera_channel = camera;
  eval::RecordingEvaluationNotes notes;
  Result<eval::EvaluationReport> report = Status::ok();
  {
    py::gil_scoped_release release;
    report = eval::evaluateRecording(paths, options, &notes);
  }
  py::object json = fromJson(eval::toJson(take(std::move(report))));
  json["notes"] = notes.notes;
  return json;
}

}  // namespace

void bindSimAndEval(py::module_& root) {
  py::module_ sim = root.def_submodule("_sim", "The simulator (see cdff.sim).");
  sim.def("run", &runScenario, py::arg("scenario"), py::arg("output"), py::arg("seed") = py::none(),
          py::arg("duration") = py::none(), py::arg("overrides") = std::vector<std::string>{});
  sim.def("scenarios", &scenarios);
  py::module_ ev = root.def_submodule("_eval", "The evaluation (see cdff.eval).");
  ev.def("evaluate", &evaluate, py::arg("recordings"), py::arg("statistic") = "p95",
         py::arg("max_truth_gap_s") = eval::PoseEvaluationOptions{}.max_truth_gap_s,
         py::arg("products") = std::vector<std::string>{},
         py::arg("pairs") = std::map<std::string, std::string>{}, py::arg("focal_px") = py::none(),
         py::arg("camera") = std::string());
}

}  // namespace cdff::python
