#include "cdff/types/polygon_model.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>

namespace cdff {

namespace {

std::string describe(const char* kind, std::size_t index, const std::string& name) {
  return name.empty() ? fmt::format("{} {}", kind, index)
                      : fmt::format("{} {} ('{}')", kind, index, name);
}

Status checkIndex(const std::vector<Eigen::Vector3d>& points, std::uint32_t index,
                  const std::string& primitive, const char* what) {
  if (index >= points.size())
    return invalidInput("{} {} refers to point {}; expected an index below {} (the point count)",
                        what, primitive, index, points.size());
  return Status::ok();
}

// A face is a polygon: at least 3 distinct points of the model, none repeated, on one plane
// (the least-squares plane of its points, within a tolerance) and not all on one line.
Status checkFace(const std::vector<Eigen::Vector3d>& points, const PolygonModel::Face& face,
                 const std::string& name, const char* what) {
  const std::set<std::uint32_t> distinct(face.points.begin(), face.points.end());
  if (distinct.size() < 3 || distinct.size() != face.points.size())
    return invalidInput(
        "{} {} has {} points of which {} distinct; expected at least 3 distinct "
        "points, none repeated",
        what, name, face.points.size(), distinct.size());
  for (std::uint32_t p : face.points) CDFF_RETURN_IF_ERROR(checkIndex(points, p, name, what));
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (std::uint32_t p : face.points) centre += points[p];
  centre /= static_cast<double>(face.points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  double size = 0;
  for (std::uint32_t p : face.points) {
    const Eigen::Vector3d d = points[p] - centre;
    scatter += d * d.transpose();
    size = std::max(size, d.norm());
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  const Eigen::Vector3d normal = eigen.eigenvectors().col(0);
  // Real models are rarely exactly planar (ViSP's chateau.cao has a wall 0.75 mm off):
  // 2 % of the face's diameter tolerates that and still catches a misplaced point.
  const double tolerance = std::max(1e-6, 0.02 * 2.0 * size);
  for (std::uint32_t p : face.points) {
    const double off = std::abs(normal.dot(points[p] - centre));
    if (off > tolerance)
      return invalidInput(
          "{} {} is not planar: point {} is {:.3g} m off the face's plane; "
          "expected at most {:.3g} m",
          what, name, p, off, tolerance);
  }
  if (eigen.eigenvalues()(1) <= 1e-18)
    return invalidInput("{} {} is degenerate (its points are collinear); expected a polygon", what,
                        name);
  return Status::ok();
}

// A circle needs a positive radius and a centre and two plane points that span its plane.
Status checkCircle(const std::vector<Eigen::Vector3d>& points, const PolygonModel::Circle& circle,
                   const std::string& name, const char* what) {
  for (std::uint32_t p : {circle.centre, circle.first, circle.second})
    CDFF_RETURN_IF_ERROR(checkIndex(points, p, name, what));
  if (!(circle.radius > 0) || !std::isfinite(circle.radius))
    return invalidInput("{} {} has radius {}; expected a positive radius in metres", what, name,
                        circle.radius);
  const Eigen::Vector3d n = (points[circle.first] - points[circle.centre])
                                .cross(points[circle.second] - points[circle.centre]);
  if (n.norm() <= 1e-12)
    return invalidInput(
        "{} {}: its centre and plane points {} and {} are collinear; expected "
        "three points spanning the circle's plane",
        what, name, circle.first, circle.second);
  return Status::ok();
}

}  // namespace

Status PolygonModel::validate(const char* what) const {
  if (empty())
    return invalidInput("{} has no face, line, cylinder or circle; expected at least one", what);
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite())
      return invalidInput("{} point {} is ({}, {}, {}); expected finite coordinates", what, i,
                          points[i].x(), points[i].y(), points[i].z());
  for (std::size_t f = 0; f < faces.size(); ++f)
    CDFF_RETURN_IF_ERROR(checkFace(points, faces[f], describe("face", f, faces[f].name), what));
  for (std::size_t l = 0; l < lines.size(); ++l) {
    const std::string name = describe("line", l, lines[l].name);
    CDFF_RETURN_IF_ERROR(checkIndex(points, lines[l].a, name, what));
    CDFF_RETURN_IF_ERROR(checkIndex(points, lines[l].b, name, what));
    if ((points[lines[l].a] - points[lines[l].b]).norm() <= 0)
      return invalidInput("{} {} joins point {} to itself; expected two distinct ends", what, name,
                          lines[l].a);
  }
  for (std::size_t c = 0; c < cylinders.size(); ++c) {
    const std::string name = describe("cylinder", c, cylinders[c].name);
    CDFF_RETURN_IF_ERROR(checkIndex(points, cylinders[c].a, name, what));
    CDFF_RETURN_IF_ERROR(checkIndex(points, cylinders[c].b, name, what));
    if ((points[cylinders[c].a] - points[cylinders[c].b]).norm() <= 0)
      return invalidInput("{} {} has a zero-length axis; expected two distinct axis points", what,
                          name);
    if (!(cylinders[c].radius > 0) || !std::isfinite(cylinders[c].radius))
      return invalidInput("{} {} has radius {}; expected a positive radius in metres", what, name,
                          cylinders[c].radius);
  }
  for (std::size_t c = 0; c < circles.size(); ++c)
    CDFF_RETURN_IF_ERROR(
        checkCircle(points, circles[c], describe("circle", c, circles[c].name), what));
  return Status::ok();
}

void PolygonModel::append(const PolygonModel& other, const Eigen::Isometry3d& transform) {
  const auto offset = static_cast<std::uint32_t>(points.size());
  for (const Eigen::Vector3d& p : other.points) points.push_back(transform * p);
  for (Face face : other.faces) {
    for (std::uint32_t& p : face.points) p += offset;
    faces.push_back(std::move(face));
  }
  for (Line line : other.lines) {
    line.a += offset;
    line.b += offset;
    lines.push_back(std::move(line));
  }
  for (Cylinder cylinder : other.cylinders) {
    cylinder.a += offset;
    cylinder.b += offset;
    cylinders.push_back(std::move(cylinder));
  }
  for (Circle circle : other.circles) {
    circle.centre += offset;
    circle.first += offset;
    circle.second += offset;
    circles.push_back(std::move(circle));
  }
  if (frame_id.empty()) frame_id = other.frame_id;
}

Eigen::AlignedBox3d PolygonModel::bounds() const {
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : points) box.extend(p);
  return box;
}

// ---------------------------------------------------------------------------------------------
// .cao parsing

namespace {

struct Token {
  std::string text;
  int line = 0;
};

class CaoParser {
 public:
  CaoParser(std::string_view text, std::string source, std::string directory, int depth)
      : source_(std::move(source)), directory_(std::move(directory)), depth_(depth) {
    splitLines(text);
  }

