#include "cdff/serve/router.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "cdff/serve/query.hpp"
#include "cdff/serve/scene.hpp"

namespace cdff::serve {

using nlohmann::json;

namespace {

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// %-decodes `s` ('+' is a space in a query); an error for a truncated or non-hex escape.
Result<std::string> percentDecode(std::string_view s, bool query) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%') {
      const int hi = i + 2 < s.size() ? hexValue(s[i + 1]) : -1;
      const int lo = i + 2 < s.size() ? hexValue(s[i + 2]) : -1;
      if (hi < 0 || lo < 0)
        return invalidInput(
            "'{}' has a malformed %-escape at character {}; expected %XX with "
            "two hexadecimal digits",
            s, i);
      out.push_back(static_cast<char>(hi * 16 + lo));
      i += 2;
    } else {
      out.push_back(query && s[i] == '+' ? ' ' : s[i]);
    }
  }
  return out;
}

http::status httpStatus(const Status& s) {
  switch (s.code()) {
    case StatusCode::kNotFound:
      return http::status::not_found;
    case StatusCode::kInvalidInput:
    case StatusCode::kInvalidParameter:
      return http::status::bad_request;
    default:
      return http::status::internal_server_error;
  }
}

/// 403 for a request whose Origin (a browser names the page's) is not this server's; none when it
/// has no Origin (not a browser) or this server's.
std::optional<Response> foreignOrigin(const Request& req, bool keep_alive) {
  const std::string_view origin = req[http::field::origin];
  const std::string expected = fmt::format("http://{}", req[http::field::host]);
  if (origin.empty() || origin == expected) return std::nullopt;
  return errorResponse(
      http::status::forbidden,
      fmt::format("Origin '{}' is not this server's; expected '{}'", origin, expected),
      req.version(), keep_alive);
}

Response fromStatus(const Request& req, const Status& s) {
  return errorResponse(httpStatus(s), s.message(), req.version(), req.keep_alive());
}

void commonHeaders(Response& res) {
  res.set(http::field::server, "cdff serve");
  res.set(http::field::cache_control, "no-store");
  res.set("X-Content-Type-Options", "nosniff");
}

Response jsonResponse(const Request& req, const json& body) {
  Response res{http::status::ok, req.version()};
  commonHeaders(res);
  res.set(http::field::content_type, "application/json");
  res.keep_alive(req.keep_alive());
  res.body() = body.dump(-1, ' ', false, json::error_handler_t::replace);
  res.prepare_payload();
  return res;
}

// A binary body (scene.hpp's mesh layout), read by the browser as an ArrayBuffer.
Response binaryResponse(const Request& req, std::string body) {
  Response res{http::status::ok, req.version()};
  commonHeaders(res);
  res.set(http::field::content_type, "application/octet-stream");
  res.keep_alive(req.keep_alive());
  res.body() = std::move(body);
  res.prepare_payload();
  return res;
}

Response methodNotAllowed(const Request& req, const char* allowed) {
  Response res = errorResponse(
      http::status::method_not_allowed,
      fmt::format("method {} on '{}': expected {}", req.method_string(), req.target(), allowed),
      req.version(), req.keep_alive());
  res.set(http::field::allow, allowed);
  return res;
}

// Constant-time comparison: the time taken does not tell how much of a guess was right.
bool sameToken(std::string_view a, std::string_view b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < a.size(); ++i)
    diff |= static_cast<unsigned char>(a[i] ^ (i < b.size() ? b[i] : 0));
  return diff == 0;
}

// A cookie cdff_token<...> holding the token (set by tokenCookie() on the page's first load, so
// that the page's own files and requests carry it).
bool hasTokenCookie(std::string_view header, const std::string& token) {
  while (!header.empty()) {
    const std::size_t end = std::min(header.find(';'), header.size());
    std::string_view cookie = header.substr(0, end);
    header = end < header.size() ? header.substr(end + 1) : std::string_view();
    while (cookie.starts_with(' ')) cookie.remove_prefix(1);
    const std::size_t eq = cookie.find('=');
    if (eq != std::string_view::npos && cookie.starts_with("cdff_token") &&
        sameToken(cookie.substr(eq + 1), token))
      return true;
  }
  return false;
}

bool isLoopbackHost(std::string_view host) {
  // Host without its port ("[::1]:8080" -> "[::1]", "localhost:80" -> "localhost").
  const std::size_t colon = host.rfind(':');
  if (colon != std::string_view::npos && host.find(']', colon) == std::string_view::npos)
    host = host.substr(0, colon);
  return host == "127.0.0.1" || host == "localhost" || host == "[::1]";
}

