// The live run of `cdff serve`: dfpcs/pose_filtering.yaml started on a served recording through
// POST /api/live, its poses and camera images over /ws/live, its state (RUNNING, IDLE, STOPPED)
// through the external API's state machine, one run at a time (409), and the refusals of bad
// graphs (path traversal), values and transitions.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <thread>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>

#include "cdff/egse/model_io.hpp"
#include "cdff/io/recorder.hpp"
#include "serve_fixture.hpp"

namespace cdff::serve::testing {
namespace {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;

const std::string kGraph = std::string(CDFF_SOURCE_DIR) + "/dfpcs/pose_filtering.yaml";
constexpr int kLiveFrames = 40;              // 4 s at 10 Hz
constexpr Timestamp kLiveStart = 5'000'000;  // us

// The target moves at 0.2 m/s along x, 10 m ahead; the measurements are exact (1 cm sigma).
Eigen::Vector3d truthAt(Timestamp stamp) {
  return {1.0 + 0.2 * toSeconds(stamp - kLiveStart), 0.5, 10.0};
}

// A camera at 10 Hz whose frame k is uniform with value 6 k (or, `noisy`, 640x480 of noise:
// large JPEGs), the target's pose measured at 10 Hz on the graph's input channel, and its truth.
std::filesystem::path writeLiveRecording(const Files& files, bool noisy = false) {
  const std::filesystem::path path = files.dir / (noisy ? "noisy.mcap" : "live.mcap");
  io::Recorder recorder;
  EXPECT_TRUE(recorder.open(path.string()).isOk());
  std::mt19937 random(7);
  const int width = noisy ? 640 : 64, height = noisy ? 480 : 48;
  for (int k = 0; k < kLiveFrames; ++k) {
    const Timestamp stamp = kLiveStart + k * kPeriod;
    std::vector<std::uint8_t> pixels(width * height, 6 * k);
    if (noisy)
      for (std::uint8_t& p : pixels) p = static_cast<std::uint8_t>(random());
    Result<Image> image = Image::fromBytes(std::move(pixels), width, height, PixelFormat::kGray8);
    EXPECT_TRUE(image.isOk());
    image->stamp = stamp;
    image->frame_id = "camera_optical";
    EXPECT_TRUE(recorder.write("/camera/image", *image).isOk());
    PoseWithCovariance pose;
    pose.pose.stamp = stamp;
    pose.pose.parent_frame = "servicer";
    pose.pose.child_frame = "target";
    pose.pose.translation = truthAt(stamp);
    pose.covariance.diagonal() << Eigen::Vector3d::Constant(1e-4), Eigen::Vector3d::Constant(1e-6);
    EXPECT_TRUE(recorder.write("/chaser/target_pose_measurement", pose).isOk());
    EXPECT_TRUE(recorder.write("/truth/target_pose", pose).isOk());
    // A LIDAR scan for the 3D view: 30000 points, more than a browser gets of one.
    std::vector<Eigen::Vector3f> xyz(30000, Eigen::Vector3f(1.0f, 0.5f, static_cast<float>(k)));
    EXPECT_TRUE(recorder.write("/lidar/points", PointCloud::fromXyz(xyz, "lidar", stamp)).isOk());
  }
  EXPECT_TRUE(recorder.close().isOk());
  return path;
}

class LiveClient {
 public:
  explicit LiveClient(unsigned short port) : ws_(ioc_) {
    ws_.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
    ws_.handshake("127.0.0.1:" + std::to_string(port), "/ws/live", error_);
  }
  const beast::error_code& error() const { return error_; }
  // The status frames come at 2 Hz of the run's clock while a run exists: reads never wait long.
  Received next() {
    beast::flat_buffer buffer;
    ws_.read(buffer);
    const std::string data = beast::buffers_to_string(buffer.data());
    return decodeFrame(data, ws_.got_text());
  }

