#include "cdff/egse/background.hpp"

#include <cmath>

#include "cdff/egse/orbit.hpp"
#include "cdff/egse/rng.hpp"

namespace cdff::egse {

namespace {

// Value noise on a hashed integer lattice, smoothly interpolated: the procedural Earth.
double latticeValue(int x, int y, int z, std::uint64_t seed) {
  const std::uint64_t h =
      mix64(seed ^ mix64(static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ULL ^
                         static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4FULL ^
                         static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ULL));
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

double valueNoise(const Eigen::Vector3d& p, std::uint64_t seed) {
  const Eigen::Vector3d f = p.array().floor();
  const int x = static_cast<int>(f.x()), y = static_cast<int>(f.y()), z = static_cast<int>(f.z());
  Eigen::Vector3d t = p - f;
  t = t.array() * t.array() * (3.0 - 2.0 * t.array());
  double c[2][2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k) c[i][j][k] = latticeValue(x + i, y + j, z + k, seed);
  auto lerp = [](double a, double b, double s) { return a + (b - a) * s; };
  return lerp(lerp(lerp(c[0][0][0], c[1][0][0], t.x()), lerp(c[0][1][0], c[1][1][0], t.x()), t.y()),
              lerp(lerp(c[0][0][1], c[1][0][1], t.x()), lerp(c[0][1][1], c[1][1][1], t.x()), t.y()),
              t.z());
}

double fbm(const Eigen::Vector3d& p, std::uint64_t seed) {
  double sum = 0, amplitude = 0.5, norm = 0;
  Eigen::Vector3d q = p;
  for (int octave = 0; octave < 5; ++octave) {
    sum += amplitude * valueNoise(q, seed + octave);
    norm += amplitude;
    amplitude *= 0.5;
    q *= 2.03;
  }
  return sum / norm;
}

// Albedo of the procedural Earth on an equirectangular grid (eci-fixed; the Earth's rotation
// is not modelled): oceans, land, clouds.
struct EarthTexture {
  static constexpr int kWidth = 1024, kHeight = 512;
  // Ground detail below the 40 km texels: a tileable noise repeated every 1/64 of the globe's
  // circumference (~600 m per detail texel) that modulates the albedo.
  static constexpr int kDetail = 256, kDetailRepeat = 64;
  std::vector<Eigen::Vector3f> albedo;
  std::vector<float> detail;
  EarthTexture() : albedo(static_cast<std::size_t>(kWidth) * kHeight), detail(kDetail * kDetail) {
    for (int j = 0; j < kDetail; ++j)
      for (int i = 0; i < kDetail; ++i) {
        // Periodic: sample the noise on a torus embedded in 4-D, folded into 3-D by two circles.
        const double a = 2 * M_PI * i / kDetail, b = 2 * M_PI * j / kDetail;
        const Eigen::Vector3d p(3.0 * std::cos(a), 3.0 * std::sin(a) + 2.0 * std::cos(b),
                                2.0 * std::sin(b));
        detail[static_cast<std::size_t>(j) * kDetail + i] =
            static_cast<float>(0.55 + 0.9 * (fbm(p * 2.0, 31) - 0.5) * 2.0);
      }
    const Eigen::Vector3f ocean(0.02f, 0.05f, 0.12f), land(0.14f, 0.12f, 0.07f),
        ice(0.7f, 0.72f, 0.75f), cloud(0.78f, 0.78f, 0.80f);
    for (int j = 0; j < kHeight; ++j) {
      const double lat = M_PI * (0.5 - (j + 0.5) / kHeight);
      for (int i = 0; i < kWidth; ++i) {
        const double lon = 2 * M_PI * ((i + 0.5) / kWidth) - M_PI;
        const Eigen::Vector3d n(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon),
                                std::sin(lat));
        const double continents = fbm(n * 2.2, 11);
        const double clouds = fbm(n * 5.0 + Eigen::Vector3d(7.1, 3.3, 1.7), 23);
        Eigen::Vector3f a = continents > 0.52 ? land : ocean;
        if (std::abs(lat) > 1.2) a = ice;
        // About half the Earth is under cloud: its mean albedo is then near the real 0.3.
        const float cover = static_cast<float>(std::clamp((clouds - 0.47) * 5.0, 0.0, 1.0));
        albedo[static_cast<std::size_t>(j) * kWidth + i] = a * (1 - cover) + cloud * cover;
      }
    }
  }
  // Bilinear between texel centres (wrapping in longitude).
  Eigen::Vector3f at(const Eigen::Vector3d& n) const {
    const double lat = std::asin(std::clamp(n.z(), -1.0, 1.0)), lon = std::atan2(n.y(), n.x());
    const double u = (lon + M_PI) / (2 * M_PI) * kWidth - 0.5,
                 v = std::clamp((0.5 - lat / M_PI) * kHeight - 0.5, 0.0, kHeight - 1.0);
    const int i0 = static_cast<int>(std::floor(u)), j0 = std::min(static_cast<int>(v), kHeight - 2);
    const float fu = static_cast<float>(u - i0), fv = static_cast<float>(v - j0);
    auto texel = [&](int i, int j) -> const Eigen::Vector3f& {
      return albedo[static_cast<std::size_t>(j) * kWidth + ((i % kWidth) + kWidth) % kWidth];
    };
    const Eigen::Vector3f coarse = (1 - fv) * ((1 - fu) * texel(i0, j0) + fu * texel(i0 + 1, j0)) +
                                   fv * ((1 - fu) * texel(i0, j0 + 1) + fu * texel(i0 + 1, j0 + 1));
    const int di =
        static_cast<int>(std::floor(u / kWidth * kDetail * kDetailRepeat)) & (kDetail - 1);
    const int dj =
        static_cast<int>(std::floor(v / kHeight * kDetail * kDetailRepeat / 2)) & (kDetail - 1);
    return coarse * std::max(0.2f, 0.4f + detail[static_cast<std::size_t>(dj) * kDetail + di]);
  }
};

const EarthTexture& earthTexture() {
  static const EarthTexture texture;
  return texture;
}

}  // namespace

const std::vector<Star>& starCatalogue() {
  static const std::vector<Star> stars = [] {
    Rng rng(0x5354415253ULL);  // fixed: the same sky in every run
    std::vector<Star> out;
    const double lo = std::pow(10.0, 0.5 * -1.5), hi = std::pow(10.0, 0.5 * 6.5);
    for (int i = 0; i < 6000; ++i) {
      Star s;
      const double z = rng.uniform(-1.0, 1.0), phi = rng.uniform(0.0, 2 * M_PI);
      const double r = std::sqrt(1 - z * z);
      s.direction = {r * std::cos(phi), r * std::sin(phi), z};
      s.magnitude = std::log10(lo + rng.uniform() * (hi - lo)) / 0.5;
      // A colour between blue-white and orange.
      const float warmth = static_cast<float>(rng.uniform());
      s.colour = Eigen::Vector3f(0.8f + 0.4f * warmth, 1.0f, 1.2f - 0.4f * warmth);
      s.colour /= s.colour.mean();
      out.push_back(s);
    }
    return out;
  }();
  return stars;
}

namespace {

// Where rays from the camera meet the Earth's sphere (lvlh frame).
struct EarthSphere {
  Eigen::Vector3d oc;  // camera position from the Earth's centre
  double oc2, R2;