  Result<PolygonModel> parse() {
    std::size_t i = 0;
    CDFF_RETURN_IF_ERROR(readVersion(i));
    PolygonModel model;
    while (i < lines_.size() && lines_[i][0].text.rfind("load(", 0) == 0) {
      Result<PolygonModel> included = include(lines_[i]);
      if (!included) return included.status();
      model.append(*included);
      ++i;
    }
    PolygonModel own;
    CDFF_RETURN_IF_ERROR(readPoints(i, own));
    CDFF_RETURN_IF_ERROR(readLinesAndLineFaces(i, own));
    CDFF_RETURN_IF_ERROR(readPointFaces(i, own));
    // ViSP's parser treats the cylinder and circle sections as optional at the end of a file.
    if (i < lines_.size()) CDFF_RETURN_IF_ERROR(readCylinders(i, own));
    if (i < lines_.size()) CDFF_RETURN_IF_ERROR(readCircles(i, own));
    if (i < lines_.size())
      return error(lines_[i][0].line,
                   "unexpected '{}' after the last section (3D circles); expected the end of "
                   "the file",
                   lines_[i][0].text);
    model.append(own);
    return model;
  }

 private:
  // The sections below read their records from line `i` on and leave `i` after them.

  // An optional version line: V1 (ViSP's format) or V2, alone on its line.
  Status readVersion(std::size_t& i) const {
    if (i < lines_.size() && !lines_[i].empty() && lines_[i][0].text.size() >= 2 &&
        (lines_[i][0].text[0] == 'V' || lines_[i][0].text[0] == 'v')) {
      const Token& version = lines_[i][0];
      if (version.text != "V1" && version.text != "V2")
        return error(version.line, "unsupported .cao version '{}'; expected V1 (or V2)",
                     version.text);
      if (lines_[i].size() > 1)
        return error(version.line, "unexpected '{}' after the version; expected a new line",
                     lines_[i][1].text);
      ++i;
    }
    return Status::ok();
  }

