#include "cdff/egse/camera_sensor.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "cdff/egse/lens.hpp"

namespace cdff::egse {

namespace {

// Separable Gaussian blur of a C-channel float image, clamped at the borders.
void gaussianBlur(std::vector<float>& image, std::vector<float>& tmp, int width, int height,
                  int channels, double sigma) {
  if (sigma < 0.05) return;
  const int radius = std::max(1, static_cast<int>(std::ceil(3 * sigma)));
  std::vector<float> kernel(2 * radius + 1);
  double total = 0;
  for (int i = -radius; i <= radius; ++i)
    total += kernel[i + radius] = static_cast<float>(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (float& k : kernel) k = static_cast<float>(k / total);
  tmp.resize(image.size());
  const int C = channels;
  const float* K = kernel.data() + radius;
  for (int y = 0; y < height; ++y) {
    const float* row = image.data() + static_cast<std::size_t>(y) * width * C;
    float* out = tmp.data() + static_cast<std::size_t>(y) * width * C;
    for (int x = 0; x < width; ++x) {
      const bool interior = x >= radius && x + radius < width;
      for (int c = 0; c < C; ++c) {
        float sum = 0;
        if (interior) {
          const float* p = row + x * C + c;
          for (int k = -radius; k <= radius; ++k) sum += K[k] * p[k * C];
        } else {
          for (int k = -radius; k <= radius; ++k)
            sum += K[k] * row[std::clamp(x + k, 0, width - 1) * C + c];
        }
        out[x * C + c] = sum;
      }
    }
  }
  const std::size_t stride = static_cast<std::size_t>(width) * C;
  for (int y = 0; y < height; ++y) {
    float* out = image.data() + y * stride;
    if (y >= radius && y + radius < height) {
      const float* centre = tmp.data() + y * stride;
      for (std::size_t i = 0; i < stride; ++i) {
        float sum = 0;
        for (int k = -radius; k <= radius; ++k)
          sum +=
              K[k] * centre[static_cast<std::ptrdiff_t>(k) * static_cast<std::ptrdiff_t>(stride) +
                            static_cast<std::ptrdiff_t>(i)];
        out[i] = sum;
      }
    } else {
      for (std::size_t i = 0; i < stride; ++i) {
        float sum = 0;
        for (int k = -radius; k <= radius; ++k)
          sum += K[k] * tmp[std::clamp(y + k, 0, height - 1) * stride + i];
        out[i] = sum;
      }
    }
  }
}

}  // namespace

Status CameraSpec::validate(const std::string& name) const {
  CDFF_RETURN_IF_ERROR(model.validate().withContext(name));
  auto positive = [&](double v, const char* key) -> Status {
    if (!std::isfinite(v) || v <= 0)
      return invalidParameter("{}: '{}' = {} is invalid; expected > 0", name, key, v);
    return Status::ok();
  };
  CDFF_RETURN_IF_ERROR(positive(exposure_time, "exposure_time"));
  CDFF_RETURN_IF_ERROR(positive(full_well, "full_well"));
  CDFF_RETURN_IF_ERROR(positive(sensitivity, "sensitivity"));
  if (format != PixelFormat::kGray8 && format != PixelFormat::kBgr8)
    return invalidParameter("{}: format '{}' is not supported; expected 8UC1 or 8UC3", name,
                            toString(format));
  if (!std::isfinite(read_noise) || read_noise < 0)
    return invalidParameter("{}: 'read_noise' = {} is invalid; expected >= 0 electrons", name,
                            read_noise);
  if (!std::isfinite(gain_db) || gain_db < -20 || gain_db > 40)
    return invalidParameter("{}: 'gain_db' = {} is out of range; expected [-20, 40]", name,
                            gain_db);
  if (supersampling < 1 || supersampling > 8)
    return invalidParameter("{}: 'supersampling' = {} is out of range; expected [1, 8]", name,
                            supersampling);
  if (motion_blur_samples < 1 || motion_blur_samples > 32)
    return invalidParameter("{}: 'motion_blur_samples' = {} is out of range; expected [1, 32]",
                            name, motion_blur_samples);
  if (!std::isfinite(psf_sigma) || psf_sigma < 0 || psf_sigma > 20)
    return invalidParameter("{}: 'psf_sigma' = {} is out of range; expected [0, 20] px", name,
                            psf_sigma);
  if (f_number < 0 || (f_number > 0 && !(focus_distance > 0)))
    return invalidParameter(
        "{}: defocus needs 'f_number' > 0 and 'focus_distance' > 0 (got {} and {})", name, f_number,
        focus_distance);
  if (shadow_map_size < 64 || shadow_map_size > 8192)
    return invalidParameter("{}: 'shadow_map_size' = {} is out of range; expected [64, 8192]", name,
                            shadow_map_size);
  return Status::ok();
}

Result<CameraSensor> CameraSensor::create(const CameraSpec& spec, const std::string& name) {
  CDFF_RETURN_IF_ERROR(spec.validate(name));
  CameraSensor s;
  s.spec_ = spec;
  s.name_ = name;
  const CameraModel& m = spec.model;
  PinholeCamera canvas;
  canvas.fx = m.fx;
  canvas.fy = m.fy;
  std::vector<float> remap;  // distorted cameras: per pixel, the canvas (u, v) its ray lands on
  if (!m.hasDistortion()) {
    canvas.width = m.width;
    canvas.height = m.height;
    canvas.cx = m.cx;
    canvas.cy = m.cy;
  } else {
    // The pinhole canvas must hold every ray the distorted pixels see: undistort the border.
    double u0 = 1e18, u1 = -1e18, v0 = 1e18, v1 = -1e18;
    auto extend = [&](double x, double y) {
      const Eigen::Vector2d n =
          undistortNormalised(m, Eigen::Vector2d((x - m.cx) / m.fx, (y - m.cy) / m.fy));
      const double u = m.fx * n.x() + m.cx, v = m.fy * n.y() + m.cy;
      u0 = std::min(u0, u);
      u1 = std::max(u1, u);
      v0 = std::min(v0, v);
      v1 = std::max(v1, v);
    };
    for (int x = -1; x <= m.width; ++x) {
      extend(x, -1);
      extend(x, m.height);
    }
    for (int y = -1; y <= m.height; ++y) {
      extend(-1, y);
      extend(m.width, y);
    }
    const double margin = 2.0;
    canvas.cx = m.cx - std::floor(u0) + margin;
    canvas.cy = m.cy - std::floor(v0) + margin;
    canvas.width = static_cast<int>(std::ceil(u1) - std::floor(u0) + 2 * margin + 1);
    canvas.height = static_cast<int>(std::ceil(v1) - std::floor(v0) + 2 * margin + 1);
    if (canvas.width > 3 * m.width || canvas.height > 3 * m.height)
      return invalidParameter(
          "{}: the distortion is too strong to render: the undistorted field of view needs a "
          "{}x{} canvas for a {}x{} image; expected at most 3 times the image size",
          name, canvas.width, canvas.height, m.width, m.height);
    remap.resize(2 * static_cast<std::size_t>(m.width) * m.height);
    Eigen::Vector2d guess((0 - m.cx) / m.fx, (0 - m.cy) / m.fy);
    for (int y = 0; y < m.height; ++y) {
      Eigen::Vector2d row_guess = guess;
      for (int x = 0; x < m.width; ++x) {
        const Eigen::Vector2d target((x - m.cx) / m.fx, (y - m.cy) / m.fy);
        const Eigen::Vector2d n = undistortNormalised(m, target, x == 0 ? guess : row_guess);
        row_guess = n;
        if (x == 0) guess = n;
        const std::size_t i = static_cast<std::size_t>(y) * m.width + x;
        remap[2 * i] = static_cast<float>(m.fx * n.x() + canvas.cx);
        remap[2 * i + 1] = static_cast<float>(m.fy * n.y() + canvas.cy);
      }
    }
  }
  s.canvas_ = canvas;
  s.samples_ = canvasSamples(m, canvas, remap);
  const int k = spec.supersampling;
  s.render_camera_ = canvas;
  s.render_camera_.width = canvas.width * k;
  s.render_camera_.height = canvas.height * k;
  s.render_camera_.fx = canvas.fx * k;
  s.render_camera_.fy = canvas.fy * k;
  // Sub-sample (i, j) of canvas pixel (u, v) sits at u + (i + 0.5) / k - 0.5.
  s.render_camera_.cx = canvas.cx * k + 0.5 * (k - 1);
  s.render_camera_.cy = canvas.cy * k + 0.5 * (k - 1);
  return s;
}

Result<CameraFrame> CameraSensor::expose(const std::vector<RenderOutput>& renders,
                                         const BackgroundView& view, const CameraFaults& faults,
                                         Rng& rng) const {
  if (renders.empty()) return invalidInput("{}: no render to expose", name_);
  const int RW = render_camera_.width, RH = render_camera_.height;
  for (const RenderOutput& r : renders)
    if (r.width != RW || r.height != RH)
      return invalidInput("{}: a render is {}x{}; expected {}x{}", name_, r.width, r.height, RW,
                          RH);
  // 1. Average the motion-blur samples and the supersamples onto the canvas.
  RenderOutput& canvas = canvas_scratch_;
  averageSamples(renders, canvas);
  // 2. Partial occlusion of the target, from the left of the image, to the requested fraction.
  CameraFrame frame;
  if (faults.occlusion > 0) frame.occluded_fraction = occludeTarget(faults, canvas);
  // 3. Background.
  compositeBackground(canvas_, view, canvas);
  // 4. Stray light from the sun near (or in) the field of view.
  addStrayLight(view, faults, canvas);
  // 5. Spectral response: one channel for a monochrome sensor.
  const bool colour = spec_.format == PixelFormat::kBgr8;
  const int C = colour ? 3 : 1;
  spectralResponse(canvas, C);
  // 6. Lens distortion: sample the canvas where each distorted pixel's ray lands.
  distort(canvas, C, frame);
  // 7. Optics blur, plus defocus at the target's mean depth.
  const int W = spec_.model.width, H = spec_.model.height;
  gaussianBlur(signal_, blur_scratch_, W, H, C, blurSigma(frame));
  // 8-10. Exposure, noise, full well, gain, quantisation.
  CDFF_RETURN_IF_ERROR(quantise(faults, rng, C, frame));
  return frame;
}

void CameraSensor::averageSamples(const std::vector<RenderOutput>& renders,
                                  RenderOutput& canvas) const {
  const int k = spec_.supersampling;
  const int RW = render_camera_.width;
  const int CW = canvas_.width, CH = canvas_.height;
  if (canvas.width != CW || canvas.height != CH) canvas.resize(CW, CH);
  const RenderOutput& middle = renders[renders.size() / 2];
  const float weight = 1.0f / static_cast<float>(renders.size() * k * k);
  if (k == 1 && renders.size() == 1) {
    canvas.radiance = middle.radiance;
    canvas.depth = middle.depth;
    canvas.id = middle.id;
  } else
    for (int y = 0; y < CH; ++y)
      for (int x = 0; x < CW; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * CW + x;
        float sum[3] = {0, 0, 0};
        for (const RenderOutput& r : renders)
          for (int j = 0; j < k; ++j)
            for (int l = 0; l < k; ++l) {
              const std::size_t s = static_cast<std::size_t>(y * k + j) * RW + (x * k + l);
              for (int c = 0; c < 3; ++c) sum[c] += r.radiance[3 * s + c];
            }
        for (int c = 0; c < 3; ++c) canvas.radiance[3 * i + c] = sum[c] * weight;
        const std::size_t centre = static_cast<std::size_t>(y * k + k / 2) * RW + (x * k + k / 2);
        canvas.depth[i] = middle.depth[centre];
        canvas.id[i] = middle.id[centre];
      }
}

double CameraSensor::occludeTarget(const CameraFaults& faults, RenderOutput& canvas) const {
  const int CW = canvas_.width, CH = canvas_.height;
  const std::size_t canvas_pixels = static_cast<std::size_t>(CW) * CH;
  std::vector<std::size_t> column_count(CW, 0);
  std::size_t total = 0;
  float nearest = std::numeric_limits<float>::infinity();
  for (std::size_t i = 0; i < canvas_pixels; ++i)
    if (canvas.id[i] == 1) {
      ++column_count[i % CW];
      ++total;
      nearest = std::min(nearest, canvas.depth[i]);
    }
  std::size_t wanted =
      static_cast<std::size_t>(std::llround(std::clamp(faults.occlusion, 0.0, 1.0) * total));
  std::size_t hidden = 0;
  for (int x = 0; x < CW && hidden < wanted; ++x)
    for (int y = 0; y < CH && hidden < wanted; ++y) {
      const std::size_t i = static_cast<std::size_t>(y) * CW + x;
      if (canvas.id[i] != 1) continue;
      ++hidden;
      canvas.radiance[3 * i] = canvas.radiance[3 * i + 1] = canvas.radiance[3 * i + 2] = 0.0f;
      if (faults.occlusion_mode == OcclusionMode::kOccluder) {
        canvas.id[i] = 255;
        canvas.depth[i] = 0.5f * nearest;
      }
    }
  return total > 0 ? static_cast<double>(hidden) / total : 0.0;
}

double CameraSensor::glareLevel(const BackgroundView& view, const CameraFaults& faults,
                                const Eigen::Vector3d& sun) const {
  const int CW = canvas_.width, CH = canvas_.height;
  bool sun_blocked = false;
  if (view.earth) {
    const Eigen::Vector3d oc = view.camera_position - view.earth_centre;
    const double b = view.sun_direction.dot(oc),
                 disc = b * b - (oc.squaredNorm() - view.earth_radius * view.earth_radius);
    sun_blocked = disc >= 0 && -b - std::sqrt(disc) > 0;
  }
  const double half_diagonal =
      std::atan(std::hypot(std::max(canvas_.cx, CW - canvas_.cx) / canvas_.fx,
                           std::max(canvas_.cy, CH - canvas_.cy) / canvas_.fy));
  const double off_axis = std::acos(std::clamp(sun.z(), -1.0, 1.0));
  double glare = 0;
  if (view.sun_irradiance > 0 && !sun_blocked) {
    glare = spec_.glare_strength * faults.glare_gain * view.sun_irradiance;
    if (off_axis > half_diagonal) {
      glare *= std::exp(-(off_axis - half_diagonal) / spec_.glare_decay);
      // Where the halo reaches the image at all; below 1e-4 (a fiftieth of a grey level at the
      // default exposure) it is left out.
      const double nearest = off_axis - half_diagonal, w2 = spec_.glare_width * spec_.glare_width;
      if (glare * w2 / (nearest * nearest + w2) < 1e-4) glare = 0;
    }
  }
  return glare;
}

void CameraSensor::addStrayLight(const BackgroundView& view, const CameraFaults& faults,
                                 RenderOutput& canvas) const {
  const int CW = canvas_.width, CH = canvas_.height;
  const Eigen::Matrix3d camera_R_lvlh = view.lvlh_R_camera.transpose();
  const Eigen::Vector3d sun = camera_R_lvlh * view.sun_direction;
  const double glare = glareLevel(view, faults, sun);
  if (!(glare > 1e-6 || faults.extra_glare > 0)) return;
  const double w2 = spec_.glare_width * spec_.glare_width;
  const bool ghosts = sun.z() > 0.05;
  double su = 0, sv = 0;
  if (ghosts) {
    su = canvas_.fx * sun.x() / sun.z() + canvas_.cx;
    sv = canvas_.fy * sun.y() / sun.z() + canvas_.cy;
  }
  const double ghost_alpha[2] = {-0.35, -0.8}, ghost_radius[2] = {0.05 * CW, 0.09 * CW},
               ghost_level[2] = {0.6, 0.35};
  for (int y = 0; y < CH; ++y)
    for (int x = 0; x < CW; ++x) {
      const Eigen::Vector3d d =
          Eigen::Vector3d((x - canvas_.cx) / canvas_.fx, (y - canvas_.cy) / canvas_.fy, 1.0)
              .normalized();
      const double chord2 = 2.0 * (1.0 - d.dot(sun));  // ~ angle^2
      double value = faults.extra_glare + glare * w2 / (chord2 + w2);
      if (ghosts && glare > 1e-6)
        for (int g = 0; g < 2; ++g) {
          const double gu = canvas_.cx + ghost_alpha[g] * (su - canvas_.cx),
                       gv = canvas_.cy + ghost_alpha[g] * (sv - canvas_.cy);
          const double r = std::hypot(x - gu, y - gv) / ghost_radius[g];
          if (r < 1.0) value += glare * ghost_level[g] * (1.0 - r * r);
        }
      const std::size_t i = static_cast<std::size_t>(y) * CW + x;
      for (int c = 0; c < 3; ++c) canvas.radiance[3 * i + c] += static_cast<float>(value);
    }
}

void CameraSensor::spectralResponse(const RenderOutput& canvas, int C) const {
  const bool colour = C == 3;
  const std::size_t canvas_pixels = static_cast<std::size_t>(canvas_.width) * canvas_.height;
  std::vector<float>& canvas_signal = canvas_signal_;
  canvas_signal.resize(canvas_pixels * C);
  for (std::size_t i = 0; i < canvas_pixels; ++i) {
    if (colour) {
      canvas_signal[3 * i] = canvas.radiance[3 * i + 2];  // B
      canvas_signal[3 * i + 1] = canvas.radiance[3 * i + 1];
      canvas_signal[3 * i + 2] = canvas.radiance[3 * i];  // R
    } else {
      canvas_signal[i] = 0.2126f * canvas.radiance[3 * i] + 0.7152f * canvas.radiance[3 * i + 1] +
                         0.0722f * canvas.radiance[3 * i + 2];
    }
  }
}

std::vector<CameraSensor::CanvasSample> CameraSensor::canvasSamples(
    const CameraModel& m, const PinholeCamera& canvas, const std::vector<float>& remap) {
  const int W = m.width, H = m.height, CW = canvas.width, CH = canvas.height;
  std::vector<CanvasSample> samples(static_cast<std::size_t>(W) * H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * W + x;
      double u = x - m.cx + canvas.cx, v = y - m.cy + canvas.cy;
      if (!remap.empty()) {
        u = remap[2 * i];
        v = remap[2 * i + 1];
      }
      const int iu = std::clamp(static_cast<int>(std::floor(u)), 0, CW - 2);
      const int iv = std::clamp(static_cast<int>(std::floor(v)), 0, CH - 2);
      const int nu = std::clamp(static_cast<int>(std::lround(u)), 0, CW - 1);
      const int nv = std::clamp(static_cast<int>(std::lround(v)), 0, CH - 1);
      CanvasSample& s = samples[i];
      s.corner = static_cast<std::uint32_t>(iv * CW + iu);
      s.nearest = static_cast<std::uint32_t>(nv * CW + nu);
      s.fu = static_cast<float>(std::clamp(u - iu, 0.0, 1.0));
      s.fv = static_cast<float>(std::clamp(v - iv, 0.0, 1.0));
    }
  return samples;
}

void CameraSensor::distort(const RenderOutput& canvas, int C, CameraFrame& frame) const {
  const int CW = canvas_.width;
  const std::vector<float>& canvas_signal = canvas_signal_;
  const int W = spec_.model.width, H = spec_.model.height;
  const std::size_t pixels = static_cast<std::size_t>(W) * H;
  std::vector<float>& signal = signal_;
  signal.resize(pixels * C);
  std::vector<float>& depth = depth_;
  depth.resize(pixels);
  frame.labels.resize(pixels);
  for (std::size_t i = 0; i < pixels; ++i) {
    const CanvasSample& s = samples_[i];
    const std::size_t a = s.corner;
    const float fu = s.fu, fv = s.fv;
    for (int c = 0; c < C; ++c) {
      auto at = [&](std::size_t canvas_index) { return canvas_signal[canvas_index * C + c]; };
      signal[i * C + c] = (1 - fv) * ((1 - fu) * at(a) + fu * at(a + 1)) +
                          fv * ((1 - fu) * at(a + CW) + fu * at(a + CW + 1));
    }
    const std::size_t n = s.nearest;
    frame.labels[i] = canvas.id[n];
    // Depth: bilinear inside one surface (all four neighbours on the same object), nearest at
    // silhouettes so that no depth is invented between two surfaces.
    const std::uint8_t label = canvas.id[a];
    const bool same = label != 0 && canvas.id[a + 1] == label && canvas.id[a + CW] == label &&
                      canvas.id[a + CW + 1] == label;
    const float d00 = canvas.depth[a], d01 = canvas.depth[a + 1], d10 = canvas.depth[a + CW],
                d11 = canvas.depth[a + CW + 1];
    const float smooth_limit = 0.02f * std::min({d00, d01, d10, d11});
    if (same && std::max({d00, d01, d10, d11}) - std::min({d00, d01, d10, d11}) < smooth_limit)
      depth[i] = (1 - fv) * ((1 - fu) * d00 + fu * d01) + fv * ((1 - fu) * d10 + fu * d11);
    else
      depth[i] = std::isfinite(canvas.depth[n]) ? canvas.depth[n] : 0.0f;
  }
}

double CameraSensor::blurSigma(const CameraFrame& frame) const {
  const std::size_t pixels = static_cast<std::size_t>(spec_.model.width) * spec_.model.height;
  const std::vector<float>& depth = depth_;
  double sigma2 = spec_.psf_sigma * spec_.psf_sigma;
  if (spec_.f_number > 0) {
    double sum = 0;
    std::size_t count = 0;
    for (std::size_t i = 0; i < pixels; ++i)
      if (frame.labels[i] == 1) {
        sum += depth[i];
        ++count;
      }
    if (count > 0) {
      const double s = sum / count, sf = spec_.focus_distance, f = spec_.focal_length;
      const double coc = f * f * std::abs(s - sf) / (spec_.f_number * s * std::max(sf - f, 1e-6));
      const double sigma_defocus = coc / (2.0 * std::sqrt(2.0)) / spec_.pixel_pitch;
      sigma2 += sigma_defocus * sigma_defocus;
    }
  }
  return std::sqrt(sigma2);
}

Status CameraSensor::quantise(const CameraFaults& faults, Rng& rng, int C,
                              CameraFrame& frame) const {
  const bool colour = C == 3;
  const int W = spec_.model.width, H = spec_.model.height;
  const std::size_t pixels = static_cast<std::size_t>(W) * H;
  const std::vector<float>& signal = signal_;
  const std::vector<float>& depth = depth_;
  const double to_electrons = spec_.sensitivity * spec_.exposure_time;
  const double gain = std::pow(10.0, spec_.gain_db / 20.0);
  const double to_dn = gain * 255.0 / spec_.full_well;
  const double read2 = spec_.read_noise * spec_.read_noise;
  std::vector<std::uint8_t> bytes(pixels * C);
  for (std::size_t i = 0; i < pixels * C; ++i) {
    double e = faults.dark ? 0.0 : std::max(0.0, static_cast<double>(signal[i]) * to_electrons);
    if (spec_.noise) e += std::sqrt(e + read2) * rng.normal();
    e = std::clamp(e, 0.0, spec_.full_well);
    bytes[i] =
        static_cast<std::uint8_t>(std::min(255.0, e * to_dn + 0.5));  // e >= 0: rounds to nearest
  }
  auto image =
      Image::fromBytes(std::move(bytes), W, H, colour ? PixelFormat::kBgr8 : PixelFormat::kGray8);
  if (!image) return image.status();
  frame.image = std::move(image).value();
  frame.image.camera = spec_.model;
  std::vector<std::uint8_t> depth_bytes(pixels * sizeof(float));
  std::memcpy(depth_bytes.data(), depth.data(), depth_bytes.size());
  auto depth_image = Image::fromBytes(std::move(depth_bytes), W, H, PixelFormat::kFloat32);
  if (!depth_image) return depth_image.status();
  frame.depth.image = std::move(depth_image).value();
  frame.depth.image.camera = spec_.model;
  frame.depth.meters_per_unit = 1.0;
  return Status::ok();
}

}  // namespace cdff::egse