  explicit EarthSphere(const BackgroundView& view)
      : oc(view.camera_position - view.earth_centre),
        oc2(oc.squaredNorm()),
        R2(view.earth_radius * view.earth_radius) {}

  // True when the ray along d_lvlh (unit) hits the Earth in front of the camera, t metres away.
  bool hit(const Eigen::Vector3d& d_lvlh, double& t) const {
    const double b = d_lvlh.dot(oc);
    const double disc = b * b - (oc2 - R2);
    if (disc < 0) return false;
    t = -b - std::sqrt(disc);
    return t > 0;
  }
};

// The Earth and its limb, where something could be visible.
void compositeEarth(const PinholeCamera& cam, const BackgroundView& view, const EarthSphere& earth,
                    RenderOutput& frame) {
  const int W = cam.width, H = cam.height;
  const Eigen::Matrix3d R = view.lvlh_R_camera;
  const Eigen::Vector3d& oc = earth.oc;
  const double oc2 = earth.oc2;
  auto ray = [&](double u, double v) {
    return Eigen::Vector3d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0).normalized();
  };
  const Eigen::Vector3d to_earth = (-oc).normalized();
  const double earth_angle = std::asin(std::min(1.0, view.earth_radius / std::sqrt(oc2)));
  const Eigen::Vector3d boresight = R.col(2);
  const double half_diagonal = std::atan(
      std::hypot(std::max(cam.cx, W - cam.cx) / cam.fx, std::max(cam.cy, H - cam.cy) / cam.fy));
  if (!(std::acos(std::clamp(boresight.dot(to_earth), -1.0, 1.0)) <
        earth_angle + half_diagonal + 0.05))
    return;
  const EarthTexture& texture = earthTexture();
  const Eigen::Vector3d sun = view.sun_direction;
  const Eigen::Vector3f limb_colour(0.10f, 0.18f, 0.38f);
  const double scale_height = 8000.0;
  // A cheap cone test first: only rays within the Earth's angular radius (plus the limb) of
  // its centre can see it.
  const double cone = std::cos(std::min(
      M_PI,
      std::asin(std::min(1.0, (view.earth_radius + 10 * scale_height) / std::sqrt(oc2))) + 0.01));
  const Eigen::Matrix3f Rf = R.cast<float>();
  const Eigen::Vector3f ef = to_earth.cast<float>();
  const float cone2 = static_cast<float>(cone * cone);
  const bool wide = cone <= 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * W + x;
      if (frame.id[i] != 0) continue;
      const Eigen::Vector3f df =
          Rf * Eigen::Vector3f(static_cast<float>((x - cam.cx) / cam.fx),
                               static_cast<float>((y - cam.cy) / cam.fy), 1.0f);
      const float de = df.dot(ef);
      if (!wide && (de <= 0 || de * de < cone2 * df.squaredNorm())) continue;
      const Eigen::Vector3d d = R * ray(x, y);
      double t;
      Eigen::Vector3f colour = Eigen::Vector3f::Zero();
      if (earth.hit(d, t)) {
        const Eigen::Vector3d n = (oc + t * d) / view.earth_radius;
        const double lit = std::max(0.0, n.dot(sun));
        if (lit > 0)
          colour = texture.at(view.eci_R_lvlh * n) * static_cast<float>(lit * view.sun_irradiance);
        frame.id[i] = 254;  // the Earth: stars are hidden behind it
      } else {
        // The limb: an exponential atmosphere along the ray's closest approach.
        const double b = d.dot(oc);
        if (b < 0) {
          const double closest = std::sqrt(std::max(0.0, oc2 - b * b));
          const double h = closest - view.earth_radius;
          if (h < 10 * scale_height) {
            const Eigen::Vector3d n = (oc - b * d).normalized();
            const double lit = std::max(0.0, n.dot(sun) + 0.15);
            colour = limb_colour *
                     static_cast<float>(std::exp(-h / scale_height) * lit * view.sun_irradiance);
          }
        }
      }
      frame.radiance[3 * i] += colour.x();
      frame.radiance[3 * i + 1] += colour.y();
      frame.radiance[3 * i + 2] += colour.z();
    }
}