const char* contentType(const std::filesystem::path& file) {
  static const std::map<std::string, const char*> types = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".png", "image/png"},
      {".svg", "image/svg+xml"},
      {".ico", "image/x-icon"},
      {".map", "application/json"}};
  auto it = types.find(file.extension().string());
  return it == types.end() ? nullptr : it->second;
}

}  // namespace

Result<Target> parseTarget(std::string_view target) {
  if (target.empty() || target.front() != '/')
    return invalidInput("request target '{}': expected an absolute path starting with '/'", target);
  Target out;
  const std::size_t q = target.find('?');
  const std::string_view path = target.substr(0, q);
  std::size_t start = 1;
  while (start <= path.size()) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    const std::string_view raw = path.substr(start, end - start);
    Result<std::string> seg = percentDecode(raw, false);
    if (!seg) return seg.status();
    const bool last = end == path.size();
    if (seg->empty() && !last)
      return invalidInput("path '{}' has an empty segment; expected no '//'", path);
    if (*seg == "." || *seg == ".." ||
        seg->find_first_of(std::string("/\\\0", 3)) != std::string::npos)
      return invalidInput(
          "path '{}' has the segment '{}'; expected names without '.', '..', "
          "'/', '\\' or NUL",
          path, *seg);
    if (!seg->empty()) out.segments.push_back(std::move(*seg));
    start = end + 1;
  }
  if (q == std::string_view::npos) return out;
  std::string_view rest = target.substr(q + 1);
  while (!rest.empty()) {
    const std::size_t amp = rest.find('&');
    const std::string_view pair = rest.substr(0, amp);
    rest = amp == std::string_view::npos ? std::string_view() : rest.substr(amp + 1);
    if (pair.empty()) continue;
    const std::size_t eq = pair.find('=');
    Result<std::string> key = percentDecode(pair.substr(0, eq), true);
    if (!key) return key.status();
    Result<std::string> value = percentDecode(
        eq == std::string_view::npos ? std::string_view() : pair.substr(eq + 1), true);
    if (!value) return value.status();
    out.query.emplace(std::move(*key), std::move(*value));
  }
  return out;
}

Response errorResponse(http::status status, const std::string& message, unsigned version,
                       bool keep_alive) {
  Response res{status, version};
  commonHeaders(res);
  res.set(http::field::content_type, "application/json");
  res.keep_alive(keep_alive);
  res.body() = json{{"error", message}}.dump(-1, ' ', false, json::error_handler_t::replace);
  res.prepare_payload();
  return res;
}

Router::Router(const std::vector<std::unique_ptr<Recording>>& recordings, RouterOptions options)
    : recordings_(recordings), options_(std::move(options)) {}

std::optional<Response> Router::admit(const Request& req, Target& target) const {
  const auto refuse = [&](http::status status, const std::string& message) {
    return errorResponse(status, message, req.version(), false);
  };
  Result<Target> parsed = parseTarget(req.target());
  if (!parsed) return refuse(http::status::bad_request, parsed.status().message());
  target = std::move(*parsed);
  if (options_.token.empty()) {
    // Without a token the server is only on the loopback interface; a Host naming another
    // server is a page of another site reaching it by DNS rebinding.
    const std::string_view host = req[http::field::host];
    if (!isLoopbackHost(host))
      return refuse(http::status::forbidden,
                    fmt::format("Host '{}' is not this server; expected 127.0.0.1, localhost or "
                                "[::1] with its port",
                                host));
  } else {
    std::string given;
    const std::string_view auth = req[http::field::authorization];
    if (auth.starts_with("Bearer ")) given = std::string(auth.substr(7));
    auto q = target.query.find("token");
    if (given.empty() && q != target.query.end()) given = q->second;
    const bool cookie = given.empty() && hasTokenCookie(req[http::field::cookie], options_.token);
    if (given.empty() && !cookie)
      return refuse(http::status::unauthorized,
                    "this server requires its token (printed by `cdff serve` at start); expected "
                    "'Authorization: Bearer <token>' or '?token=<token>'");
    if (!cookie && !sameToken(given, options_.token))
      return refuse(http::status::unauthorized,
                    "the token does not match the one printed by `cdff serve` at start");
  }
  target.query.erase("token");
  return std::nullopt;
}

