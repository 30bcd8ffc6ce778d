// The replay stream over a WebSocket: the frames of a time after a seek, playback to the end in
// order, refusals before the upgrade, and the per-browser queue that drops its oldest frames.
#include <gtest/gtest.h>
#include <condition_variable>
#include <cstring>
#include <mutex>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>

#include "cdff/serve/frame_queue.hpp"
#include "cdff/serve/replay_stream.hpp"
#include "serve_fixture.hpp"

namespace cdff::serve::testing {
namespace {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;

class Client {
 public:
  Client(unsigned short port, const std::string& target, const std::string& origin = {})
      : ws_(ioc_) {
    ws_.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
    const std::string host = "127.0.0.1:" + std::to_string(port);
    ws_.set_option(websocket::stream_base::decorator([origin](websocket::request_type& req) {
      if (!origin.empty()) req.set(beast::http::field::origin, origin);
    }));
    ws_.handshake(response_, host, target, error_);
  }
  const beast::error_code& error() const { return error_; }
  const websocket::response_type& response() const { return response_; }

  void send(const json& command) { ws_.write(net::buffer(command.dump())); }
  void sendText(const std::string& text) { ws_.write(net::buffer(text)); }

  Received next() {
    beast::flat_buffer buffer;
    ws_.read(buffer);
    const std::string data = beast::buffers_to_string(buffer.data());
    return decodeFrame(data, ws_.got_text());
  }
  // Frames up to and including the next state message.
  std::vector<Received> untilState() {
    std::vector<Received> out;
    do out.push_back(next());
    while (out.back().image || out.back().header["type"] != "state");
    return out;
  }