 private:
  net::io_context ioc_;
  websocket::stream<tcp::socket> ws_;
  beast::error_code error_;
};

// pose_filtering's filter with its innovation's NIS as the only output: a graph with no pose.
std::filesystem::path writeNisGraph(const Files& files) {
  const std::filesystem::path path = files.dir / "nis_only.yaml";
  std::ofstream(path) << R"(name: nis_only
inputs:
  - {name: pose, type: PoseWithCovariance, channel: /chaser/target_pose_measurement}
outputs:
  - {name: nis, type: Double}
nodes:
  ekf:
    dfn: EstimationFilter
    dfi: ExtendedKalman
    parameters: {max_prediction_interval: 10}
    trigger: {on: [pose_measurement]}
connections:
  - pose -> ekf.pose_measurement
  - ekf.innovation_nis -> nis
)";
  return path;
}

// Recording 0: the live recording; 1: the fixture's, which has no pose measurement.
std::unique_ptr<Server> startLiveServer(const Files& files, const std::filesystem::path& rec,
                                        const std::string& token = {}) {
  ServerOptions options;
  options.port = 0;
  options.token = token;
  options.app_dir = files.app_dir;
  options.recordings = {rec.string(), files.recording.string()};
  options.graphs = {kGraph, writeNisGraph(files).string()};
  Result<std::unique_ptr<Server>> server = Server::start(options);
  EXPECT_TRUE(server.isOk()) << server.status().message();
  return server ? std::move(*server) : nullptr;
}

std::string startBody(double speed = 2.0) {
  return json{{"graph", kGraph}, {"recording", 0}, {"speed", speed}}.dump();
}

// GET /api/graphs/model: a served graph's mesh_file (lidar_tracking.yaml's, named absolutely here:
// the server reads it relative to its working directory) as a mesh body; refusals as JSON.
TEST(LiveRun, GraphModelIsItsMeshFile) {
  const Files files = makeFiles("live_model");
  const std::string mesh = std::string(CDFF_SOURCE_DIR) + "/data/models/target.ply";
  std::ifstream in(std::string(CDFF_SOURCE_DIR) + "/dfpcs/lidar_tracking.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  for (std::size_t at = 0; (at = yaml.find("data/models/target.ply", at)) != std::string::npos;
       at += mesh.size())
    yaml.replace(at, std::string("data/models/target.ply").size(), mesh);
  const std::string lidar = (files.dir / "lidar_model.yaml").string();
  std::ofstream(lidar) << yaml;
  ServerOptions options;
  options.port = 0;
  options.app_dir = files.app_dir;
  options.recordings = {files.recording.string()};
  options.graphs = {kGraph, lidar};
  Result<std::unique_ptr<Server>> server = Server::start(options);
  ASSERT_TRUE(server.isOk()) << server.status().message();
  const unsigned short port = (*server)->port();

  const Reply r = get(port, "/api/graphs/model?graph=" + lidar);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.headers.at("Content-Type"), "application/octet-stream");
  std::uint32_t n = 0;
  std::memcpy(&n, r.body.data(), 4);
  const json header = json::parse(r.body.substr(4, n));
  EXPECT_EQ(header["type"], "mesh");
  EXPECT_EQ(header["source"], mesh);
  Result<egse::TargetModel> model = egse::loadModel(mesh);
  ASSERT_TRUE(model.isOk()) << model.status().message();
  EXPECT_EQ(header["vertices"], model->mesh.vertexCount());
  EXPECT_EQ(header["triangles"], model->mesh.triangleCount());
  EXPECT_GT(model->mesh.triangleCount(), 100u);
  EXPECT_EQ(r.body.size(), 4 + n + 12 * (model->mesh.vertexCount() + model->mesh.triangleCount()));

