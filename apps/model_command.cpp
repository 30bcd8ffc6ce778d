// cdff model info SOURCE | cdff model perturb SOURCE -o DIR [model errors]: the tracker's model
// as something other than the simulated target (model errors, docs/simulator.md). SOURCE is a
// scenario (a library name or a YAML file, with --set overrides: its target as the simulator
// builds it, named parts and face model included) or a mesh file (OBJ, PLY, STL, glTF; a PLY
// written by cdff keeps its named parts).
#include <cmath>
#include <cstdlib>
#include <memory>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/egse/model_io.hpp"
#include "cdff/egse/model_perturbation.hpp"
#include "cdff/egse/simulator.hpp"
#include "commands.hpp"
#include "model_source.hpp"

namespace cdff::app {

namespace {

struct ModelOptions {
  std::string source;
  std::vector<std::string> overrides;
  std::string output;
  std::string basename = "target";
  std::string scale_error;
  std::vector<std::string> remove_parts;
  std::vector<std::string> add_boxes;
  double max_edge = 0;
  bool retriangulate = false;
  std::size_t points = 200000;
};

Result<egse::TargetModel> loadSource(const ModelOptions& o) {
  return loadModelSource(o.source, o.overrides);
}

// Comma-separated finite numbers; `what` names the option in the error.
Result<std::vector<double>> numbers(const std::string& text, const std::string& what) {
  std::vector<double> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(v))
      return invalidParameter("{} '{}': '{}' is not a finite number", what, text, item);
    out.push_back(v);
    start = comma + 1;
  }
  return out;
}

Result<egse::ModelPerturbation> perturbation(const ModelOptions& o) {
  egse::ModelPerturbation p;
  if (!o.scale_error.empty()) {
    Result<std::vector<double>> v = numbers(o.scale_error, "--scale-error");
    if (!v) return v.status();
    if (v->size() == 1)
      p.scale_error = Eigen::Vector3d::Constant((*v)[0]);
    else if (v->size() == 3)
      p.scale_error = {(*v)[0], (*v)[1], (*v)[2]};
    else
      return invalidParameter(
          "--scale-error '{}' has {} numbers; expected 1 (every axis) or 3 (x,y,z)", o.scale_error,
          v->size());
  }
  p.remove_parts = o.remove_parts;
  for (const std::string& text : o.add_boxes) {
    const std::size_t eq = text.find('=');
    if (eq == std::string::npos || eq == 0)
      return invalidParameter("--add-box '{}': expected NAME=CX,CY,CZ,HX,HY,HZ (m)", text);
    Result<std::vector<double>> v = numbers(text.substr(eq + 1), "--add-box " + text.substr(0, eq));
    if (!v) return v.status();
    if (v->size() != 6)
      return invalidParameter(
          "--add-box '{}' has {} numbers; expected 6: the centre and the half extents (m)", text,
          v->size());
    const std::vector<double>& n = *v;
    p.add_boxes.push_back({text.substr(0, eq), {n[0], n[1], n[2]}, {n[3], n[4], n[5]}});
  }
  p.max_edge = o.max_edge;
  p.flip_diagonals = o.retriangulate;
  CDFF_RETURN_IF_ERROR(p.validate());
  return p;
}

void printSummary(const egse::TargetModel& model) {
  const Eigen::AlignedBox3d box = model.bounds();
  const Eigen::Vector3d size = box.sizes();
  fmt::print("model '{}': {} vertices, {} triangles, {} polygons, area {:.4f} m^2\n", model.name,
             model.mesh.vertices.size(), model.mesh.triangles.size(), model.polygons.size(),
             model.surfaceArea());
  fmt::print(
      "bounding box: [{:.4f}, {:.4f}] x [{:.4f}, {:.4f}] x [{:.4f}, {:.4f}] m (size {:.4f} x "
      "{:.4f} x {:.4f})\n",
      box.min().x(), box.max().x(), box.min().y(), box.max().y(), box.min().z(), box.max().z(),
      size.x(), size.y(), size.z());
  if (model.parts.empty()) {
    fmt::print("parts: none\n");
    return;
  }
  std::vector<std::size_t> triangles(model.parts.size(), 0);
  for (std::uint16_t p : model.triangle_part) ++triangles[p];
  fmt::print("parts:\n");
  for (std::size_t p = 0; p < model.parts.size(); ++p)
    fmt::print("  {:<20} {} triangles\n", model.parts[p], triangles[p]);
}

