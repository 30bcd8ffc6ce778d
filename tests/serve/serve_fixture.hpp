#pragma once
// A small recording (a camera at 10 Hz whose frame k is a uniform image of value 20 k, a pose
// at 10 Hz whose position is (k, 2k, 3k) m, a Double channel), an application directory, and an
// HTTP/WebSocket client for the server under test.
#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include <boost/beast/http.hpp>
#include <nlohmann/json.hpp>

#include "cdff/serve/server.hpp"

namespace cdff::serve::testing {

constexpr int kFrames = 10;
constexpr Timestamp kFirstStamp = 1'000'000;  // us
constexpr Timestamp kPeriod = 100'000;        // us

struct Files {
  std::filesystem::path dir, recording, app_dir, secret;
  std::shared_ptr<void> cleanup;
};
/// Writes the recording, the application (index.html) and a file beside it that must never be
/// served, under a fresh directory of the test's temporary directory, removed with the last copy
/// of the Files.
Files makeFiles(const std::string& name);

struct Reply {
  int status = 0;
  std::map<std::string, std::string> headers;
  std::string body;
  nlohmann::json json() const;
};

/// Sends `raw` bytes as they are and reads one response.
Reply sendRaw(unsigned short port, const std::string& raw);
/// GET `target` with a Host header naming the loopback interface and the extra `headers`.
Reply get(unsigned short port, const std::string& target,
          const std::map<std::string, std::string>& headers = {});
Reply post(unsigned short port, const std::string& target, const std::string& body,
           const std::string& content_type = "application/json");

/// One WebSocket frame of a stream: a text frame's JSON, or a binary frame's header (4 bytes of
/// little-endian length, then its JSON) and the mean grey level of its JPEG.
struct Received {
  nlohmann::json header;
  bool image = false;
  double mean = -1;  // of an image
};
Received decodeFrame(const std::string& data, bool text);

/// A server on 127.0.0.1, any free port, over the files (and a token when not empty).
std::unique_ptr<Server> startServer(const Files& files, const std::string& token = {});

}  // namespace cdff::serve::testing