  const auto expectError = [&](const std::string& target, int status, const std::string& says) {
    Reply e = get(port, target);
    EXPECT_EQ(e.status, status) << target << ": " << e.body;
    EXPECT_EQ(e.headers["Content-Type"], "application/json") << target;
    EXPECT_NE(e.json().value("error", "").find(says), std::string::npos)
        << target << ": " << e.body;
  };
  expectError("/api/graphs/model?graph=" + kGraph, 404, "names no mesh_file");
  expectError("/api/graphs/model", 400, "'graph' is missing");
  expectError("/api/graphs/model?graph=../dfpcs/lidar_tracking.yaml", 400, "is a path");
  expectError("/api/graphs/model?graph=dfpcs/lidar_tracking.yaml", 404, "not a served graph");
  expectError("/api/graphs/model?graph=" + lidar + "&x=1", 400, "'x' is unknown");
  EXPECT_EQ(post(port, "/api/graphs/model?graph=" + lidar, "{}").status, 405);
}

TEST(LiveRun, PosesAndImagesStreamAndTheStateFollowsTheExternalApi) {
  const Files files = makeFiles("live");
  const std::filesystem::path rec = writeLiveRecording(files);
  auto server = startLiveServer(files, rec);
  ASSERT_TRUE(server);
  const unsigned short port = server->port();

  Reply r = get(port, "/api/graphs");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["graphs"], json::array({kGraph, (files.dir / "nis_only.yaml").string()}));
  r = get(port, "/api/live");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["active"], false);

  LiveClient client(port);
  ASSERT_FALSE(client.error()) << client.error().message();
  Received first = client.next();  // the state when the browser connects
  EXPECT_EQ(first.header["type"], "state");
  EXPECT_EQ(first.header["active"], false);

  r = post(port, "/api/live", startBody());
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["state"], "running");
  EXPECT_EQ(r.json()["camera"], "/camera/image");

  // One run at a time.
  Reply again = post(port, "/api/live", startBody());
  EXPECT_EQ(again.status, 409) << again.body;
  EXPECT_NE(again.json()["error"].get<std::string>().find("DELETE /api/live"), std::string::npos)
      << again.body;

  // Poses near the truth of their time (exact measurements: the filter's error stays within
  // its 0.2 m/s velocity times a 0.1 s frame interval until its velocity converges), camera
  // images of the frame of their time, the DFPC's status RUNNING.
  int poses = 0, images = 0, statuses = 0, scans = 0, errors = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while ((poses < 3 || images < 1 || statuses < 1 || scans < 1 || errors < 1) &&
         std::chrono::steady_clock::now() < deadline) {
    const Received m = client.next();
    const std::string type = m.header.value("type", "");
    if (m.image && type == "points") {
      // The latest scan, thinned to the live stream's 20000 points at most.
      ++scans;
      EXPECT_EQ(m.header["channel"], "/lidar/points");
      EXPECT_EQ(m.header["source_count"], 30000);
      EXPECT_LE(m.header["count"].get<int>(), 20000);
      EXPECT_EQ(m.header["count"], 15000);  // every 2nd point
      ASSERT_EQ(m.payload.size(), m.header["count"].get<std::size_t>() * 12);
      float z = -1;
      std::memcpy(&z, m.payload.data() + 8, 4);
      const Timestamp stamp = m.header["stamp_us"];
      EXPECT_EQ(z, static_cast<float>((stamp - kLiveStart) / kPeriod));
    } else if (m.image) {
      ++images;
      EXPECT_EQ(m.header["channel"], "/camera/image");
      EXPECT_EQ(m.header["width"], 64);
      const Timestamp stamp = m.header["stamp_us"];
      const int k = static_cast<int>((stamp - kLiveStart) / kPeriod);
      EXPECT_NEAR(m.mean, 6.0 * k, 2.0) << m.header.dump();
      EXPECT_NEAR(m.header["t"].get<double>(), toSeconds(stamp - kLiveStart), 1e-6);
    } else if (type == "pose") {
      ++poses;
      EXPECT_EQ(m.header["dfpc"], "pose_filtering");
      const Timestamp stamp = m.header["stamp_us"];
      const Eigen::Vector3d p(m.header["p"][0], m.header["p"][1], m.header["p"][2]);
      EXPECT_LT((p - truthAt(stamp)).norm(), 0.02 + 1e-3) << m.header.dump();
      EXPECT_EQ(m.header["covariance"].size(), 36u);
      EXPECT_GT(m.header["covariance"][0].get<double>(), 0.0);
      // The truth of its time from the recording, its error as `cdff eval` measures it and the
      // thresholds of SR_DFPC_0100 (mid range: 10 m).
      if (m.header.contains("error")) {
        ++errors;
        EXPECT_EQ(m.header["truth"]["channel"], "/truth/target_pose");
        const Eigen::Vector3d t(m.header["truth"]["p"][0], m.header["truth"]["p"][1],
                                m.header["truth"]["p"][2]);
        EXPECT_LT((t - truthAt(stamp)).norm(), 1e-9);
        EXPECT_NEAR(m.header["error"]["position_error_m"].get<double>(), (p - t).norm(), 1e-9);
        EXPECT_NEAR(m.header["error"]["range_m"].get<double>(), t.norm(), 1e-9);
        EXPECT_EQ(m.header["error"]["position_threshold_m"], 1.0);
        EXPECT_EQ(m.header["error"]["angle_threshold_deg"], 10.0);
        EXPECT_EQ(m.header["error"]["requirement"], "SR_DFPC_0100");
      }
    } else if (type == "status") {
      ++statuses;
      EXPECT_EQ(m.header["name"], "pose_filtering");
      EXPECT_EQ(m.header["cdff_state"], "running");
    }
  }
  EXPECT_GE(poses, 3);
  EXPECT_GE(images, 1);
  EXPECT_GE(statuses, 1);
  EXPECT_GE(scans, 1);
  EXPECT_GE(errors, 1);

  r = get(port, "/api/live");
  ASSERT_EQ(r.status, 200) << r.body;
  json state = r.json();
  EXPECT_EQ(state["active"], true);
  EXPECT_EQ(state["state"], "running");
  ASSERT_EQ(state["dfpcs"].size(), 1u) << state.dump();
  EXPECT_EQ(state["dfpcs"][0]["name"], "pose_filtering");
  EXPECT_EQ(state["dfpcs"][0]["state"], "running");
  EXPECT_GT(state["dfpcs"][0]["products"].get<int>(), 0);
  ASSERT_FALSE(state["dfpcs"][0]["instances"].empty());
  // The DFN call times: the mean from the DFPC's status, the latest from the timing records.
  const json& instance = state["dfpcs"][0]["instances"][0];
  EXPECT_GT(instance["mean_wall_s"].get<double>(), 0.0) << state.dump();
  EXPECT_GT(instance["last_wall_s"].get<double>(), 0.0) << state.dump();
  EXPECT_GT(state["dfpcs"][0]["stream_time_us"].get<std::int64_t>(), 0) << state.dump();
  EXPECT_FALSE(state["events"].empty());  // the DFPC's lifecycle (initialised, started)

  // One DFPC through stopDFPC and initDFPC; an unknown DFPC (the API's 404), a bad request.
  r = post(port, "/api/live/dfpcs/pose_filtering", R"({"request": "stop"})");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["dfpcs"][0]["state"], "stopped");
  EXPECT_EQ(r.json()["state"], "running");
  r = post(port, "/api/live/dfpcs/pose_filtering", R"({"request": "init"})");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["dfpcs"][0]["state"], "running");
  r = post(port, "/api/live/dfpcs/nope", R"({"request": "stop"})");
  EXPECT_EQ(r.status, 404) << r.body;
  EXPECT_NE(r.body.find("nope"), std::string::npos) << r.body;
  r = post(port, "/api/live/dfpcs/pose_filtering", R"({"request": "start"})");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_NE(r.body.find("initDFPC"), std::string::npos) << r.body;

  // The state machine through setCDFFState: idle, a refused idle (the API's message), a bad
  // value, stop.
  r = post(port, "/api/live/state", R"({"request": "idle"})");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["state"], "idle");
  r = post(port, "/api/live/state", R"({"request": "idle"})");
  EXPECT_EQ(r.status, 409) << r.body;
  EXPECT_NE(r.json()["error"].get<std::string>().find("in state idle"), std::string::npos)
      << r.body;
  r = post(port, "/api/live/state", R"({"request": "pause"})");
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_NE(r.json()["error"].get<std::string>().find("pause"), std::string::npos) << r.body;
  EXPECT_NE(r.json()["error"].get<std::string>().find("initialize"), std::string::npos) << r.body;
  r = post(port, "/api/live/state", R"({"request": "initialize"})");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["state"], "running");
  r = post(port, "/api/live/state", R"({"request": "stop"})");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["state"], "stopped");
  r = get(port, "/api/live");
  EXPECT_EQ(r.json()["state"], "stopped");
  EXPECT_EQ(r.json()["dfpcs"][0]["state"], "stopped") << r.body;

  // DELETE removes it; its last state stays visible; a new run may start.
  r = sendRaw(port, "DELETE /api/live HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["active"], false);
  EXPECT_EQ(r.json()["last"]["state"], "stopped");
  r = sendRaw(port, "DELETE /api/live HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(r.status, 404) << r.body;
  r = post(port, "/api/live/state", R"({"request": "idle"})");
  EXPECT_EQ(r.status, 404) << r.body;
  r = post(port, "/api/live", startBody(4.0));
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["state"], "running");
  // The server stops a run that is still there when it stops.
}