  Status readPoints(std::size_t& i, PolygonModel& own) const {
    std::size_t count = 0;
    CDFF_RETURN_IF_ERROR(readCount(i, "3D points", count));
    for (std::size_t k = 0; k < count; ++k, ++i) {
      std::vector<double> xyz;
      CDFF_RETURN_IF_ERROR(readNumbers(i, "3D points", k, count, 3, xyz, nullptr));
      own.points.emplace_back(xyz[0], xyz[1], xyz[2]);
    }
    return Status::ok();
  }

  // The 3D lines, then the faces made of them: a line that bounds a face is part of that face's
  // outline, the others stay lines of the model.
  Status readLinesAndLineFaces(std::size_t& i, PolygonModel& own) const {
    std::size_t count = 0;
    CDFF_RETURN_IF_ERROR(readCount(i, "3D lines", count));
    std::vector<PolygonModel::Line> lines;
    for (std::size_t k = 0; k < count; ++k, ++i) {
      std::vector<std::uint32_t> ends;
      std::string name;
      CDFF_RETURN_IF_ERROR(
          readIndices(i, "3D lines", k, count, 2, false, own.points.size(), "point", ends, &name));
      lines.push_back({ends[0], ends[1], name});
    }
    std::vector<bool> line_in_face(lines.size(), false);

    CDFF_RETURN_IF_ERROR(readCount(i, "faces from 3D lines", count));
    for (std::size_t k = 0; k < count; ++k, ++i) {
      std::vector<std::uint32_t> ids;
      std::string name;
      CDFF_RETURN_IF_ERROR(readIndices(i, "faces from 3D lines", k, count, 0, true, lines.size(),
                                       "line", ids, &name));
      Result<PolygonModel::Face> face = chainLines(lines, ids, lineOf(i));
      if (!face) return face.status();
      face->name = name;
      for (std::uint32_t id : ids) line_in_face[id] = true;
      own.faces.push_back(std::move(face).value());
    }
    for (std::size_t l = 0; l < lines.size(); ++l)
      if (!line_in_face[l]) own.lines.push_back(lines[l]);
    return Status::ok();
  }

  Status readPointFaces(std::size_t& i, PolygonModel& own) const {
    std::size_t count = 0;
    CDFF_RETURN_IF_ERROR(readCount(i, "faces from 3D points", count));
    for (std::size_t k = 0; k < count; ++k, ++i) {
      PolygonModel::Face face;
      CDFF_RETURN_IF_ERROR(readIndices(i, "faces from 3D points", k, count, 0, true,
                                       own.points.size(), "point", face.points, &face.name));
      if (face.points.size() < 3)
        return error(lineOf(i), "face {} of {} has {} points; expected at least 3", k, count,
                     face.points.size());
      own.faces.push_back(std::move(face));
    }
    return Status::ok();
  }