// Splats a point source in direction d_camera with a Gaussian PSF of `sigma` pixels (out to
// `reach` pixels) onto pixels that see empty sky.
void splatPointSource(const PinholeCamera& cam, double sigma, int reach,
                      const Eigen::Vector3d& d_camera, const Eigen::Vector3f& value,
                      RenderOutput& frame) {
  const int W = cam.width, H = cam.height;
  if (d_camera.z() <= 0) return;
  const double u = cam.fx * d_camera.x() / d_camera.z() + cam.cx;
  const double v = cam.fy * d_camera.y() / d_camera.z() + cam.cy;
  if (u < -reach || v < -reach || u > W + reach || v > H + reach) return;
  const int u0 = static_cast<int>(std::floor(u)), v0 = static_cast<int>(std::floor(v));
  double weights[16][16];
  double total = 0;
  const int span = 2 * reach + 1;
  for (int j = 0; j < span && j < 16; ++j)
    for (int k = 0; k < span && k < 16; ++k) {
      const double dx = u0 - reach + k - u, dy = v0 - reach + j - v;
      weights[j][k] = std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma));
      total += weights[j][k];
    }
  for (int j = 0; j < span && j < 16; ++j)
    for (int k = 0; k < span && k < 16; ++k) {
      const int x = u0 - reach + k, y = v0 - reach + j;
      if (x < 0 || y < 0 || x >= W || y >= H) continue;
      const std::size_t i = static_cast<std::size_t>(y) * W + x;
      if (frame.id[i] != 0) continue;
      const float w = static_cast<float>(weights[j][k] / total);
      frame.radiance[3 * i] += w * value.x();
      frame.radiance[3 * i + 1] += w * value.y();
      frame.radiance[3 * i + 2] += w * value.z();
    }
}