TEST(LiveRun, RefusesGraphsOutsideTheServedOnesAndBadValues) {
  const Files files = makeFiles("live_errors");
  const std::filesystem::path rec = writeLiveRecording(files);
  auto server = startLiveServer(files, rec);
  ASSERT_TRUE(server);
  const unsigned short port = server->port();
  const auto start = [&](const json& body) { return post(port, "/api/live", body.dump()); };
  const auto expectError = [](const Reply& r, int status, const std::string& fragment) {
    EXPECT_EQ(r.status, status) << r.body;
    ASSERT_TRUE(r.json().contains("error")) << r.body;
    EXPECT_NE(r.json()["error"].get<std::string>().find(fragment), std::string::npos) << r.body;
  };
  // Path traversal, a file that exists but is not a served graph, an unknown graph.
  expectError(
      start({{"graph", std::string(CDFF_SOURCE_DIR) + "/dfpcs/../dfpcs/pose_filtering.yaml"},
             {"recording", 0}}),
      400, "is a path");
  expectError(start({{"graph", "dfpcs/../../etc/passwd"}, {"recording", 0}}), 400, "is a path");
  expectError(start({{"graph", files.secret.string()}, {"recording", 0}}), 404,
              "not a served graph");
  expectError(start({{"graph", std::string(CDFF_SOURCE_DIR) + "/dfpcs/lidar_tracking.yaml"},
                     {"recording", 0}}),
              404, kGraph);
  // Bad values: recording, speed, types, unknown and missing keys, not JSON, wrong type.
  expectError(start({{"graph", kGraph}, {"recording", 3}}), 404, "\"recording\" = 3");
  // A recording without the graph's input: the API's own refusal.
  const Reply lacking = start({{"graph", kGraph}, {"recording", 1}});
  EXPECT_EQ(lacking.status, 404) << lacking.body;
  EXPECT_NE(lacking.body.find("/chaser/target_pose_measurement"), std::string::npos)
      << lacking.body;
  expectError(start({{"graph", kGraph}, {"recording", 0}, {"speed", 100}}), 400, "[0.0625, 16]");
  expectError(start({{"graph", kGraph}, {"recording", "0"}}), 400, "an integer");
  expectError(start({{"graph", kGraph}, {"recording", 0}, {"colour", 1}}), 400, "colour");
  expectError(start({{"recording", 0}}), 400, "\"graph\" is missing");
  expectError(start({{"graph", kGraph}, {"recording", 0}, {"camera", "/truth/target_pose"}}), 400,
              "expected an Image channel");
  expectError(post(port, "/api/live", "{not json"), 400, "not a JSON object");
  expectError(post(port, "/api/live", startBody(), "text/plain"), 415, "application/json");
  expectError(sendRaw(port,
                      "PUT /api/live HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: "
                      "0\r\nConnection: close\r\n\r\n"),
              405, "GET, POST, DELETE");
  expectError(get(port, "/api/live/other"), 404, "/api/live/state");
  // The live stream from another site's page (WebSockets are not bound by the same-origin
  // policy).
  const std::string upgrade =
      "GET /ws/live HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
      "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Version: 13\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n";
  expectError(sendRaw(port, upgrade + "Origin: http://evil.example\r\n\r\n"), 403,
              "Origin 'http://evil.example'");
  expectError(sendRaw(port, upgrade.substr(0, 12) + "?x=1" + upgrade.substr(12) + "\r\n"), 400,
              "'x'");
  // Nothing was started by any of them.
  EXPECT_EQ(get(port, "/api/live").json()["active"], false);
}

