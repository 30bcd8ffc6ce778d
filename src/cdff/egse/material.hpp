#pragma once
// Surface materials of simulated spacecraft: what the cameras, LIDAR and ToF see.
//
// Reflectance is expressed as a reflectance factor: a white Lambertian surface facing the sun
// renders with radiance 1.0 (before exposure). Speculars use a normalised Blinn-Phong lobe, so
// that a shiny surface keeps its energy and a highlight on solar-cell glass or MLI can exceed the
// diffuse white by an order of magnitude (which is what saturates real cameras).

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace cdff::egse {

/// A procedural surface pattern evaluated in the shader (both renderers).
enum class SurfacePattern : std::uint8_t {
  kNone = 0,
  kCrinkle = 1,    // multi-layer insulation: faceted wrinkles that scatter speculars
  kSolarCell = 2,  // a grid of dark cells with bright interconnects
};

struct Material {
  std::string name;
  Eigen::Vector3f diffuse = Eigen::Vector3f::Constant(0.5f);   // linear RGB albedo
  Eigen::Vector3f specular = Eigen::Vector3f::Constant(0.0f);  // specular reflectance
  float shininess = 1.0f;                                      // Blinn-Phong exponent
  SurfacePattern pattern = SurfacePattern::kNone;
  float pattern_strength = 0.0f;  // crinkle: facet tilt (rad); cells: interconnect albedo boost
  float pattern_scale = 0.05f;    // m: crinkle facet size, or solar cell pitch
  float lidar_reflectivity =
      0.5f;  // diffuse reflectance at 905 nm (LIDAR intensity, ToF amplitude)
};

/// The built-in materials; their indices are MaterialId values.
enum class MaterialId : std::uint8_t {
  kMliGold = 0,
  kMliSilver,
  kSolarCell,
  kPanelBack,
  kRadiator,
  kAdapterRing,
  kStructure,
  kAntenna,
  kThruster,
  kServicerBody,
  kCount,
};

/// The built-in material table, indexed by MaterialId.
const std::vector<Material>& builtinMaterials();
const Material& builtinMaterial(MaterialId id);
/// The built-in material called `name` (e.g. "mli_gold"), if any.
std::optional<MaterialId> builtinMaterialByName(const std::string& name);

}  // namespace cdff::egse
