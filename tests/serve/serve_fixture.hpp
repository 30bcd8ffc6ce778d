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
/// little-endian length, then its JSON), its payload and, for an image, the mean grey level of
/// its JPEG.
struct Received {
  nlohmann::json header;
  bool image = false;   // a binary frame (an image, or a point cloud: header "type")
  double mean = -1;     // of an image
  std::string payload;  // of a binary frame
};
Received decodeFrame(const std::string& data, bool text);

/// The 3D view's recording, beside the files' own (scene.mcap): 10 frames at 10 Hz from
/// kFirstStamp; /lidar/points (frame "lidar"), 1000 points of which every 10th is NaN, point i
/// of frame k at (0.01 i, k, 1); /truth/target_pose servicer_T_target at (0, 0, 10 - k) m
/// (ranges 10 m down to 1 m); the product /cdff/test/pose, the truth moved by kProductOffset
/// along x and turned by kProductTurnDeg about z; /truth/target_mesh (frame "target", 4
/// vertices (0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0.5), 2 triangles facing -z) once;
/// /camera/image (64x48) as in makeFiles, with a pinhole camera model (focal kSceneFocal px,
/// centre (32, 24)), and its mounting /chaser/tf/camera_optical (servicer_T_camera_optical, the
/// identity) once; /truth/tf/servicer (lvlh_T_servicer) at (k, 0, 0) m turned 90 degrees about x.
constexpr int kScenePoints = 1000;
constexpr double kSceneFocal = 50;       // px
constexpr double kProductOffset = 0.1;   // m
constexpr double kProductTurnDeg = 2.0;  // deg
std::filesystem::path writeSceneRecording(const Files& files);

/// A server on 127.0.0.1, any free port, over the files (and a token when not empty).
std::unique_ptr<Server> startServer(const Files& files, const std::string& token = {});

}  // namespace cdff::serve::testing
