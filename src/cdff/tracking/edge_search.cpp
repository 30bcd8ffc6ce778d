#include "cdff/tracking/edge_search.hpp"

#include <algorithm>
#include <cmath>

namespace cdff::tracking {

namespace {

class Bilinear {
 public:
  explicit Bilinear(const Image& image)
      : data_(image.pixels.data()),
        stride_(image.stride_bytes),
        max_x_(image.width - 1.001),
        max_y_(image.height - 1.001) {}

  bool inside(double x, double y) const { return x >= 0 && y >= 0 && x <= max_x_ && y <= max_y_; }
  // Only valid when inside(x, y).
  float operator()(double x, double y) const {
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
    const std::uint8_t* r0 = data_ + static_cast<std::size_t>(y0) * stride_ + x0;
    const std::uint8_t* r1 = r0 + stride_;
    const float top = r0[0] + fx * (r0[1] - r0[0]);
    const float bottom = r1[0] + fx * (r1[1] - r1[0]);
    return top + fy * (bottom - top);
  }

 private:
  const std::uint8_t* data_;
  std::size_t stride_;
  double max_x_, max_y_;
};

// The edge responses along every sample's search line: for each of its rows (offsets
// -(D+2) .. D+2 along the normal), the derivative along the normal (mean over the 2 h + 1 lines)
// and across it (outer lines), and whether the whole mask was inside the image. With contrast
// adaptation, also each sample's strongest response within -D .. D and every response's
// magnitude, from which the threshold adapts.
struct Responses {
  int rows = 0;
  std::vector<float> gn, gt;  // rows per sample
  std::vector<char> valid;    // rows per sample
  std::vector<float> peaks, magnitudes;
};

Responses edgeResponses(const Image& image, const std::vector<ContourSample>& samples,
                        const EdgeSearchOptions& options) {
  const Bilinear at(image);
  const int D = options.search_distance;
  const int h = options.half_width;
  const int rows = 2 * D + 5;  // offsets -(D+2) .. D+2
  const int lines = 2 * h + 1;
  std::vector<float> grey(static_cast<std::size_t>(rows * lines));
  const std::size_t n_samples = samples.size();
  Responses out;
  out.rows = rows;
  out.gn.resize(n_samples * rows);
  out.gt.resize(n_samples * rows);
  out.valid.resize(n_samples * rows);
  out.peaks.reserve(n_samples);
  if (options.relative_gradient > 0) out.magnitudes.reserve(n_samples * rows);
  for (std::size_t i = 0; i < n_samples; ++i) {
    const ContourSample& s = samples[i];
    float* gn = out.gn.data() + i * rows;
    float* gt = out.gt.data() + i * rows;
    char* valid = out.valid.data() + i * rows;
    const Eigen::Vector2d n = s.normal, t(-s.normal.y(), s.normal.x());
    for (int r = 0; r < rows; ++r) {
      const int j = r - (D + 2);
      bool ok = true;
      for (int k = -h; k <= h && ok; ++k) {
        const double x = s.pixel.x() + j * n.x() + k * t.x();
        const double y = s.pixel.y() + j * n.y() + k * t.y();
        if (!at.inside(x, y)) {
          ok = false;
          break;
        }
        grey[static_cast<std::size_t>(r * lines + k + h)] = at(x, y);
      }
      valid[r] = ok;
    }
    // Derivatives along the normal (mean over the lines) and across it (outer lines).
    const float norm_n = 1.0f / (2.0f * lines);
    float peak = 0;
    for (int r = 1; r + 1 < rows; ++r) {
      if (!valid[r - 1] || !valid[r + 1] || !valid[r]) {
        gn[r] = 0;
        gt[r] = 0;
        continue;
      }
      float sum = 0;
      for (int k = 0; k < lines; ++k) sum += grey[(r + 1) * lines + k] - grey[(r - 1) * lines + k];
      gn[r] = sum * norm_n;
      if (h > 0) {
        float across = 0;
        for (int rr = r - 1; rr <= r + 1; ++rr)
          across += grey[rr * lines + lines - 1] - grey[rr * lines];
        gt[r] = across / (3.0f * 2.0f * h);
      } else {
        gt[r] = 0;
      }
      if (options.relative_gradient > 0) {
        out.magnitudes.push_back(std::abs(gn[r]));
        if (r >= 2 && r + 2 < rows) peak = std::max(peak, std::abs(gn[r]));
      }
    }
    gn[0] = gn[rows - 1] = 0;
    if (options.relative_gradient > 0) out.peaks.push_back(peak);
  }
  return out;
}

double percentile(std::vector<float>& v, double q) {
  const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return static_cast<double>(v[static_cast<std::size_t>(k)]);
}

// The gradient threshold: min_gradient, or with contrast adaptation the lower of it and the
// adapted threshold (see EdgeSearchOptions). Reorders the peaks and magnitudes.
double gradientThreshold(const EdgeSearchOptions& options, std::vector<float>& peaks,
                         std::vector<float>& magnitudes) {
  double threshold = options.min_gradient;
  if (options.relative_gradient > 0 && !peaks.empty() && !magnitudes.empty()) {
    const double strong = percentile(peaks, 0.75);
    // Median absolute response / 0.6745: the noise's standard deviation if most of the line
    // positions see flat image.
    const double noise = percentile(magnitudes, 0.5) / 0.6745;
    const double adapted = std::max({options.relative_gradient * strong,
                                     options.noise_sigmas * noise, options.min_gradient_floor});
    threshold = std::min(threshold, adapted);
  }
  return threshold;
}

// The candidates of sample `i` from its rows of responses: local maxima of the response within
// -D .. D above the threshold whose gradient is close enough to the normal, refined to a
// fraction of a pixel, strongest first, at most max_candidates. `found` is scratch space.
void appendCandidates(const Responses& responses, std::size_t i, double threshold, float tan_max,
                      const EdgeSearchOptions& options, std::vector<EdgeCandidate>& found,
                      ContourSample& s, std::vector<EdgeCandidate>& candidates) {
  const int rows = responses.rows;
  const float* gn = responses.gn.data() + i * rows;
  const float* gt = responses.gt.data() + i * rows;
  const char* valid = responses.valid.data() + i * rows;
  const int D = options.search_distance;
  s.first_candidate = static_cast<std::uint32_t>(candidates.size());
  s.candidate_count = 0;
  found.clear();
  for (int r = 2; r + 2 < rows; ++r) {  // offsets -D .. D
    const float a = std::abs(gn[r - 1]), b = std::abs(gn[r]), c = std::abs(gn[r + 1]);
    if (b < threshold || b < a || b <= c) continue;
    if (!valid[r]) continue;
    if (std::abs(gt[r]) > tan_max * b) continue;  // not parallel to the contour
    // Opposite signs around the peak mean two edges: keep the peak unrefined.
    float delta = 0;
    const float denom = a - 2 * b + c;
    if (denom < 0 && gn[r - 1] * gn[r] >= 0 && gn[r + 1] * gn[r] >= 0)
      delta = std::clamp(0.5f * (a - c) / denom, -0.5f, 0.5f);
    found.push_back({static_cast<float>(r - (D + 2)) + delta, b});
  }
  if (found.empty()) return;
  const std::size_t keep = std::min<std::size_t>(found.size(), options.max_candidates);
  std::partial_sort(
      found.begin(), found.begin() + static_cast<std::ptrdiff_t>(keep), found.end(),
      [](const EdgeCandidate& x, const EdgeCandidate& y) { return x.strength > y.strength; });
  candidates.insert(candidates.end(), found.begin(),
                    found.begin() + static_cast<std::ptrdiff_t>(keep));
  s.candidate_count = static_cast<std::uint32_t>(keep);
}

}  // namespace

Result<ContourSamples> searchEdges(const Image& image, const ContourSamples& samples,
                                   const EdgeSearchOptions& options, double* applied_threshold) {
  CDFF_RETURN_IF_ERROR(image.validate("image", {PixelFormat::kGray8}));
  CDFF_RETURN_IF_ERROR(samples.validate("samples"));
  const CameraModel& camera = samples.contours->camera;
  if (image.width != camera.width || image.height != camera.height)
    return invalidInput(
        "image is {}x{} but the contours were computed for a {}x{} camera; "
        "expected the image of that camera",
        image.width, image.height, camera.width, camera.height);
  if (options.search_distance < 1 || options.half_width < 0 || options.max_candidates < 1)
    return invalidParameter(
        "edge search needs search_distance >= 1, half_width >= 0 and "
        "max_candidates >= 1; got {}, {} and {}",
        options.search_distance, options.half_width, options.max_candidates);
  if (!(options.relative_gradient >= 0 && options.relative_gradient <= 1) ||
      !(options.noise_sigmas >= 0) || !(options.min_gradient_floor >= 0))
    return invalidParameter(
        "edge search needs relative_gradient in [0, 1], noise_sigmas >= 0 and "
        "min_gradient_floor >= 0; got {}, {} and {}",
        options.relative_gradient, options.noise_sigmas, options.min_gradient_floor);

  ContourSamples out;
  out.contours = samples.contours;
  out.samples = samples.samples;
  out.matched = true;
  out.candidates.reserve(samples.samples.size() * 2);

  // First the responses along every sample's line, then the threshold from all of them, then
  // the candidates.
  Responses responses = edgeResponses(image, out.samples, options);
  const double threshold = gradientThreshold(options, responses.peaks, responses.magnitudes);
  if (applied_threshold) *applied_threshold = threshold;

  const float tan_max = static_cast<float>(std::tan(std::min(options.angular_threshold, 1.5607)));
  std::vector<EdgeCandidate> found;
  for (std::size_t i = 0; i < out.samples.size(); ++i)
    appendCandidates(responses, i, threshold, tan_max, options, found, out.samples[i],
                     out.candidates);
  return out;
}

}  // namespace cdff::tracking