// The stars not hidden by the Earth, as point sources.
void compositeStars(const PinholeCamera& cam, const BackgroundView& view, const EarthSphere& earth,
                    RenderOutput& frame) {
  const Eigen::Matrix3d R = view.lvlh_R_camera;
  const Eigen::Matrix3d camera_R_lvlh = R.transpose();
  // Pixel solid angle at the canvas centre; the unit of point sources.
  const double point_scale = M_PI * cam.fx * cam.fy;
  const double sigma = std::max(0.3, view.star_psf_sigma);
  const int reach = static_cast<int>(std::ceil(3 * sigma));
  const Eigen::Matrix3d camera_R_eci = camera_R_lvlh * view.eci_R_lvlh.transpose();
  for (const Star& s : starCatalogue()) {
    const Eigen::Vector3d d = camera_R_eci * s.direction;
    if (d.z() <= 0) continue;
    double t;
    if (view.earth && earth.hit(R * d, t)) continue;
    const double relative = std::pow(10.0, -0.4 * (s.magnitude - kSunMagnitude));
    splatPointSource(cam, sigma, reach, d,
                     s.colour * static_cast<float>(relative * point_scale * view.star_gain), frame);
  }
}

// The sun's disc (uniform, ~46 000 times a white plate), when in view and not hidden.
void compositeSunDisc(const PinholeCamera& cam, const BackgroundView& view,
                      const EarthSphere& earth, RenderOutput& frame) {
  const int W = cam.width, H = cam.height;
  const Eigen::Matrix3d camera_R_lvlh = view.lvlh_R_camera.transpose();
  const Eigen::Vector3d d = camera_R_lvlh * view.sun_direction;
  double t;
  if (!(d.z() > 0 && !(view.earth && earth.hit(view.sun_direction, t)))) return;
  const double u = cam.fx * d.x() / d.z() + cam.cx, v = cam.fy * d.y() / d.z() + cam.cy;
  const double radius = kSunAngularRadius * cam.fx;
  const float value =
      static_cast<float>(view.sun_irradiance / (kSunAngularRadius * kSunAngularRadius));
  if (!(u > -radius && v > -radius && u < W + radius && v < H + radius)) return;
  const int x0 = std::max(0, static_cast<int>(std::floor(u - radius))),
            x1 = std::min(W - 1, static_cast<int>(std::ceil(u + radius)));
  const int y0 = std::max(0, static_cast<int>(std::floor(v - radius))),
            y1 = std::min(H - 1, static_cast<int>(std::ceil(v + radius)));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * W + x;
      if (frame.id[i] != 0) continue;
      if (std::hypot(x - u, y - v) > radius) continue;
      for (int c = 0; c < 3; ++c) frame.radiance[3 * i + c] += value;
    }
}

}  // namespace

void compositeBackground(const PinholeCamera& cam, const BackgroundView& view,
                         RenderOutput& frame) {
  const EarthSphere earth(view);
  if (view.earth) compositeEarth(cam, view, earth, frame);
  if (view.stars && view.star_gain > 0) compositeStars(cam, view, earth, frame);
  if (view.sun_disc && view.sun_irradiance > 0) compositeSunDisc(cam, view, earth, frame);
}

}  // namespace cdff::egse