TEST(LiveRun, RoutesNeedTheTokenWhenTheServerHasOne) {
  const Files files = makeFiles("live_token");
  const std::filesystem::path rec = writeLiveRecording(files);
  const std::string token = "0123456789abcdef0123456789abcdef";
  auto server = startLiveServer(files, rec, token);
  ASSERT_TRUE(server);
  const unsigned short port = server->port();
  EXPECT_EQ(post(port, "/api/live", startBody()).status, 401);
  EXPECT_EQ(get(port, "/api/live").status, 401);
  EXPECT_EQ(get(port, "/api/graphs").status, 401);
  EXPECT_EQ(post(port, "/api/live/state", R"({"request": "idle"})").status, 401);
  EXPECT_EQ(post(port, "/api/live/designation", R"({"x": 1, "y": 1, "w": 8, "h": 8})").status, 401);
  EXPECT_EQ(get(port, "/ws/live").status, 401);
  EXPECT_EQ(get(port, "/api/live").json()["error"].is_string(), true);
  const Reply r = post(port, "/api/live?token=" + token, startBody());
  EXPECT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["state"], "running");
}

// A graph without a pose output runs; its state says why no pose is streamed.
TEST(LiveRun, AGraphWithoutAPoseRunsAndSaysSo) {
  const Files files = makeFiles("live_nis");
  const std::filesystem::path rec = writeLiveRecording(files);
  auto server = startLiveServer(files, rec);
  ASSERT_TRUE(server);
  const std::string graph = (files.dir / "nis_only.yaml").string();
  const Reply r = post(server->port(), "/api/live",
                       json{{"graph", graph}, {"recording", 0}, {"speed", 4}}.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.json()["state"], "running");
  EXPECT_NE(r.json().value("pose_error", "").find("has no pose output"), std::string::npos)
      << r.body;
}