int runInfo(const ModelOptions& o) {
  Result<egse::TargetModel> model = loadSource(o);
  if (!model) {
    fmt::print(stderr, "error: {}\n", model.status().message());
    return 1;
  }
  printSummary(*model);
  return 0;
}

int runPerturb(const ModelOptions& o) {
  Result<egse::ModelPerturbation> p = perturbation(o);
  if (!p) {
    fmt::print(stderr, "error: cdff model perturb: {}\n", p.status().message());
    return 1;
  }
  Result<egse::TargetModel> model = loadSource(o);
  if (!model) {
    fmt::print(stderr, "error: {}\n", model.status().message());
    return 1;
  }
  Result<egse::TargetModel> perturbed = egse::perturbModel(*model, *p);
  if (!perturbed) {
    fmt::print(stderr, "error: cdff model perturb {}: {}\n", o.source,
               perturbed.status().message());
    return 1;
  }
  auto files = egse::exportModel(*perturbed, o.output, o.basename, o.points);
  if (!files) {
    fmt::print(stderr, "error: {}\n", files.status().message());
    return 1;
  }
  printSummary(*perturbed);
  for (const auto& f :
       {files->obj, files->mtl, files->ply, files->points_ply, files->cao, files->edges})
    fmt::print("wrote {}\n", f.string());
  return 0;
}

void addSource(CLI::App* command, ModelOptions& o) {
  command
      ->add_option("SOURCE", o.source,
                   "A scenario (library name or YAML file: its target) or a mesh file (OBJ, PLY, "
                   "STL, glTF)")
      ->required();
  command->add_option("--set", o.overrides,
                      "Override a scenario key (as cdff sim --set), e.g. "
                      "target.procedural.kind=hexagonal");
}

}  // namespace

void addModelCommands(CLI::App& root, int& exit_code) {
  CLI::App* model = root.add_subcommand(
      "model", "Target models: their parts and sizes, and model errors for the trackers");
  model->require_subcommand(1);
  auto options = std::make_shared<ModelOptions>();

  CLI::App* info = model->add_subcommand("info", "Print a model's size, area and named parts");
  addSource(info, *options);
  info->callback([options, &exit_code] { exit_code = runInfo(*options); });

  CLI::App* perturb = model->add_subcommand(
      "perturb",
      "Write a model that differs from SOURCE (scaled, a part removed or added, re-triangulated) "
      "in every format the DFPCs load");
  addSource(perturb, *options);
  perturb->add_option("-o,--output", options->output, "The directory to write")->required();
  perturb->add_option("--name", options->basename, "The files' base name (default: target)");
  perturb->add_option("--scale-error", options->scale_error,
                      "Relative dimension error: E (every axis) or EX,EY,EZ; 0.01: 1 % larger");
  perturb->add_option("--remove-part", options->remove_parts,
                      "Drop a named part (repeatable; `cdff model info SOURCE` lists them)");
  perturb->add_option("--add-box", options->add_boxes,
                      "Add a box part: NAME=CX,CY,CZ,HX,HY,HZ (centre, half extents, m; "
                      "repeatable)");
  perturb->add_flag("--retriangulate", options->retriangulate,
                    "Re-triangulate: flip the diagonal of every planar convex quad of two "
                    "triangles");
  perturb->add_option("--max-edge", options->max_edge,
                      "Re-triangulate: split every edge longer than this (m) until none is");
  perturb->add_option("--points", options->points,
                      "Points in the dense point cloud export (default 200000)");
  perturb->callback([options, &exit_code] { exit_code = runPerturb(*options); });
}

}  // namespace cdff::app
