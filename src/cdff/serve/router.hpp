#pragma once
// What `cdff serve` answers (docs/web-ui.md): the web application's files, the REST/JSON queries
// on the recordings, and the checks in front of them. Independent of the network: a request in,
// a response out (server.hpp moves them over TCP).
//
// Every refusal is a 4xx response with a JSON body {"error": "<what, which value, what was
// expected>"}: a request without the token when one is required (401), a Host or Origin that is
// not this server's (403), a path with '..', '.', a backslash or a bad %-escape (400), an unknown
// route, recording or file (404), a wrong method (405), an unknown or malformed query parameter or
// body (400), a body that is not JSON (415 for the content type, 400 for its text).

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include <boost/beast/http.hpp>

#include "cdff/serve/live_run.hpp"
#include "cdff/serve/recording.hpp"
#include "cdff/serve/replay_stream.hpp"

namespace cdff::serve {

namespace http = boost::beast::http;
using Request = http::request<http::string_body>;
using Response = http::response<http::string_body>;

struct RouterOptions {
  std::filesystem::path app_dir;  // the bundled web application (index.html, app.js, app.css)
  /// Required on every request when not empty (Authorization: Bearer <token>, or ?token=).
  /// Without one, the Host header must name the loopback interface.
  std::string token;
  /// The live run and its graphs (/api/graphs, /api/live, /ws/live); none when null.
  std::shared_ptr<LiveHub> live;
};

/// A request target split into its %-decoded path segments and query parameters.
struct Target {
  std::vector<std::string> segments;
  std::multimap<std::string, std::string> query;
};

/// Splits and decodes a request target; an error for '.', '..', a backslash, a NUL, an empty
/// segment or a malformed %-escape (anything that could leave the served directories).
Result<Target> parseTarget(std::string_view target);

/// A JSON error response {"error": message}.
Response errorResponse(http::status status, const std::string& message, unsigned version = 11,
                       bool keep_alive = false);

class Router {
 public:
  Router(const std::vector<std::unique_ptr<Recording>>& recordings, RouterOptions options);

  /// The response to a request that is not a WebSocket upgrade.
  Response handle(const Request& request) const;

  /// A WebSocket upgrade to /api/recordings/<id>/stream (the recording and what to stream) or
  /// to /ws/live (`live`: the live run's frames), or the error response to send instead.
  struct Stream {
    const Recording* recording = nullptr;
    StreamSpec spec;
    bool live = false;
  };
  std::variant<Stream, Response> stream(const Request& request) const;

 private:
  /// The checks every request passes: target, token, Host. Fills `target` or returns an error.
  std::optional<Response> admit(const Request& request, Target& target) const;
  Response api(const Request& request, const Target& target) const;
  Response file(const Request& request, const Target& target) const;
  Response live(const Request& request, const Target& target) const;
  Result<const Recording*> recording(const std::string& id) const;

  const std::vector<std::unique_ptr<Recording>>& recordings_;
  RouterOptions options_;
};

}  // namespace cdff::serve