// A browser that connects and never reads: its socket's buffers fill with 640x480 noise JPEGs
// (about 300 kB each, 40 of them) and its queue drops frames, while the DFPC still gets every
// message of the recording and the input reaches its end.
TEST(LiveRun, ABrowserThatDoesNotReadNeverHoldsTheRunBack) {
  const Files files = makeFiles("live_slow");
  const std::filesystem::path rec = writeLiveRecording(files, true);
  auto server = startLiveServer(files, rec);
  ASSERT_TRUE(server);
  const unsigned short port = server->port();
  LiveClient idle(port);  // never reads
  ASSERT_FALSE(idle.error()) << idle.error().message();
  Reply r = post(port, "/api/live", startBody(4.0));
  ASSERT_EQ(r.status, 200) << r.body;
  json state;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  do {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    state = get(port, "/api/live").json();
  } while (!state.value("input_ended", false) && std::chrono::steady_clock::now() < deadline);
  ASSERT_TRUE(state.value("input_ended", false)) << state.dump();
  // Every measurement reached the DFPC (processed before the input's end was seen).
  ASSERT_EQ(state["dfpcs"].size(), 1u) << state.dump();
  EXPECT_EQ(state["dfpcs"][0]["messages"], kLiveFrames) << state.dump();
  EXPECT_EQ(state["dfpcs"][0]["ignored_messages"], 0) << state.dump();
  // Only that browser's copy was decimated.
  ASSERT_EQ(state["browsers"].size(), 1u) << state.dump();
  EXPECT_GT(state["browsers"][0]["dropped"].get<int>(), 0) << state.dump();
}

