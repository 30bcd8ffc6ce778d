#include "cdff/egse/material.hpp"

namespace cdff::egse {

namespace {

Material make(std::string name, Eigen::Vector3f diffuse, Eigen::Vector3f specular, float shininess,
              SurfacePattern pattern, float strength, float scale, float lidar) {
  Material m;
  m.name = std::move(name);
  m.diffuse = diffuse;
  m.specular = specular;
  m.shininess = shininess;
  m.pattern = pattern;
  m.pattern_strength = strength;
  m.pattern_scale = scale;
  m.lidar_reflectivity = lidar;
  return m;
}

std::vector<Material> makeTable() {
  using V = Eigen::Vector3f;
  std::vector<Material> t(static_cast<std::size_t>(MaterialId::kCount));
  auto set = [&](MaterialId id, Material m) { t[static_cast<std::size_t>(id)] = std::move(m); };
  // Gold (aluminised Kapton) MLI: a warm, wrinkled, strongly specular foil.
  set(MaterialId::kMliGold, make("mli_gold", V(0.30f, 0.20f, 0.06f), V(0.75f, 0.56f, 0.26f), 60.0f,
                                 SurfacePattern::kCrinkle, 0.12f, 0.02f, 0.55f));
  set(MaterialId::kMliSilver, make("mli_silver", V(0.22f, 0.22f, 0.23f), V(0.75f, 0.75f, 0.77f),
                                   60.0f, SurfacePattern::kCrinkle, 0.12f, 0.02f, 0.6f));
  // Solar cells: dark blue under cover glass, a sharp glass highlight, silver interconnects.
  set(MaterialId::kSolarCell, make("solar_cell", V(0.025f, 0.035f, 0.09f), V(0.30f, 0.30f, 0.32f),
                                   600.0f, SurfacePattern::kSolarCell, 0.35f, 0.04f, 0.12f));
  set(MaterialId::kPanelBack, make("panel_back", V(0.10f, 0.10f, 0.11f), V(0.08f, 0.08f, 0.08f),
                                   20.0f, SurfacePattern::kNone, 0.0f, 0.05f, 0.15f));
  // White radiator (optical solar reflector tiles): bright and mirror-like.
  set(MaterialId::kRadiator, make("radiator", V(0.78f, 0.78f, 0.80f), V(0.25f, 0.25f, 0.25f),
                                  250.0f, SurfacePattern::kNone, 0.0f, 0.05f, 0.8f));
  // Black anodised launch adapter ring.
  set(MaterialId::kAdapterRing,
      make("adapter_ring", V(0.06f, 0.06f, 0.065f), V(0.25f, 0.25f, 0.25f), 35.0f,
           SurfacePattern::kNone, 0.0f, 0.05f, 0.1f));
  set(MaterialId::kStructure, make("structure", V(0.35f, 0.35f, 0.36f), V(0.45f, 0.45f, 0.45f),
                                   40.0f, SurfacePattern::kNone, 0.0f, 0.05f, 0.5f));
  set(MaterialId::kAntenna, make("antenna", V(0.72f, 0.72f, 0.70f), V(0.04f, 0.04f, 0.04f), 10.0f,
                                 SurfacePattern::kNone, 0.0f, 0.05f, 0.75f));
  set(MaterialId::kThruster, make("thruster", V(0.20f, 0.19f, 0.18f), V(0.55f, 0.52f, 0.50f), 60.0f,
                                  SurfacePattern::kNone, 0.0f, 0.05f, 0.3f));
  set(MaterialId::kServicerBody,
      make("servicer_body", V(0.50f, 0.50f, 0.52f), V(0.60f, 0.60f, 0.62f), 100.0f,
           SurfacePattern::kCrinkle, 0.18f, 0.04f, 0.6f));
  return t;
}

}  // namespace

const std::vector<Material>& builtinMaterials() {
  static const std::vector<Material> table = makeTable();
  return table;
}

const Material& builtinMaterial(MaterialId id) {
  return builtinMaterials()[static_cast<std::size_t>(id)];
}

std::optional<MaterialId> builtinMaterialByName(const std::string& name) {
  const auto& table = builtinMaterials();
  for (std::size_t i = 0; i < table.size(); ++i)
    if (table[i].name == name) return static_cast<MaterialId>(i);
  return std::nullopt;
}

}  // namespace cdff::egse
