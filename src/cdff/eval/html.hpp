#pragma once
// Self-contained HTML pages of results (`cdff eval --html`, `cdff campaign`'s report.html): text
// escaping, the shared style sheet, and plots as inline SVG, so that a page needs no script and
// no file beside it.

#include <cmath>
#include <string>
#include <vector>

namespace cdff::eval {

/// `text` with &, <, > and " escaped for HTML.
std::string escapeHtml(const std::string& text);

/// The style sheet of the pages (tables with pass/fail cells, plots).
extern const char* const kPageCss;

struct PlotSeries {
  std::vector<double> x, y;
};

/// A vertical line across a plot at x, labelled (a phase's start).
struct PlotMarker {
  double x = 0;
  std::string label;
};

/// One scatter-and-line plot as inline SVG: axes with ticks, the data, an optional horizontal
/// threshold line (the requirement) drawn dashed, and vertical markers within the data's span;
/// `connect` draws the line.
std::string svgPlot(const std::string& title, const std::string& x_label,
                    const std::string& y_label, const PlotSeries& data, double threshold = NAN,
                    bool connect = true, const std::vector<PlotMarker>& markers = {});

}  // namespace cdff::eval
