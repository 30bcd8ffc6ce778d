#include "serve_fixture.hpp"

#include <cmath>
#include <fstream>
#include <limits>

#include <unistd.h>

#include <gtest/gtest.h>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cdff/io/recorder.hpp"

namespace cdff::serve::testing {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;

namespace {

/// The fixture recordings' k-th camera frame: a 64x48 uniform grey of 20 k, in camera_optical.
Result<Image> frameOfGrey(int k, Timestamp stamp) {
  Result<Image> image =
      Image::fromBytes(std::vector<std::uint8_t>(64 * 48, 20 * k), 64, 48, PixelFormat::kGray8);
  if (image.isOk()) {
    image->stamp = stamp;
    image->frame_id = "camera_optical";
  }
  return image;
}

}  // namespace

Files makeFiles(const std::string& name) {
  Files f;
  // One directory per process: CTest runs the tests of this program in parallel processes.
  f.dir = std::filesystem::path(::testing::TempDir()) /
          ("cdff_serve_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(f.dir);
  f.cleanup = std::shared_ptr<void>(nullptr, [dir = f.dir](void*) {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  });
  f.app_dir = f.dir / "app";
  std::filesystem::create_directories(f.app_dir);
  std::ofstream(f.app_dir / "index.html") << "<!doctype html><title>app</title>\n";
  f.secret = f.dir / "secret.txt";
  std::ofstream(f.secret) << "not for the browser\n";
  f.recording = f.dir / "small.mcap";
  io::Recorder recorder;
  EXPECT_TRUE(recorder.open(f.recording.string()).isOk());
  for (int k = 0; k < kFrames; ++k) {
    const Timestamp stamp = kFirstStamp + k * kPeriod;
    Result<Image> image = frameOfGrey(k, stamp);
    EXPECT_TRUE(image.isOk());
    EXPECT_TRUE(recorder.write("/camera/image", *image).isOk());
    PoseWithCovariance pose;
    pose.pose.stamp = stamp;
    pose.pose.parent_frame = "world";
    pose.pose.child_frame = "target";
    pose.pose.translation = Eigen::Vector3d(k, 2 * k, 3 * k);
    pose.covariance = Matrix6d::Identity() * 0.01;
    EXPECT_TRUE(recorder.write("/truth/pose", pose).isOk());
    EXPECT_TRUE(recorder.write("/range", 10.0 + k, stamp).isOk());
  }
  EXPECT_TRUE(recorder.close().isOk());
  return f;
}

std::filesystem::path writeSceneRecording(const Files& files) {
  const std::filesystem::path path = files.dir / "scene.mcap";
  io::Recorder recorder;
  EXPECT_TRUE(recorder.open(path.string()).isOk());
  for (int k = 0; k < kFrames; ++k) {
    const Timestamp stamp = kFirstStamp + k * kPeriod;
    Result<Image> image = frameOfGrey(k, stamp);
    EXPECT_TRUE(image.isOk());
    CameraModel camera;
    camera.width = 64;
    camera.height = 48;
    camera.fx = camera.fy = kSceneFocal;
    camera.cx = 32;
    camera.cy = 24;
    image->camera = camera;
    EXPECT_TRUE(recorder.write("/camera/image", *image).isOk());
    if (k == 0) {
      // The camera's mounting: its optical frame is the servicer's.
      EXPECT_TRUE(recorder
                      .write("/chaser/tf/camera_optical",
                             Transform::identity("servicer", "camera_optical", stamp))
                      .isOk());
    }
    std::vector<Eigen::Vector3f> xyz;
    for (int i = 0; i < kScenePoints; ++i) {
      const float nan = std::numeric_limits<float>::quiet_NaN();
      xyz.emplace_back(i % 10 == 9 ? nan : 0.01f * i, static_cast<float>(k), 1.0f);
    }
    EXPECT_TRUE(recorder.write("/lidar/points", PointCloud::fromXyz(xyz, "lidar", stamp)).isOk());
    PoseWithCovariance truth;
    truth.pose.stamp = stamp;
    truth.pose.parent_frame = "servicer";
    truth.pose.child_frame = "target";
    truth.pose.translation = Eigen::Vector3d(0, 0, 10.0 - k);
    truth.covariance = Matrix6d::Identity() * 1e-4;
    EXPECT_TRUE(recorder.write("/truth/target_pose", truth).isOk());
    PoseWithCovariance product = truth;
    product.pose.translation.x() += kProductOffset;
    product.pose.rotation = Eigen::Quaterniond(
        Eigen::AngleAxisd(kProductTurnDeg * M_PI / 180, Eigen::Vector3d::UnitZ()));
    EXPECT_TRUE(recorder.write("/cdff/test/pose", product).isOk());
    // The servicer in LVLH: k m along x, turned 90 degrees about x.
    Transform servicer = Transform::identity("lvlh", "servicer", stamp);
    servicer.translation = Eigen::Vector3d(k, 0, 0);
    servicer.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()));
    EXPECT_TRUE(recorder.write("/truth/tf/servicer", servicer).isOk());
    if (k == 0) {
      TriangleMesh mesh;
      mesh.stamp = stamp;
      mesh.frame_id = "target";
      mesh.vertices =
          Buffer<Eigen::Vector3f>::fromVector({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0.5f}});
      mesh.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector({{0, 2, 1}, {0, 3, 2}});
      EXPECT_TRUE(recorder.write("/truth/target_mesh", mesh).isOk());
    }
  }
  EXPECT_TRUE(recorder.close().isOk());
  return path;
}

