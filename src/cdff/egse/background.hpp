#pragma once
// What lies behind the spacecraft: stars, the sun's disc, the Earth with its limb.
//
// Brightness uses the renderer's unit (a white Lambertian plate facing the sun = 1.0 per pixel),
// so a point source of irradiance E spreads E / E_sun * pi / Omega_pixel over its image, with
// Omega_pixel = 1 / (fx fy) for a pinhole canvas. With exposures set for a sunlit target this
// makes stars as faint as they are in real rendezvous imagery (a magnitude-0 star reaches about
// 1e-4 of a white plate behind a 6 mm lens); `star_gain` can brighten them for visual checks.

#include <vector>

#include <Eigen/Core>

#include "cdff/egse/render.hpp"

namespace cdff::egse {

struct Star {
  Eigen::Vector3d direction;                         // unit, eci
  double magnitude = 0;                              // visual
  Eigen::Vector3f colour = Eigen::Vector3f::Ones();  // relative, mean 1
};

/// A fixed synthetic catalogue (same stars in every run): uniform on the sphere, magnitudes
/// -1.5 to 6.5 distributed like the real sky's counts (about 10^(0.5 m)).
const std::vector<Star>& starCatalogue();

struct BackgroundView {
  Eigen::Matrix3d lvlh_R_camera = Eigen::Matrix3d::Identity();
  Eigen::Vector3d camera_position = Eigen::Vector3d::Zero();  // lvlh
  Eigen::Matrix3d eci_R_lvlh = Eigen::Matrix3d::Identity();
  Eigen::Vector3d sun_direction = Eigen::Vector3d::UnitY();  // lvlh, unit
  double sun_irradiance = 1.0;                               // 0 when the camera is in eclipse
  bool earth = false;
  Eigen::Vector3d earth_centre = Eigen::Vector3d::Zero();  // lvlh
  double earth_radius = 6378137.0;
  bool stars = true;
  double star_gain = 1.0;
  double star_psf_sigma = 0.7;  // pixels
  bool sun_disc = true;
};

/// Adds the background to the pixels of `frame` with id 0 (nothing rendered there), on the
/// pinhole canvas `camera`.
void compositeBackground(const PinholeCamera& camera, const BackgroundView& view,
                         RenderOutput& frame);

/// Angular radius of the sun seen from 1 AU (rad).
constexpr double kSunAngularRadius = 0.004652;

}  // namespace cdff::egse