Result<const Recording*> Router::recording(const std::string& id) const {
  std::size_t index = 0;
  const auto [end, ec] = std::from_chars(id.data(), id.data() + id.size(), index);
  if (ec != std::errc() || end != id.data() + id.size() || index >= recordings_.size())
    return notFound("recording '{}' does not exist; expected an index in [0, {})", id,
                    recordings_.size());
  return recordings_[index].get();
}

Response Router::handle(const Request& req) const {
  Target target;
  if (std::optional<Response> refused = admit(req, target)) return std::move(*refused);
  const bool api_route = !target.segments.empty() && target.segments[0] == "api";
  Response res = api_route ? api(req, target) : file(req, target);
  // The page was opened with ?token=: its scripts, styles and requests carry the token as a
  // cookie from then on. Named per port (cookies are not), readable by no script, sent to no
  // other site.
  if (!options_.token.empty() && !api_route && res.result() == http::status::ok) {
    const std::string_view host = req[http::field::host];
    const std::size_t colon = host.rfind(':');
    std::string port = colon == std::string_view::npos ? "" : std::string(host.substr(colon + 1));
    if (port.find_first_not_of("0123456789") != std::string::npos) port.clear();
    res.set(http::field::set_cookie, fmt::format("cdff_token{}={}; Path=/; HttpOnly; "
                                                 "SameSite=Strict",
                                                 port.empty() ? "" : "_" + port, options_.token));
  }
  return res;
}

Response Router::file(const Request& req, const Target& target) const {
  namespace fs = std::filesystem;
  if (req.method() != http::verb::get) {
    Response res = errorResponse(
        http::status::method_not_allowed,
        fmt::format("method {} on '{}': expected GET", req.method_string(), req.target()),
        req.version(), req.keep_alive());
    res.set(http::field::allow, "GET");
    return res;
  }
  if (!target.query.empty())
    if (Status s = expectParameters(target.query, {}); !s.isOk()) return fromStatus(req, s);
  fs::path relative;
  for (const std::string& s : target.segments) relative /= s;
  if (target.segments.empty()) relative = "index.html";
  const fs::path path = options_.app_dir / relative;
  const char* type = contentType(path);
  std::error_code ec;
  // The canonical path must stay inside the application's directory (no link leads out).
  const fs::path root = fs::canonical(options_.app_dir, ec);
  const fs::path real = fs::canonical(path, ec);
  const bool inside =
      !ec && std::mismatch(root.begin(), root.end(), real.begin(), real.end()).first == root.end();
  if (!type || !inside || !fs::is_regular_file(real, ec))
    return errorResponse(http::status::not_found,
                         fmt::format("'{}' is neither an API route (/api/...) nor a file of the "
                                     "web application",
                                     req.target()),
                         req.version(), req.keep_alive());
  std::ifstream in(real, std::ios::binary);
  std::ostringstream body;
  body << in.rdbuf();
  if (!in) return fromStatus(req, ioError("cannot read '{}'", real.string()));
  Response res{http::status::ok, req.version()};
  commonHeaders(res);
  res.set(http::field::content_type, type);
  res.set("Content-Security-Policy",
          "default-src 'self'; img-src 'self' blob: data:; style-src 'self' 'unsafe-inline'");
  res.keep_alive(req.keep_alive());
  res.body() = body.str();
  res.prepare_payload();
  return res;
}

// ---- /api ------------------------------------------------------------------------------------