  Status readCylinders(std::size_t& i, PolygonModel& own) const {
    std::size_t count = 0;
    CDFF_RETURN_IF_ERROR(readCount(i, "3D cylinders", count));
    for (std::size_t k = 0; k < count; ++k, ++i) {
      std::vector<double> values;
      std::string name;
      CDFF_RETURN_IF_ERROR(readNumbers(i, "3D cylinders", k, count, 3, values, &name));
      PolygonModel::Cylinder cylinder;
      CDFF_RETURN_IF_ERROR(
          toIndex(values[0], i, "cylinder axis point", own.points.size(), cylinder.a));
      CDFF_RETURN_IF_ERROR(
          toIndex(values[1], i, "cylinder axis point", own.points.size(), cylinder.b));
      cylinder.radius = values[2];
      cylinder.name = name;
      if (!(cylinder.radius > 0))
        return error(lineOf(i), "cylinder {} of {} has radius {}; expected a positive radius", k,
                     count, cylinder.radius);
      own.cylinders.push_back(cylinder);
    }
    return Status::ok();
  }

  Status readCircles(std::size_t& i, PolygonModel& own) const {
    std::size_t count = 0;
    CDFF_RETURN_IF_ERROR(readCount(i, "3D circles", count));
    for (std::size_t k = 0; k < count; ++k, ++i) {
      std::vector<double> values;
      std::string name;
      CDFF_RETURN_IF_ERROR(readNumbers(i, "3D circles", k, count, 4, values, &name));
      PolygonModel::Circle circle;
      circle.radius = values[0];
      CDFF_RETURN_IF_ERROR(
          toIndex(values[1], i, "circle centre", own.points.size(), circle.centre));
      CDFF_RETURN_IF_ERROR(
          toIndex(values[2], i, "circle plane point", own.points.size(), circle.first));
      CDFF_RETURN_IF_ERROR(
          toIndex(values[3], i, "circle plane point", own.points.size(), circle.second));
      circle.name = name;
      if (!(circle.radius > 0))
        return error(lineOf(i), "circle {} of {} has radius {}; expected a positive radius", k,
                     count, circle.radius);
      own.circles.push_back(circle);
    }
    return Status::ok();
  }

  template <typename... Args>
  Status error(int line, fmt::format_string<Args...> format, Args&&... args) const {
    return {
        StatusCode::kCorruptData,
        fmt::format("{}:{}: {}", source_, line, fmt::format(format, std::forward<Args>(args)...))};
  }

  int lineOf(std::size_t i) const { return i < lines_.size() ? lines_[i][0].line : last_line_; }

  void splitLines(std::string_view text) {
    int number = 0;
    std::size_t start = 0;
    while (start <= text.size()) {
      std::size_t end = text.find('\n', start);
      if (end == std::string_view::npos) end = text.size();
      std::string_view line = text.substr(start, end - start);
      ++number;
      if (const std::size_t hash = line.find('#'); hash != std::string_view::npos)
        line = line.substr(0, hash);
      std::vector<Token> tokens;
      std::size_t p = 0;
      while (p < line.size()) {
        while (p < line.size() && std::isspace(static_cast<unsigned char>(line[p]))) ++p;
        if (p >= line.size()) break;
        std::size_t q = p;
        if (line.substr(p, 5) == "load(") {
          // A path may hold spaces: the token runs to the closing parenthesis.
          const std::size_t close = line.find(')', p);
          q = close == std::string_view::npos ? line.size() : close + 1;
        } else {
          while (q < line.size() && !std::isspace(static_cast<unsigned char>(line[q]))) ++q;
        }
        tokens.push_back({std::string(line.substr(p, q - p)), number});
        p = q;
      }
      if (!tokens.empty()) lines_.push_back(std::move(tokens));
      if (end == text.size()) break;
      start = end + 1;
    }
    last_line_ = number;
  }