// A DFPC that reads designations as dfpcs/far_range_tracking.yaml does (TargetDesignation passing
// the user's region on with the next image), on the live recording's camera.
const std::string kDesignationGraph = CDFF_SOURCE_DIR "/tests/dfpc/designation_probe.yaml";

// POST /api/live/designation: the box (full-resolution pixels) goes through the external API's
// designateTarget to the DFPC, which passes it on with the next image (a "region" frame on the
// stream, its corners the box's edges); every watching browser gets the "designation" frame.
// Malformed and out-of-image boxes are 400 with what was wrong; a run whose graph reads no
// designation is 409; no run is 404; another site's page is 403.
TEST(LiveRun, ADesignationReachesTheGraphThroughTheExternalApi) {
  const Files files = makeFiles("live_designation");
  const std::filesystem::path rec = writeLiveRecording(files);
  ServerOptions options;
  options.port = 0;
  options.app_dir = files.app_dir;
  options.recordings = {rec.string()};
  const std::string graph = kDesignationGraph;
  options.graphs = {graph, kGraph};
  Result<std::unique_ptr<Server>> server = Server::start(options);
  ASSERT_TRUE(server.isOk()) << server.status().message();
  const unsigned short port = (*server)->port();
  const auto designate = [&](const std::string& body) {
    return post(port, "/api/live/designation", body);
  };
  const auto expectError = [](const Reply& r, int status, const std::string& fragment) {
    EXPECT_EQ(r.status, status) << r.body;
    ASSERT_TRUE(r.json().contains("error")) << r.body;
    EXPECT_NE(r.json()["error"].get<std::string>().find(fragment), std::string::npos) << r.body;
  };
  const std::string box = R"({"x": 20.5, "y": 10, "w": 8, "h": 6})";
  expectError(designate(box), 404, "no live run");

  // A graph that reads no designation: the API's refusal, a conflict with the run.
  Reply r = post(port, "/api/live", json{{"graph", kGraph}, {"recording", 0}, {"speed", 4}}.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  expectError(designate(box), 409, "no DFPC reads designations");
  ASSERT_EQ(
      sendRaw(port, "DELETE /api/live HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n")
          .status,
      200);

  LiveClient client(port);
  ASSERT_FALSE(client.error()) << client.error().message();
  r = post(port, "/api/live", json{{"graph", graph}, {"recording", 0}, {"speed", 0.5}}.dump());
  ASSERT_EQ(r.status, 200) << r.body;
  // Once an image was processed (the stream shows it), the box goes in.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline && !client.next().image) {
  }
  // Malformed boxes and ones that leave the 64x48 image, each naming the value.
  expectError(designate(R"({"x": 20, "y": 10, "w": 8})"), 400, "\"h\" is missing");
  expectError(designate(R"({"x": "20", "y": 10, "w": 8, "h": 6})"), 400, "\"x\" = \"20\"");
  expectError(designate(R"({"x": 20, "y": 10, "w": 0, "h": 6})"), 400,
              "\"w\" = 0: expected a whole number of pixels");
  expectError(designate(R"({"x": 20, "y": 10, "w": 2.5, "h": 6})"), 400, "\"w\" = 2.5");
  expectError(designate(R"({"x": 20, "y": 10, "w": 8, "h": 6, "t": 1})"), 400,
              "key \"t\" is unknown");
  expectError(designate("[1, 2, 3, 4]"), 400, "not a JSON object");
  expectError(designate(R"({"x": 60, "y": 10, "w": 8, "h": 6})"), 400,
              "leaves the 64x48 image of /camera/image");
  expectError(designate(R"({"x": -1, "y": 10, "w": 8, "h": 6})"), 400, "leaves the 64x48 image");
  const std::string raw_post =
      "POST /api/live/designation HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
      "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(box.size()) +
      "\r\nConnection: close\r\n";
  expectError(sendRaw(port, raw_post + "Origin: http://evil.example\r\n\r\n" + box), 403,
              "Origin 'http://evil.example'");
  // Nor may another site's page stop the run; the page's own origin may.
  expectError(sendRaw(port, "DELETE /api/live HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                                "\r\nOrigin: http://evil.example\r\nConnection: close\r\n\r\n"),
              403, "is not this server's");
  EXPECT_EQ(get(port, "/api/live").json()["active"], true);
  const std::string tall = R"({"x": 0, "y": 0, "w": 64, "h": 49})";
  const Reply own = sendRaw(
      port, "POST /api/live/designation HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                "\r\nOrigin: http://127.0.0.1:" + std::to_string(port) +
                "\r\nContent-Type: application/json\r\nContent-Length: " +
                std::to_string(tall.size()) + "\r\nConnection: close\r\n\r\n" + tall);
  // Past the Origin check: the box is refused for its height (49 > 48).
  expectError(own, 400, "leaves the 64x48 image");

  r = designate(box);
  ASSERT_EQ(r.status, 200) << r.body;
  const json d = r.json()["designation"];
  EXPECT_EQ(d["x"], 20.5);
  EXPECT_EQ(d["width"], 8);
  EXPECT_EQ(d["dfpcs"], json::array({"designation_probe"}));
  EXPECT_EQ(d["image"]["channel"], "/camera/image");
  EXPECT_EQ(d["image"]["width"], 64);
  EXPECT_EQ(d["image"]["height"], 48);
  EXPECT_GE(d["t"].get<double>(), d["image"]["t"].get<double>());
  // The stream: the designation, then the DFPC's region of the next image with the box's edges.
  bool announced = false;
  std::optional<json> region;
  while (std::chrono::steady_clock::now() < deadline && !region) {
    const Received m = client.next();
    const std::string type = m.header.value("type", "");
    if (type == "designation") announced = true;
    if (type == "region" && m.header["output"] == "designated") region = m.header;
  }
  EXPECT_TRUE(announced);
  ASSERT_TRUE(region);
  EXPECT_EQ((*region)["source"], "user");
  EXPECT_EQ((*region)["dfpc"], "designation_probe");
  EXPECT_GT((*region)["t"].get<double>(), d["t"].get<double>());
  const json& corners = (*region)["corners"];
  ASSERT_EQ(corners.size(), 4u);
  EXPECT_NEAR(corners[0][0].get<double>(), 20.5 - 0.5, 1e-9);
  EXPECT_NEAR(corners[0][1].get<double>(), 10 - 0.5, 1e-9);
  EXPECT_NEAR(corners[2][0].get<double>(), 20.5 + 8 - 0.5, 1e-9);
  EXPECT_NEAR(corners[2][1].get<double>(), 10 + 6 - 0.5, 1e-9);
}

}  // namespace
}  // namespace cdff::serve::testing