namespace {

struct MessagesQuery {
  std::string channel;
  double t = 0;
  std::size_t count = 1;
};

// The body of POST .../messages: {"channel": "/topic", "t": seconds, "count": n}.
Result<MessagesQuery> messagesFromBody(const Request& req) {
  const std::string_view type = req[http::field::content_type];
  if (!type.starts_with("application/json"))
    return invalidInput("Content-Type '{}': expected application/json", type);
  json body;
  try {
    body = json::parse(req.body());
  } catch (const json::parse_error& e) {
    return invalidInput(
        "the body is not JSON ({}); expected {{\"channel\": \"/topic\", \"t\": "
        "seconds, \"count\": n}}",
        e.what());
  }
  if (!body.is_object())
    return invalidInput("the body is {}; expected a JSON object", body.type_name());
  MessagesQuery q;
  for (const auto& [key, value] : body.items()) {
    if (key == "channel" && value.is_string()) {
      q.channel = value.get<std::string>();
    } else if (key == "t" && value.is_number()) {
      q.t = value.get<double>();
    } else if (key == "count" && value.is_number_unsigned() && value.get<std::size_t>() >= 1 &&
               value.get<std::size_t>() <= 1000) {
      q.count = value.get<std::size_t>();
    } else if (key == "channel" || key == "t" || key == "count") {
      return invalidInput("\"{}\" = {}: expected {}", key, value.dump(),
                          key == "channel" ? "a channel's topic (a string)"
                          : key == "t"     ? "seconds from the recording's start (a number)"
                                           : "an integer in [1, 1000]");
    } else {
      return invalidInput("key \"{}\" is unknown; expected one of {{channel, t, count}}", key);
    }
  }
  if (q.channel.empty()) return invalidInput("\"channel\" is missing; expected a topic");
  return q;
}

Result<MessagesQuery> messagesFromQuery(const Query& query) {
  CDFF_RETURN_IF_ERROR(expectParameters(query, {"channel", "t", "count"}));
  MessagesQuery q;
  Result<std::string> channel = requiredText(query, "channel", "a channel's topic");
  if (!channel) return channel.status();
  q.channel = *channel;
  Result<double> t = number(query, "t", 0, 0, 1e12, "seconds from the recording's start");
  if (!t) return t.status();
  Result<double> count = number(query, "count", 1, 1, 1000, "a number of messages");
  if (!count) return count.status();
  q.t = *t;
  q.count = static_cast<std::size_t>(*count);
  return q;
}

Response imageResponse(const Request& req, const Recording& rec, const Query& query) {
  if (Status s = expectParameters(query, {"channel", "t", "max_width", "quality"}); !s.isOk())
    return fromStatus(req, s);
  Result<std::string> channel = requiredText(query, "channel", "an Image channel's topic");
  Result<double> t = number(query, "t", 0, 0, 1e12, "seconds from the recording's start");
  Result<double> width = number(query, "max_width", 640, 16, 4096, "pixels");
  Result<double> quality = number(query, "quality", 80, 1, 100, "a JPEG quality");
  for (const Status* s : {&channel.status(), &t.status(), &width.status(), &quality.status()})
    if (!s->isOk()) return fromStatus(req, *s);
  Result<EncodedImage> image =
      rec.imageAt(*channel, *t, static_cast<int>(*width), static_cast<int>(*quality));
  if (!image) return fromStatus(req, image.status());
  Response res{http::status::ok, req.version()};
  commonHeaders(res);
  res.set(http::field::content_type, "image/jpeg");
  res.set("X-CDFF-Log-Time-Ns", std::to_string(image->log_time_ns));
  res.set("X-CDFF-T", fmt::format("{:.9f}", rec.secondsOf(image->log_time_ns)));
  res.keep_alive(req.keep_alive());
  res.body().assign(image->jpeg.begin(), image->jpeg.end());
  res.prepare_payload();
  return res;
}

// /api/recordings/<id>[/<what>] of one recording.
Response recordingRoute(const Request& req, const Target& target, const Recording& rec) {
  const auto& seg = target.segments;
  const bool get = req.method() == http::verb::get;
  const std::string what = seg.size() == 4 ? seg[3] : "";
  if (what == "messages") {
    if (!get && req.method() != http::verb::post) return methodNotAllowed(req, "GET, POST");
    Result<MessagesQuery> q = get ? messagesFromQuery(target.query) : messagesFromBody(req);
    if (!q && !get && q.status().reason().starts_with("Content-Type"))
      return errorResponse(http::status::unsupported_media_type, q.status().message(),
                           req.version(), req.keep_alive());
    if (!q) return fromStatus(req, q.status());
    Result<json> messages = rec.messages(q->channel, q->t, q->count);
    return messages ? jsonResponse(req, *messages) : fromStatus(req, messages.status());
  }
  if (!get) return methodNotAllowed(req, "GET");
  if (what.empty()) {
    if (Status s = expectParameters(target.query, {}); !s.isOk()) return fromStatus(req, s);
    json j = rec.summary(true);
    j["id"] = std::stoul(seg[2]);
    return jsonResponse(req, j);
  }
  if (what == "image") return imageResponse(req, rec, target.query);
  if (what == "poses") {
    if (Status s = expectParameters(target.query, {"channel", "max_points", "via"}); !s.isOk())
      return fromStatus(req, s);
    Result<std::string> channel = requiredText(target.query, "channel", "a pose channel's topic");
    if (!channel) return fromStatus(req, channel.status());
    Result<double> points = number(target.query, "max_points", 5000, 2, 1e6, "a number of points");
    if (!points) return fromStatus(req, points.status());
    const auto via = target.query.find("via");
    Result<json> poses = rec.poses(*channel, static_cast<std::size_t>(*points),
                                   via == target.query.end() ? "" : via->second);
    return poses ? jsonResponse(req, *poses) : fromStatus(req, poses.status());
  }
  if (what == "mesh") {
    if (Status s = expectParameters(target.query, {"channel"}); !s.isOk())
      return fromStatus(req, s);
    Result<std::string> channel =
        requiredText(target.query, "channel", "a TriangleMesh channel's topic");
    if (!channel) return fromStatus(req, channel.status());
    Result<std::string> body = rec.meshBody(*channel);
    return body ? binaryResponse(req, std::move(*body)) : fromStatus(req, body.status());
  }
  if (what == "contour") {
    if (Status s = expectParameters(target.query, {"image", "t", "pose", "mesh"}); !s.isOk())
      return fromStatus(req, s);
    Result<std::string> image = requiredText(target.query, "image", "an Image channel's topic");
    Result<std::string> pose = requiredText(target.query, "pose", "a pose channel's topic");
    Result<double> t = number(target.query, "t", 0, 0, 1e12, "seconds from the recording's start");
    for (const Status* s : {&image.status(), &pose.status(), &t.status()})
      if (!s->isOk()) return fromStatus(req, *s);
    const auto mesh = target.query.find("mesh");
    Result<json> contour =
        rec.contour(*image, *t, *pose, mesh == target.query.end() ? "" : mesh->second);
    return contour ? jsonResponse(req, *contour) : fromStatus(req, contour.status());
  }
  if (what == "errors") {
    if (Status s = expectParameters(target.query, {"estimate", "truth", "max_points"}); !s.isOk())
      return fromStatus(req, s);
    Result<std::string> estimate =
        requiredText(target.query, "estimate", "a pose product's topic (/cdff/<dfpc>/<output>)");
    if (!estimate) return fromStatus(req, estimate.status());
    const auto truth = target.query.find("truth");
    Result<double> points = number(target.query, "max_points", 5000, 2, 1e6, "a number of points");
    if (!points) return fromStatus(req, points.status());
    Result<json> errors = rec.errors(*estimate, truth == target.query.end() ? "" : truth->second,
                                     static_cast<std::size_t>(*points));
    return errors ? jsonResponse(req, *errors) : fromStatus(req, errors.status());
  }
  if (what == "stream")
    return errorResponse(http::status::bad_request,
                         "'stream' is a WebSocket endpoint; expected an Upgrade: websocket request",
                         req.version(), req.keep_alive());
  return errorResponse(http::status::not_found,
                       fmt::format("no API route '{}'; expected messages, image, poses, mesh, "
                                   "errors, contour or stream after /api/recordings/<id>",
                                   req.target()),
                       req.version(), req.keep_alive());
}

}  // namespace