nlohmann::json Reply::json() const {
  return nlohmann::json::parse(body, nullptr, false);
}

namespace {

Reply readReply(tcp::socket& socket) {
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(64u << 20);
  beast::error_code ec;
  http::read(socket, buffer, parser, ec);
  Reply r;
  if (ec) {
    r.status = -1;
    r.body = ec.message();
    return r;
  }
  const auto& res = parser.get();
  r.status = static_cast<int>(res.result_int());
  for (const auto& field : res) r.headers[std::string(field.name_string())] = field.value();
  r.body = res.body();
  return r;
}

tcp::socket connect(net::io_context& ioc, unsigned short port) {
  tcp::socket socket(ioc);
  socket.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  return socket;
}

}  // namespace

Reply sendRaw(unsigned short port, const std::string& raw) {
  net::io_context ioc;
  tcp::socket socket = connect(ioc, port);
  beast::error_code ec;
  net::write(socket, net::buffer(raw), ec);
  return readReply(socket);
}

Reply get(unsigned short port, const std::string& target,
          const std::map<std::string, std::string>& headers) {
  std::string raw = "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                    "\r\nConnection: close\r\n";
  for (const auto& [k, v] : headers) raw += k + ": " + v + "\r\n";
  return sendRaw(port, raw + "\r\n");
}

Reply post(unsigned short port, const std::string& target, const std::string& body,
           const std::string& content_type) {
  const std::string raw = "POST " + target +
                          " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                          "\r\nConnection: close\r\nContent-Type: " + content_type +
                          "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
  return sendRaw(port, raw);
}

std::unique_ptr<Server> startServer(const Files& files, const std::string& token) {
  ServerOptions options;
  options.port = 0;
  options.token = token;
  options.app_dir = files.app_dir;
  options.recordings = {files.recording.string()};
  Result<std::unique_ptr<Server>> server = Server::start(options);
  EXPECT_TRUE(server.isOk()) << server.status().message();
  return server ? std::move(*server) : nullptr;
}

Received decodeFrame(const std::string& data, bool text) {
  Received r;
  if (text) {
    r.header = nlohmann::json::parse(data);
    return r;
  }
  const std::uint32_t n = static_cast<std::uint8_t>(data[0]) |
                          static_cast<std::uint8_t>(data[1]) << 8 |
                          static_cast<std::uint8_t>(data[2]) << 16 |
                          static_cast<std::uint32_t>(static_cast<std::uint8_t>(data[3])) << 24;
  r.header = nlohmann::json::parse(data.substr(4, n));
  r.image = true;
  r.payload = data.substr(4 + n);
  if (r.header.value("type", "") != "image") return r;
  const std::vector<std::uint8_t> jpeg(r.payload.begin(), r.payload.end());
  r.mean = cv::mean(cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE))[0];
  return r;
}

}  // namespace cdff::serve::testing