  Result<PolygonModel> include(const std::vector<Token>& tokens) {
    const Token& t = tokens[0];
    if (tokens.size() > 1)
      return error(t.line, "unexpected '{}' after {}; expected a new line", tokens[1].text, t.text);
    std::string path = t.text.substr(5);
    if (path.empty() || path.back() != ')')
      return error(t.line, "malformed include '{}'; expected load(\"file.cao\")", t.text);
    path.pop_back();
    if (path.size() >= 2 && path.front() == '"' && path.back() == '"')
      path = path.substr(1, path.size() - 2);
    if (path.empty()) return error(t.line, "load() names no file; expected load(\"file.cao\")");
    if (depth_ >= 16)
      return error(t.line,
                   "load(\"{}\") nests more than 16 includes deep; expected no include "
                   "cycle",
                   path);
    std::filesystem::path resolved(path);
    if (resolved.is_relative()) resolved = std::filesystem::path(directory_) / resolved;
    std::ifstream in(resolved, std::ios::binary);
    if (!in)
      return Status(StatusCode::kNotFound,
                    fmt::format("{}:{}: cannot open the included model '{}' ({})", source_, t.line,
                                resolved.string(), std::strerror(errno)));
    std::stringstream text;
    text << in.rdbuf();
    CaoParser parser(text.str(), resolved.string(), resolved.parent_path().string(), depth_ + 1);
    return parser.parse();
  }

  Status readCount(std::size_t& i, const char* section, std::size_t& count) const {
    if (i >= lines_.size())
      return error(last_line_, "the file ends before the {} section; expected its count", section);
    const std::vector<Token>& tokens = lines_[i];
    char* end = nullptr;
    errno = 0;
    const long value = std::strtol(tokens[0].text.c_str(), &end, 10);
    if (*end != '\0' || value < 0 || errno != 0)
      return error(tokens[0].line, "expected the number of {} (a non-negative integer), got '{}'",
                   section, tokens[0].text);
    if (tokens.size() > 1)
      return error(tokens[0].line, "unexpected '{}' after the number of {}; expected a new line",
                   tokens[1].text, section);
    count = static_cast<std::size_t>(value);
    ++i;
    return Status::ok();
  }

  static bool parseNumber(const std::string& text, double& value) {
    char* end = nullptr;
    errno = 0;
    value = std::strtod(text.c_str(), &end);
    return end != text.c_str() && *end == '\0' && errno == 0 && std::isfinite(value);
  }

  // Options after a record's numbers: `key=value`; `name` is kept, the level-of-detail keys are
  // accepted and ignored (they tune ViSP's own culling).
  Status readOptions(const std::vector<Token>& tokens, std::size_t from, const char* section,
                     std::string* name) const {
    for (std::size_t t = from; t < tokens.size(); ++t) {
      const std::string& text = tokens[t].text;
      const std::size_t eq = text.find('=');
      if (eq == std::string::npos || eq == 0)
        return error(tokens[t].line,
                     "unexpected '{}' in a record of the {} section; expected key=value options "
                     "(name=..., useLod=..., minLineLengthThreshold=..., "
                     "minPolygonAreaThreshold=...)",
                     text, section);
      const std::string key = text.substr(0, eq);
      std::string value = text.substr(eq + 1);
      if (value.size() >= 2 && value.front() == '"' && value.back() == '"')
        value = value.substr(1, value.size() - 2);
      if (key == "name") {
        if (name) *name = value;
      } else if (key != "useLod" && key != "minLineLengthThreshold" &&
                 key != "minPolygonAreaThreshold") {
        return error(tokens[t].line,
                     "unknown option '{}' in the {} section; expected name, useLod, "
                     "minLineLengthThreshold or minPolygonAreaThreshold",
                     key, section);
      }
    }
    return Status::ok();
  }