Response Router::api(const Request& req, const Target& target) const {
  const auto& seg = target.segments;
  const bool get = req.method() == http::verb::get;
  if (seg.size() >= 2 && (seg[1] == "live" || seg[1] == "graphs")) return live(req, target);
  if (seg.size() == 2 && seg[1] == "requirements") {
    if (!get) return methodNotAllowed(req, "GET");
    if (Status s = expectParameters(target.query, {}); !s.isOk()) return fromStatus(req, s);
    return jsonResponse(req, json{{"pose", poseThresholdsJson()}});
  }
  if (seg.size() < 2 || seg[1] != "recordings" || seg.size() > 4)
    return errorResponse(
        http::status::not_found,
        fmt::format("no API route '{}'; expected /api/recordings[/<id>[/messages"
                    "|image|poses|mesh|errors|contour|stream]], /api/requirements, "
                    "/api/graphs[/model] or /api/live[/state]",
                    req.target()),
        req.version(), req.keep_alive());
  if (seg.size() == 2) {
    if (!get) return methodNotAllowed(req, "GET");
    if (Status s = expectParameters(target.query, {}); !s.isOk()) return fromStatus(req, s);
    json list = json::array();
    for (std::size_t i = 0; i < recordings_.size(); ++i) {
      json j = recordings_[i]->summary(false);
      j["id"] = i;
      list.push_back(std::move(j));
    }
    return jsonResponse(req, list);
  }
  Result<const Recording*> rec = recording(seg[2]);
  if (!rec) return fromStatus(req, rec.status());
  return recordingRoute(req, target, **rec);
}

