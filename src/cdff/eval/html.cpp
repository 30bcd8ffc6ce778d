// HTML pages of results (html.hpp).

#include "cdff/eval/html.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace cdff::eval {

const char* const kPageCss =
    R"(body { font-family: system-ui, sans-serif; margin: 2em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
.pass { background: #d9f2d9; } .fail { background: #f8d0d0; } .not_applicable { color: #888; }
.plot { margin: 0.3em 1em 0.3em 0; } .plot .title { font-weight: bold; font-size: 13px; }
.plot .frame { fill: none; stroke: #444; } .plot .grid { stroke: #eee; }
.plot .tick, .plot .label { font-size: 11px; fill: #444; }
.plot .data { fill: none; stroke: #1f77b4; stroke-width: 1; }
.plot .point { fill: #1f77b4; } .plot .threshold { stroke: #d62728; stroke-dasharray: 5 4; }
.plot .marker { stroke: #555; stroke-dasharray: 2 3; }
)";

namespace {

// A "nice" step (1, 2 or 5 times a power of ten) giving about `count` ticks over `span`.
double niceStep(double span, int count) {
  const double raw = span / count;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (raw <= m * magnitude) return m * magnitude;
  return 10.0 * magnitude;
}

}  // namespace

std::string escapeHtml(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string svgPlot(const std::string& title, const std::string& x_label,
                    const std::string& y_label, const PlotSeries& data, double threshold,
                    bool connect, const std::vector<PlotMarker>& markers) {
  constexpr double kWidth = 560, kHeight = 260, kLeft = 62, kRight = 14, kTop = 26, kBottom = 40;
  const double plot_w = kWidth - kLeft - kRight, plot_h = kHeight - kTop - kBottom;
  std::string svg = fmt::format(
      "<svg xmlns='http://www.w3.org/2000/svg' width='{0}' height='{1}' viewBox='0 0 {0} {1}' "
      "class='plot'><text x='{2}' y='16' class='title'>{3}</text>",
      kWidth, kHeight, kLeft, escapeHtml(title));
  if (data.x.empty()) return svg + "<text x='200' y='130'>no data</text></svg>";

  auto [x_min_it, x_max_it] = std::minmax_element(data.x.begin(), data.x.end());
  double x_min = *x_min_it, x_max = *x_max_it;
  double y_max = *std::max_element(data.y.begin(), data.y.end());
  if (std::isfinite(threshold) && threshold < 4 * y_max) y_max = std::max(y_max, threshold);
  if (x_max <= x_min) x_max = x_min + 1;
  if (y_max <= 0) y_max = 1;
  const double y_step = niceStep(y_max, 5), x_step = niceStep(x_max - x_min, 6);
  y_max = std::ceil(y_max / y_step) * y_step;
  const auto px = [&](double x) { return kLeft + (x - x_min) / (x_max - x_min) * plot_w; };
  const auto py = [&](double y) { return kTop + plot_h - std::min(y, y_max) / y_max * plot_h; };

  svg += fmt::format("<rect x='{}' y='{}' width='{}' height='{}' class='frame'/>", kLeft, kTop,
                     plot_w, plot_h);
  for (double y = 0; y <= y_max + 1e-12 * y_max; y += y_step)
    svg += fmt::format(
        "<line x1='{0}' x2='{1}' y1='{2:.1f}' y2='{2:.1f}' class='grid'/>"
        "<text x='{3}' y='{4:.1f}' class='tick' text-anchor='end'>{5:g}</text>",
        kLeft, kLeft + plot_w, py(y), kLeft - 4, py(y) + 4, y);
  for (double x = std::ceil(x_min / x_step) * x_step; x <= x_max + 1e-9; x += x_step)
    svg += fmt::format("<text x='{:.1f}' y='{}' class='tick' text-anchor='middle'>{:g}</text>",
                       px(x), kTop + plot_h + 14, x);
  svg += fmt::format(
      "<text x='{}' y='{}' class='label' text-anchor='middle'>{}</text>"
      "<text x='14' y='{}' class='label' text-anchor='middle' transform='rotate(-90 14 {})'>{}"
      "</text>",
      kLeft + plot_w / 2, kHeight - 6, escapeHtml(x_label), kTop + plot_h / 2, kTop + plot_h / 2,
      escapeHtml(y_label));
  if (std::isfinite(threshold) && threshold <= y_max)
    svg += fmt::format(
        "<line x1='{0}' x2='{1}' y1='{2:.1f}' y2='{2:.1f}' class='threshold'/>"
        "<text x='{1}' y='{3:.1f}' class='tick' text-anchor='end'>requirement {4:g}</text>",
        kLeft, kLeft + plot_w, py(threshold), py(threshold) - 3, threshold);
  for (const PlotMarker& m : markers) {
    if (m.x < x_min || m.x > x_max) continue;
    svg += fmt::format(
        "<line x1='{0:.1f}' x2='{0:.1f}' y1='{1}' y2='{2}' class='marker'/>"
        "<text x='{3:.1f}' y='{4}' class='tick'>{5}</text>",
        px(m.x), kTop, kTop + plot_h, px(m.x) + 3, kTop + 10, escapeHtml(m.label));
  }
  if (connect) {
    svg += "<polyline class='data' points='";
    for (std::size_t i = 0; i < data.x.size(); ++i)
      svg += fmt::format("{:.1f},{:.1f} ", px(data.x[i]), py(data.y[i]));
    svg += "'/>";
  }
  for (std::size_t i = 0; i < data.x.size(); ++i)
    svg += fmt::format("<circle cx='{:.1f}' cy='{:.1f}' r='1.6' class='point'/>", px(data.x[i]),
                       py(data.y[i]));
  return svg + "</svg>";
}

}  // namespace cdff::eval
