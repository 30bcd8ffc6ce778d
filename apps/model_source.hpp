#pragma once
// A target model named on the command line: a mesh file, or a scenario whose target the
// simulator builds (cdff model, cdff train).
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

#include "cdff/egse/model_io.hpp"
#include "cdff/egse/simulator.hpp"

namespace cdff::app {

inline bool isMeshFile(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".obj" || ext == ".ply" || ext == ".stl" || ext == ".gltf" || ext == ".glb";
}

/// The model of `source`: a mesh file (OBJ, PLY, STL, glTF), or a scenario (library name or
/// YAML file, with `overrides`) whose target the simulator builds.
inline Result<egse::TargetModel> loadModelSource(const std::string& source,
                                                 const std::vector<std::string>& overrides) {
  if (isMeshFile(source)) {
    if (!overrides.empty())
      return invalidParameter("--set applies to a scenario, not to the mesh file '{}'", source);
    return egse::loadModel(source);
  }
  Result<std::filesystem::path> path = egse::resolveScenario(source);
  if (!path) return path.status();
  Result<egse::Scenario> scenario = egse::loadScenario(*path, overrides);
  if (!scenario) return scenario.status();
  return egse::makeScenarioTarget(*scenario);
}

}  // namespace cdff::app