std::variant<Router::Stream, Response> Router::stream(const Request& req) const {
  Target target;
  if (std::optional<Response> refused = admit(req, target)) return std::move(*refused);
  const auto& seg = target.segments;
  const bool is_live = seg.size() == 2 && seg[0] == "ws" && seg[1] == "live" && options_.live;
  if (!is_live &&
      (seg.size() != 4 || seg[0] != "api" || seg[1] != "recordings" || seg[3] != "stream"))
    return errorResponse(http::status::not_found,
                         fmt::format("no WebSocket endpoint '{}'; expected "
                                     "/api/recordings/<id>/stream or /ws/live",
                                     req.target()),
                         req.version(), false);
  // A browser sends the page's origin: a page of another site must not open the stream
  // (WebSockets are not bound by the same-origin policy).
  if (std::optional<Response> refused = foreignOrigin(req, false)) return std::move(*refused);
  if (is_live) {
    if (Status s = expectParameters(target.query, {}); !s.isOk()) return fromStatus(req, s);
    Stream out;
    out.live = true;
    return out;
  }
  Result<const Recording*> rec = recording(seg[2]);
  if (!rec) return fromStatus(req, rec.status());
  if (Status s = expectParameters(target.query,
                                  {"image", "pose", "points", "max_width", "max_points"}, "pose");
      !s.isOk())
    return fromStatus(req, s);
  Stream out;
  out.recording = *rec;
  if (auto it = target.query.find("image"); it != target.query.end()) out.spec.image = it->second;
  for (auto [it, end] = target.query.equal_range("pose"); it != end; ++it)
    out.spec.poses.push_back(it->second);
  Result<double> width = number(target.query, "max_width", 640, 16, 4096, "pixels");
  if (!width) return fromStatus(req, width.status());
  out.spec.max_width = static_cast<int>(*width);
  if (auto it = target.query.find("points"); it != target.query.end()) out.spec.points = it->second;
  Result<double> points = number(target.query, "max_points", 20000, 1,
                                 static_cast<double>(kMaxCloudPoints), "a number of points");
  if (!points) return fromStatus(req, points.status());
  out.spec.max_points = static_cast<std::size_t>(*points);
  if (Status s = validate(**rec, out.spec); !s.isOk()) return fromStatus(req, s);
  return out;
}

}  // namespace cdff::serve

// ---- /api/live ---------------------------------------------------------------------------------