 private:
  net::io_context ioc_;
  websocket::stream<tcp::socket> ws_;
  websocket::response_type response_;
  beast::error_code error_;
};

const std::string kStream = "/api/recordings/0/stream?image=/camera/image&pose=/truth/pose";

TEST(ReplayStream, StartsAtTheBeginningAndSeeksToTheFrameOfATime) {
  const Files files = makeFiles("stream_seek");
  std::unique_ptr<Server> server = startServer(files);
  Client client(server->port(), kStream);
  ASSERT_FALSE(client.error()) << client.error().message();

  std::vector<Received> first = client.untilState();
  ASSERT_EQ(first.size(), 3u);
  EXPECT_TRUE(first[0].image);
  EXPECT_DOUBLE_EQ(first[0].header["t"].get<double>(), 0.0);
  EXPECT_EQ(first[0].header["width"], 64);
  EXPECT_NEAR(first[0].mean, 0, 2.0);
  EXPECT_EQ(first[1].header["type"], "pose");
  EXPECT_EQ(first[2].header["playing"], false);

  client.send({{"cmd", "seek"}, {"t", 0.72}});
  std::vector<Received> seek = client.untilState();
  ASSERT_EQ(seek.size(), 3u);
  ASSERT_TRUE(seek[0].image);
  EXPECT_NEAR(seek[0].header["t"].get<double>(), 0.7, 1e-9);
  EXPECT_NEAR(seek[0].mean, 7 * 20, 2.0);  // frame 7's pixels, not only its time
  EXPECT_EQ(seek[1].header["p"], json::parse("[7.0, 14.0, 21.0]"));
  EXPECT_NEAR(seek[2].header["t"].get<double>(), 0.72, 1e-9);
}

TEST(ReplayStream, PlaysToTheEndInOrder) {
  const Files files = makeFiles("stream_play");
  std::unique_ptr<Server> server = startServer(files);
  Client client(server->port(), kStream);
  ASSERT_FALSE(client.error()) << client.error().message();
  client.untilState();
  client.send({{"cmd", "speed"}, {"value", 8}});
  EXPECT_EQ(client.untilState().back().header["speed"], 8.0);
  client.send({{"cmd", "play"}});
  std::vector<double> images, poses;
  for (;;) {
    const Received r = client.next();
    if (r.image)
      images.push_back(r.header["t"]);
    else if (r.header["type"] == "pose")
      poses.push_back(r.header["t"]);
    else if (r.header["type"] == "state" && r.header["ended"] == true)
      break;
  }
  // Frames 1..9 after the start (frame 0 was sent at the start), each in time order.
  ASSERT_EQ(images.size(), static_cast<std::size_t>(kFrames - 1));
  ASSERT_EQ(poses.size(), static_cast<std::size_t>(kFrames - 1));
  for (int k = 1; k < kFrames; ++k) {
    EXPECT_NEAR(images[k - 1], k * kPeriod * 1e-6, 1e-9);
    EXPECT_NEAR(poses[k - 1], k * kPeriod * 1e-6, 1e-9);
  }
}

TEST(ReplayStream, BadCommandsGetAnErrorFrameAndTheStreamGoesOn) {
  const Files files = makeFiles("stream_commands");
  std::unique_ptr<Server> server = startServer(files);
  Client client(server->port(), kStream);
  ASSERT_FALSE(client.error()) << client.error().message();
  client.untilState();
  const auto errorOf = [&](const std::string& text) {
    client.sendText(text);
    const Received r = client.next();
    EXPECT_EQ(r.header["type"], "error") << r.header;
    return r.header.value("error", "");
  };
  EXPECT_NE(errorOf("{play").find("is not JSON"), std::string::npos);
  EXPECT_NE(errorOf(R"({"cmd": "rewind"})").find("'rewind' is unknown"), std::string::npos);
  EXPECT_NE(errorOf(R"({"cmd": "seek", "t": 12})").find("t = 12 s is outside the recording"),
            std::string::npos);
  EXPECT_NE(errorOf(R"({"cmd": "speed", "value": 1000})").find("expected a factor in"),
            std::string::npos);
  client.send({{"cmd", "seek"}, {"t", 0.3}});
  EXPECT_NEAR(client.untilState().front().header["t"].get<double>(), 0.3, 1e-9);
}

TEST(ReplayStream, RefusedBeforeTheUpgrade) {
  const Files files = makeFiles("stream_refused");
  std::unique_ptr<Server> server = startServer(files);
  // The upgrade request a browser sends; the refusal is a plain HTTP response.
  const auto refusal = [&](const std::string& target, const std::string& origin = {}) {
    const Reply r =
        sendRaw(server->port(),
                "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(server->port()) +
                    "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                    "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                    "Sec-WebSocket-Version: 13\r\n" +
                    (origin.empty() ? "" : "Origin: " + origin + "\r\n") + "\r\n");
    EXPECT_TRUE(r.json().contains("error")) << r.body;
    return std::make_pair(r.status, r.body);
  };
  // A page of another site must not open the stream.
  auto [status, body] = refusal(kStream, "http://evil.example");
  EXPECT_EQ(status, 403);
  EXPECT_NE(body.find("Origin 'http://evil.example' is not this server's"), std::string::npos);
  std::tie(status, body) = refusal("/api/recordings/0/stream?image=/range");
  EXPECT_EQ(status, 400);
  EXPECT_NE(body.find("holds Double messages; expected an Image channel"), std::string::npos);
  std::tie(status, body) = refusal("/api/recordings/3/stream?image=/camera/image");
  EXPECT_EQ(status, 404);
  std::tie(status, body) = refusal("/api/recordings/0/stream");
  EXPECT_EQ(status, 400);
  EXPECT_NE(body.find("no channel to stream"), std::string::npos);
  // The page's own origin is accepted.
  Client same(server->port(), kStream, "http://127.0.0.1:" + std::to_string(server->port()));
  EXPECT_FALSE(same.error()) << same.error().message();
}

// The 3D view's stream: the LIDAR scan of the time as Float32 points, thinned to max_points.
TEST(ReplayStream, PointCloudsThinnedToTheirBoundAsFloat32) {
  Files files = makeFiles("stream_points");
  files.recording = writeSceneRecording(files);
  std::unique_ptr<Server> server = startServer(files);
  const auto pointsOf = [](const std::vector<Received>& frames) {
    for (const Received& r : frames)
      if (r.image && r.header["type"] == "points") return r;
    ADD_FAILURE() << "no points frame";
    return Received{};
  };
  // 900 finite points of 1000, at most 100: every 9th finite one.
  Client client(
      server->port(),
      "/api/recordings/0/stream?points=/lidar/points&pose=/truth/target_pose&max_points=100");
  ASSERT_FALSE(client.error()) << client.error().message();
  Received first = pointsOf(client.untilState());
  EXPECT_EQ(first.header["count"], 100);
  EXPECT_EQ(first.header["source_count"], kScenePoints);
  EXPECT_EQ(first.header["finite_count"], 900);
  EXPECT_EQ(first.header["stride"], 9);
  EXPECT_EQ(first.header["frame"], "lidar");
  EXPECT_EQ(first.header["channel"], "/lidar/points");
  ASSERT_EQ(first.payload.size(), 100u * 3 * sizeof(float));
  std::vector<float> xyz(300);
  std::memcpy(xyz.data(), first.payload.data(), first.payload.size());
  // Kept point j is finite point 9 j, i.e. point i = 10 j (every 10th point is NaN).
  for (int j = 0; j < 100; ++j) {
    EXPECT_NEAR(xyz[3 * j], 0.01f * (10 * j), 1e-6) << j;
    EXPECT_EQ(xyz[3 * j + 1], 0.0f);
    EXPECT_EQ(xyz[3 * j + 2], 1.0f);
  }
  // The scan of a scrubbed time.
  client.send({{"cmd", "seek"}, {"t", 0.55}});
  Received seek = pointsOf(client.untilState());
  ASSERT_EQ(seek.payload.size(), 1200u);
  std::memcpy(xyz.data(), seek.payload.data(), seek.payload.size());
  EXPECT_EQ(xyz[1], 5.0f);
  EXPECT_NEAR(seek.header["t"].get<double>(), 0.5, 1e-9);

  // Refusals before the upgrade: JSON 4xx naming the value.
  const auto refusal = [&](const std::string& target) {
    const Reply r = sendRaw(server->port(), "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1:" +
                                                std::to_string(server->port()) +
                                                "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                                                "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                                                "Sec-WebSocket-Version: 13\r\n\r\n");
    EXPECT_TRUE(r.json().contains("error")) << r.body;
    return std::make_pair(r.status, r.body);
  };
  auto [status, body] = refusal("/api/recordings/0/stream?points=/camera/image");
  EXPECT_EQ(status, 400);
  EXPECT_NE(body.find("expected a PointCloud channel"), std::string::npos) << body;
  std::tie(status, body) = refusal("/api/recordings/0/stream?points=/lidar/points&max_points=0");
  EXPECT_EQ(status, 400);
  EXPECT_NE(body.find("max_points"), std::string::npos) << body;
  std::tie(status, body) =
      refusal("/api/recordings/0/stream?points=/lidar/points&max_points=1000000");
  EXPECT_EQ(status, 400);
  std::tie(status, body) = refusal("/api/recordings/0/stream?points=/nope");
  EXPECT_EQ(status, 404);
}

TEST(ReplayStream, ABrowserThatDoesNotReadNeverHoldsTheReplayBack) {
  const Files files = makeFiles("stream_slow");
  Result<std::unique_ptr<Recording>> recording = Recording::open(files.recording.string());
  ASSERT_TRUE(recording.isOk()) << recording.status().message();
  // Nobody pops this queue: the browser has stopped reading.
  auto queue = std::make_shared<FrameQueue>(2);
  struct End {
    std::mutex mutex;
    std::condition_variable reached;
    bool ended = false;
  };
  auto end = std::make_shared<End>();
  const auto sink = [queue, end](Frame f) {
    const bool ended =
        !f.binary && json::parse(f.data, nullptr, false).value("ended", false) == true;
    queue->push(std::move(f));
    if (!ended) return;
    std::lock_guard lock(end->mutex);
    end->ended = true;
    end->reached.notify_all();
  };
  Result<std::unique_ptr<ReplayStream>> replay =
      ReplayStream::start(**recording, StreamSpec{"/camera/image", {"/truth/pose"}}, sink,
                          [queue] { return queue->dropped(); });
  ASSERT_TRUE(replay.isOk()) << replay.status().message();
  ASSERT_TRUE((*replay)->command({{"cmd", "speed"}, {"value", 64}}).isOk());
  ASSERT_TRUE((*replay)->command({{"cmd", "play"}}).isOk());
  // 0.9 s of recording at 64x: about 14 ms. The replay reaches its end all the same.
  std::unique_lock lock(end->mutex);
  ASSERT_TRUE(end->reached.wait_for(lock, std::chrono::seconds(10), [&] { return end->ended; }));
  // Start (image, pose, state), speed and play states, 9 images and 9 poses, the end state: 24
  // frames, of which the queue keeps the newest 2 (an image more than 0.2 s late on a loaded
  // machine is skipped, not queued).
  EXPECT_EQ(queue->size(), 2u);
  EXPECT_GE(queue->dropped(), 15u);
  EXPECT_LE(queue->dropped(), 22u);
  queue->pop();
  EXPECT_EQ(json::parse(queue->pop()->data)["ended"], true);
}

TEST(FrameQueue, DropsTheOldestFramesOfASlowBrowserOnly) {
  FrameQueue slow(3), fast(3);
  for (int i = 0; i < 10; ++i) {
    slow.push({false, std::to_string(i)});
    fast.push({false, std::to_string(i)});
    ASSERT_EQ(fast.pop()->data, std::to_string(i));  // a browser that keeps up gets every frame
  }
  EXPECT_EQ(fast.dropped(), 0u);
  EXPECT_EQ(slow.dropped(), 7u);
  EXPECT_EQ(slow.size(), 3u);
  for (const char* kept : {"7", "8", "9"}) EXPECT_EQ(slow.pop()->data, kept);
  EXPECT_FALSE(slow.pop().has_value());
}

// Images and scans (binary, replaced by the next) go before poses and states (text, each its own).
TEST(FrameQueue, DropsTheOldestBinaryFrameFirst) {
  FrameQueue q(3);
  q.push({true, "image 0"});
  q.push({false, "pose 0"});
  q.push({true, "image 1"});
  q.push({false, "pose 1"});  // drops image 0
  q.push({false, "pose 2"});  // drops image 1
  q.push({false, "pose 3"});  // only text waits: drops pose 0
  EXPECT_EQ(q.dropped(), 3u);
  for (const char* kept : {"pose 1", "pose 2", "pose 3"}) EXPECT_EQ(q.pop()->data, kept);
}

}  // namespace
}  // namespace cdff::serve::testing