  Status readNumbers(std::size_t i, const char* section, std::size_t k, std::size_t count,
                     std::size_t n, std::vector<double>& out, std::string* name) const {
    if (i >= lines_.size())
      return error(last_line_,
                   "the file ends at record {} of {} in the {} section; expected {} "
                   "more",
                   k, count, section, count - k);
    const std::vector<Token>& tokens = lines_[i];
    out.clear();
    for (std::size_t t = 0; t < n; ++t) {
      double value = 0;
      if (t >= tokens.size() || tokens[t].text.find('=') != std::string::npos)
        return error(tokens[0].line,
                     "record {} of {} in the {} section has {} numbers; expected {}", k, count,
                     section, t, n);
      if (!parseNumber(tokens[t].text, value))
        return error(tokens[t].line,
                     "record {} of {} in the {} section: '{}' is not a number; expected {} numbers",
                     k, count, section, tokens[t].text, n);
      out.push_back(value);
    }
    if (name == nullptr && tokens.size() > n) {
      // Points take no options: anything more is a malformed record.
      return error(tokens[n].line,
                   "unexpected '{}' after record {} of {} in the {} section; expected {} numbers",
                   tokens[n].text, k, count, section, n);
    }
    return readOptions(tokens, n, section, name);
  }

  Status toIndex(double value, std::size_t i, const char* what, std::size_t limit,
                 std::uint32_t& index) const {
    if (value != std::floor(value) || value < 0 || value >= static_cast<double>(limit))
      return error(lineOf(i), "{} index {} is not a valid index; expected an integer in [0, {}]",
                   what, value, limit == 0 ? 0 : limit - 1);
    index = static_cast<std::uint32_t>(value);
    return Status::ok();
  }

  // A record of indices: `fixed` of them, or (fixed == 0) a count followed by that many.
  Status readIndices(std::size_t i, const char* section, std::size_t k, std::size_t count,
                     std::size_t fixed, bool counted, std::size_t limit, const char* kind,
                     std::vector<std::uint32_t>& out, std::string* name) const {
    if (i >= lines_.size())
      return error(last_line_,
                   "the file ends at record {} of {} in the {} section; expected {} "
                   "more",
                   k, count, section, count - k);
    const std::vector<Token>& tokens = lines_[i];
    std::size_t n = fixed;
    std::size_t first = 0;
    if (counted) {
      double value = 0;
      if (!parseNumber(tokens[0].text, value) || value != std::floor(value) || value < 1)
        return error(tokens[0].line,
                     "record {} of {} in the {} section starts with '{}'; expected the number of "
                     "{} indices that follow",
                     k, count, section, tokens[0].text, kind);
      n = static_cast<std::size_t>(value);
      first = 1;
    }
    out.clear();
    for (std::size_t t = first; t < first + n; ++t) {
      double value = 0;
      if (t >= tokens.size() || tokens[t].text.find('=') != std::string::npos)
        return error(tokens[0].line,
                     "record {} of {} in the {} section lists {} {} indices; expected {}", k, count,
                     section, t - first, kind, n);
      if (!parseNumber(tokens[t].text, value))
        return error(tokens[t].line, "record {} of {} in the {} section: '{}' is not a {} index", k,
                     count, section, tokens[t].text, kind);
      std::uint32_t index = 0;
      if (value != std::floor(value) || value < 0 || value >= static_cast<double>(limit))
        return error(tokens[t].line,
                     "record {} of {} in the {} section refers to {} {}; expected an index in "
                     "[0, {}] ({} {}s are defined before it)",
                     k, count, section, kind, tokens[t].text, limit == 0 ? 0 : limit - 1, limit,
                     kind);
      index = static_cast<std::uint32_t>(value);
      out.push_back(index);
    }
    return readOptions(tokens, first + n, section, name);
  }