namespace cdff::serve {

namespace {

// A JSON object body: the parsed object, or the error response (415 for the content type, 400
// for text that does not parse or is not an object).
std::variant<json, Response> objectBody(const Request& req, const char* expected) {
  const std::string_view type = req[http::field::content_type];
  if (!type.starts_with("application/json"))
    return errorResponse(http::status::unsupported_media_type,
                         fmt::format("Content-Type '{}': expected application/json", type),
                         req.version(), req.keep_alive());
  json body = json::parse(req.body(), nullptr, false);
  if (body.is_discarded() || !body.is_object())
    return errorResponse(http::status::bad_request,
                         fmt::format("the body '{}' is not a JSON object; expected {}",
                                     req.body().substr(0, 200), expected),
                         req.version(), req.keep_alive());
  return body;
}

Result<LiveSpec> liveSpec(const json& body) {
  LiveSpec spec;
  bool graph = false, recording = false;
  for (const auto& [key, value] : body.items()) {
    if (key == "graph" && value.is_string()) {
      spec.graph = value.get<std::string>();
      graph = true;
    } else if (key == "recording" && value.is_number_unsigned()) {
      spec.recording = value.get<std::size_t>();
      recording = true;
    } else if (key == "speed" && value.is_number()) {
      spec.speed = value.get<double>();
    } else if (key == "camera" && value.is_string()) {
      spec.camera = value.get<std::string>();
    } else if (key == "points" && value.is_string()) {
      spec.points = value.get<std::string>();
    } else if (key == "graph" || key == "recording" || key == "speed" || key == "camera" ||
               key == "points") {
      return invalidInput("\"{}\" = {}: expected {}", key, value.dump(),
                          key == "graph"       ? "a graph of GET /api/graphs (a string)"
                          : key == "recording" ? "a recording's id (an integer)"
                          : key == "speed"     ? "a factor in [0.0625, 16] (a number)"
                          : key == "camera"    ? "an Image channel's topic (a string)"
                                               : "a PointCloud channel's topic (a string)");
    } else {
      return invalidInput(
          "key \"{}\" is unknown; expected one of {{graph, recording, speed, camera, points}}",
          key);
    }
  }
  if (!graph) return invalidInput("\"graph\" is missing; expected a graph of GET /api/graphs");
  if (!recording) return invalidInput("\"recording\" is missing; expected a recording's id");
  return spec;
}

}  // namespace

namespace {

// The API refuses what its state does not allow: a conflict with that state (409), with the
// API's message; no run, or an unknown DFPC, is 404.
Response refusedByApi(const Request& req, const Status& s) {
  return errorResponse(
      s.code() == StatusCode::kNotFound ? http::status::not_found : http::status::conflict,
      s.message(), req.version(), req.keep_alive());
}

// A body {"request": ...} with no other key, or the error response.
std::variant<json, Response> requestBody(const Request& req, const char* expected) {
  auto body = objectBody(req, expected);
  if (std::holds_alternative<Response>(body)) return body;
  for (const auto& [key, value] : std::get<json>(body).items())
    if (key != "request")
      return fromStatus(req, invalidInput("key \"{}\" is unknown; expected only \"request\"", key));
  return body;
}

// POST /api/live/dfpcs/<dfpc> {"request": "init" | "stop"}: initDFPC, stopDFPC.
Response liveDfpcRoute(const Request& req, LiveHub& hub, const std::string& dfpc) {
  if (req.method() != http::verb::post) return methodNotAllowed(req, "POST");
  auto body = requestBody(req, "{\"request\": \"init\"|\"stop\"}");
  if (Response* r = std::get_if<Response>(&body)) return std::move(*r);
  const json request = std::get<json>(body).value("request", json());
  if (request != "init" && request != "stop")
    return fromStatus(req, invalidInput("\"request\" = {}: expected \"init\" (initDFPC) or "
                                        "\"stop\" (stopDFPC)",
                                        request.dump()));
  Status s = hub.dfpcRequest(dfpc, request == "init");
  if (!s.isOk()) return refusedByApi(req, s);
  return jsonResponse(req, hub.state());
}

// POST /api/live/state {"request": "idle" | "initialize" | "reset" | "stop"}: setCDFFState.
Response liveStateRoute(const Request& req, LiveHub& hub) {
  if (req.method() != http::verb::post) return methodNotAllowed(req, "POST");
  auto body = requestBody(req, "{\"request\": \"idle\"|\"initialize\"|\"reset\"|\"stop\"}");
  if (Response* r = std::get_if<Response>(&body)) return std::move(*r);
  const json& b = std::get<json>(body);
  if (!b.contains("request") || !b["request"].is_string())
    return fromStatus(req, invalidInput("\"request\" = {}: expected one of idle, initialize, "
                                        "reset, stop (a string)",
                                        b.value("request", json()).dump()));
  Result<api::StateRequest> request = parseStateRequest(b["request"].get<std::string>());
  if (!request) return fromStatus(req, request.status());
  Status s = hub.request(*request);
  if (!s.isOk()) return refusedByApi(req, s);
  return jsonResponse(req, hub.state());
}

// POST /api/live/designation {"x", "y", "w", "h"}: designateTarget, the box in full-resolution
// pixels of the run's camera image (the page converts from the decimated image it shows).
Response liveDesignationRoute(const Request& req, LiveHub& hub) {
  if (req.method() != http::verb::post) return methodNotAllowed(req, "POST");
  constexpr const char* kExpected =
      "{\"x\", \"y\", \"w\", \"h\"}: the box's corner and size in full-resolution pixels of "
      "the camera image";
  auto body = objectBody(req, kExpected);
  if (Response* r = std::get_if<Response>(&body)) return std::move(*r);
  const json& b = std::get<json>(body);
  for (const auto& [key, value] : b.items())
    if (key != "x" && key != "y" && key != "w" && key != "h")
      return fromStatus(req, invalidInput("key \"{}\" is unknown; expected {}", key, kExpected));
  double box[4] = {0, 0, 0, 0};
  const char* keys[4] = {"x", "y", "w", "h"};
  for (int i = 0; i < 4; ++i) {
    if (!b.contains(keys[i]))
      return fromStatus(req, invalidInput("\"{}\" is missing; expected {}", keys[i], kExpected));
    const json& v = b[keys[i]];
    const bool size = i >= 2;
    // A size is a whole number of pixels, at least one; the corner may be sub-pixel.
    if (!v.is_number() || (size && !(v.get<double>() >= 1 && v.get<double>() <= 1e6 &&
                                     v.get<double>() == std::floor(v.get<double>()))))
      return fromStatus(req,
                        invalidInput("\"{}\" = {}: expected {}", keys[i], v.dump(),
                                     size ? "a whole number of pixels in [1, 1e6]"
                                          : "a pixel coordinate (a number) in the camera image"));
    box[i] = v.get<double>();
  }
  bool no_run = false;
  Result<json> d =
      hub.designate(box[0], box[1], static_cast<int>(box[2]), static_cast<int>(box[3]), no_run);
  if (no_run) return fromStatus(req, d.status());
  // The API's refusals: a box that leaves the image is the request's fault (400); no DFPC that
  // reads designations, or no image yet, is the run's state (409).
  if (!d)
    return errorResponse(d.status().code() == StatusCode::kInvalidInput ? http::status::bad_request
                                                                        : http::status::conflict,
                         d.status().message(), req.version(), req.keep_alive());
  return jsonResponse(req, json{{"designation", *d}});
}

}  // namespace

Response Router::live(const Request& req, const Target& target) const {
  const auto& seg = target.segments;
  const bool state_route = seg.size() == 3 && seg[1] == "live" && seg[2] == "state";
  const bool dfpc_route = seg.size() == 4 && seg[1] == "live" && seg[2] == "dfpcs";
  const bool designation_route = seg.size() == 3 && seg[1] == "live" && seg[2] == "designation";
  const bool model_route = seg.size() == 3 && seg[1] == "graphs" && seg[2] == "model";
  if (!options_.live ||
      (seg.size() > 2 && !state_route && !dfpc_route && !designation_route && !model_route))
    return errorResponse(http::status::not_found,
                         fmt::format("no API route '{}'; expected /api/graphs, /api/live, "
                                     "/api/graphs/model, /api/live/state, /api/live/designation "
                                     "or /api/live/dfpcs/<dfpc>",
                                     req.target()),
                         req.version(), req.keep_alive());
  if (Status s = expectParameters(target.query,
                                  model_route ? std::initializer_list<std::string_view>{"graph"}
                                              : std::initializer_list<std::string_view>{});
      !s.isOk())
    return fromStatus(req, s);
  // A command (anything but GET) from a page of another site is refused, as the stream is: a
  // browser names the page's origin.
  if (req.method() != http::verb::get)
    if (std::optional<Response> refused = foreignOrigin(req, req.keep_alive()))
      return std::move(*refused);
  LiveHub& hub = *options_.live;
  if (seg[1] == "graphs" && !model_route) {
    if (req.method() != http::verb::get) return methodNotAllowed(req, "GET");
    return jsonResponse(req, json{{"graphs", hub.graphs()}});
  }
  if (dfpc_route) return liveDfpcRoute(req, hub, seg[3]);
  if (designation_route) return liveDesignationRoute(req, hub);
  if (model_route) {
    if (req.method() != http::verb::get) return methodNotAllowed(req, "GET");
    Result<std::string> graph = requiredText(target.query, "graph", "a graph of GET /api/graphs");
    if (!graph) return fromStatus(req, graph.status());
    Result<std::string> body = hub.modelBody(*graph);
    return body ? binaryResponse(req, std::move(*body)) : fromStatus(req, body.status());
  }
  if (state_route) return liveStateRoute(req, hub);
  if (req.method() == http::verb::get) return jsonResponse(req, hub.state());
  if (req.method() == http::verb::delete_) {
    Status s = hub.remove();
    if (!s.isOk()) return fromStatus(req, s);
    return jsonResponse(req, hub.state());
  }
  if (req.method() != http::verb::post) return methodNotAllowed(req, "GET, POST, DELETE");
  auto body = objectBody(req, "{\"graph\", \"recording\", \"speed\"}");
  if (Response* refused = std::get_if<Response>(&body)) return std::move(*refused);
  Result<LiveSpec> spec = liveSpec(std::get<json>(body));
  if (!spec) return fromStatus(req, spec.status());
  bool conflict = false;
  Status s = hub.start(*spec, conflict);
  if (conflict)
    return errorResponse(http::status::conflict, s.message(), req.version(), req.keep_alive());
  if (!s.isOk()) return fromStatus(req, s);
  return jsonResponse(req, hub.state());
}

}  // namespace cdff::serve