  Result<PolygonModel::Face> chainLines(const std::vector<PolygonModel::Line>& lines,
                                        const std::vector<std::uint32_t>& ids, int line) const {
    if (ids.size() < 3)
      return error(line, "a face from lines has {} lines; expected at least 3", ids.size());
    PolygonModel::Face face;
    face.points = {lines[ids[0]].a, lines[ids[0]].b};
    for (std::size_t k = 1; k + 1 < ids.size(); ++k) {
      const PolygonModel::Line& l = lines[ids[k]];
      if (l.a == face.points.back())
        face.points.push_back(l.b);
      else if (l.b == face.points.back())
        face.points.push_back(l.a);
      else
        return error(line,
                     "face from lines: line {} does not start where line {} ends (point {}); "
                     "expected the lines in order around the face",
                     ids[k], ids[k - 1], face.points.back());
    }
    const PolygonModel::Line& last = lines[ids.back()];
    if (!((last.a == face.points.back() && last.b == face.points.front()) ||
          (last.b == face.points.back() && last.a == face.points.front())))
      return error(line,
                   "face from lines: the last line {} does not close the face (from point {} "
                   "back to point {})",
                   ids.back(), face.points.back(), face.points.front());
    return face;
  }

  std::string source_;
  std::string directory_;
  int depth_ = 0;
  std::vector<std::vector<Token>> lines_;
  int last_line_ = 0;
};

std::string sanitiseName(const std::string& name) {
  std::string out = name;
  for (char& c : out)
    if (std::isspace(static_cast<unsigned char>(c)) || c == '#') c = '_';
  return out;
}

}  // namespace

Result<PolygonModel> parseCao(std::string_view text, const std::string& source,
                              const std::string& directory) {
  CaoParser parser(text, source, directory, 0);
  Result<PolygonModel> model = parser.parse();
  if (!model) return model;
  if (model->empty())
    return Status(StatusCode::kCorruptData,
                  fmt::format("{}: the model has no face, line, cylinder or circle; expected at "
                              "least one",
                              source));
  return model;
}

Result<PolygonModel> loadCao(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return Status(StatusCode::kNotFound,
                  fmt::format("cannot open the model file '{}' ({})", path, std::strerror(errno)));
  std::stringstream text;
  text << in.rdbuf();
  if (in.bad()) return ioError("reading the model file '{}' failed", path);
  return parseCao(text.str(), path, std::filesystem::path(path).parent_path().string());
}

std::string toCao(const PolygonModel& model) {
  std::string out = "V1\n";
  out += fmt::format("# CDFF polygon model '{}', metres\n# 3D points\n{}\n", model.frame_id,
                     model.points.size());
  for (const Eigen::Vector3d& p : model.points)
    out += fmt::format("{:.9g} {:.9g} {:.9g}\n", p.x(), p.y(), p.z());
  const auto named = [](const std::string& name) {
    return name.empty() ? std::string() : " name=" + sanitiseName(name);
  };
  out += fmt::format("# 3D lines\n{}\n", model.lines.size());
  for (const PolygonModel::Line& l : model.lines)
    out += fmt::format("{} {}{}\n", l.a, l.b, named(l.name));
  out += "# Faces from 3D lines\n0\n";
  out += fmt::format("# Faces from 3D points (counter-clockwise seen from outside)\n{}\n",
                     model.faces.size());
  for (const PolygonModel::Face& f : model.faces) {
    out += fmt::format("{}", f.points.size());
    for (std::uint32_t p : f.points) out += fmt::format(" {}", p);
    out += named(f.name) + "\n";
  }
  out += fmt::format("# 3D cylinders\n{}\n", model.cylinders.size());
  for (const PolygonModel::Cylinder& c : model.cylinders)
    out += fmt::format("{} {} {:.9g}{}\n", c.a, c.b, c.radius, named(c.name));
  out += fmt::format("# 3D circles\n{}\n", model.circles.size());
  for (const PolygonModel::Circle& c : model.circles)
    out += fmt::format("{:.9g} {} {} {}{}\n", c.radius, c.centre, c.first, c.second, named(c.name));
  return out;
}

Status writeCao(const PolygonModel& model, const std::string& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return ioError("cannot open '{}' for writing ({})", path, std::strerror(errno));
  out << toCao(model);
  out.close();
  if (!out) return ioError("writing '{}' failed", path);
  return Status::ok();
}

}  // namespace cdff
