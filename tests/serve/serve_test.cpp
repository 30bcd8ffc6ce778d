// `cdff serve`'s HTTP side in-process: the routes on a small recording, and every refusal a 4xx
// with a JSON {"error"} that names the value at fault (docs/web-ui.md#security).
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "cdff/serve/router.hpp"
#include "serve_fixture.hpp"

namespace cdff::serve::testing {
namespace {

using nlohmann::json;

class ServeTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    files_ = new Files(makeFiles("routes"));
    server_ = startServer(*files_).release();
  }
  static void TearDownTestSuite() {
    delete server_;
    delete files_;
  }
  static unsigned short port() { return server_->port(); }

  // A 4xx whose JSON error contains `words`.
  static void expectRefused(const Reply& r, int status, const std::string& words) {
    EXPECT_EQ(r.status, status) << r.body;
    const json j = r.json();
    ASSERT_TRUE(j.is_object() && j.contains("error")) << r.body;
    EXPECT_NE(j["error"].get<std::string>().find(words), std::string::npos)
        << "error: " << j["error"] << ", expected to contain: " << words;
    EXPECT_EQ(r.headers.at("Content-Type"), "application/json");
  }

  static inline Files* files_ = nullptr;
  static inline Server* server_ = nullptr;
};

TEST_F(ServeTest, ListsTheRecordingAndItsChannelsWithRates) {
  const Reply list = get(port(), "/api/recordings");
  ASSERT_EQ(list.status, 200) << list.body;
  ASSERT_EQ(list.json().size(), 1u);
  EXPECT_EQ(list.json()[0]["name"], "small.mcap");
  EXPECT_NEAR(list.json()[0]["duration_s"].get<double>(), (kFrames - 1) * kPeriod * 1e-6, 1e-9);

  const Reply one = get(port(), "/api/recordings/0");
  ASSERT_EQ(one.status, 200) << one.body;
  const json body = one.json();
  std::map<std::string, json> channels;
  for (const json& c : body["channels"]) channels[c["topic"]] = c;
  ASSERT_EQ(channels.size(), 3u) << one.body;
  EXPECT_EQ(channels["/camera/image"]["type"], "Image");
  EXPECT_EQ(channels["/camera/image"]["schema"], "foxglove.RawImage");
  EXPECT_EQ(channels["/truth/pose"]["type"], "PoseWithCovariance");
  EXPECT_EQ(channels["/range"]["type"], "Double");
  for (const auto& [topic, c] : channels) {
    EXPECT_EQ(c["messages"], kFrames) << topic;
    EXPECT_NEAR(c["rate_hz"].get<double>(), 1e6 / kPeriod, 1e-9) << topic;
  }
}

TEST_F(ServeTest, ServesTheApplication) {
  const Reply index = get(port(), "/");
  ASSERT_EQ(index.status, 200);
  EXPECT_EQ(index.body, "<!doctype html><title>app</title>\n");
  EXPECT_EQ(index.headers.at("Content-Type"), "text/html; charset=utf-8");
  EXPECT_EQ(get(port(), "/index.html").body, index.body);
}

TEST_F(ServeTest, ImageAtATimeIsThatFrameAsAJpeg) {
  // t = 0.55 s after the first frame: frame 5 (0.5 s) is the last one at or before it.
  const Reply r = get(port(), "/api/recordings/0/image?channel=/camera/image&t=0.55");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.headers.at("Content-Type"), "image/jpeg");
  EXPECT_EQ(r.headers.at("X-CDFF-Log-Time-Ns"), std::to_string((kFirstStamp + 5 * kPeriod) * 1000));
  const cv::Mat jpeg =
      cv::imdecode(std::vector<std::uint8_t>(r.body.begin(), r.body.end()), cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(jpeg.cols, 64);
  // A uniform image survives JPEG almost exactly; frame 4 or 6 would be 20 away.
  EXPECT_NEAR(cv::mean(jpeg)[0], 5 * 20, 2.0);

  const Reply small = get(port(), "/api/recordings/0/image?channel=/camera/image&t=0&max_width=32");
  ASSERT_EQ(small.status, 200) << small.body;
  const cv::Mat half = cv::imdecode(std::vector<std::uint8_t>(small.body.begin(), small.body.end()),
                                    cv::IMREAD_GRAYSCALE);
  EXPECT_EQ(half.cols, 32);
  EXPECT_EQ(half.rows, 24);
}

TEST_F(ServeTest, MessagesNearATimeAndPosesAsColumns) {
  const Reply r = get(port(), "/api/recordings/0/messages?channel=/range&t=0.31&count=2");
  ASSERT_EQ(r.status, 200) << r.body;
  ASSERT_EQ(r.json()["messages"].size(), 2u);
  EXPECT_NEAR(r.json()["messages"][0]["t"].get<double>(), 0.3, 1e-9);
  EXPECT_NEAR(r.json()["messages"][1]["t"].get<double>(), 0.4, 1e-9);

  const Reply same =
      post(port(), "/api/recordings/0/messages", R"({"channel": "/range", "t": 0.31, "count": 2})");
  ASSERT_EQ(same.status, 200) << same.body;
  EXPECT_EQ(same.json(), r.json());

  const Reply poses = get(port(), "/api/recordings/0/poses?channel=/truth/pose");
  ASSERT_EQ(poses.status, 200) << poses.body;
  const json p = poses.json();
  ASSERT_EQ(p["t"].size(), static_cast<std::size_t>(kFrames));
  EXPECT_EQ(p["frame"], "world");
  for (int k = 0; k < kFrames; ++k) {
    EXPECT_NEAR(p["t"][k].get<double>(), k * kPeriod * 1e-6, 1e-9);
    EXPECT_DOUBLE_EQ(p["y"][k].get<double>(), 2.0 * k);
  }
  const Reply decimated = get(port(), "/api/recordings/0/poses?channel=/truth/pose&max_points=4");
  ASSERT_EQ(decimated.status, 200) << decimated.body;
  // Every third pose (stride ceil(10 / 4) = 3) and the last: 0, 3, 6, 9.
  EXPECT_EQ(decimated.json()["x"], json::parse("[0.0, 3.0, 6.0, 9.0]"));
}

TEST_F(ServeTest, PathTraversalIsRefused) {
  expectRefused(get(port(), "/../secret.txt"), 400, "'..'");
  expectRefused(get(port(), "/%2e%2e/secret.txt"), 400, "'..'");
  expectRefused(get(port(), "/%2E%2E%2Fsecret.txt"), 400, "'../secret.txt'");
  expectRefused(get(port(), "/app/..%5c..%5csecret.txt"), 400, "'..\\..\\secret.txt'");
  expectRefused(get(port(), "/./index.html"), 400, "'.'");
  expectRefused(get(port(), "/%zz"), 400, "malformed %-escape");
  expectRefused(get(port(), "/api/recordings/0/..%2f..%2fsecret.txt"), 400, "segment");
  // The recording itself is not a file of the application.
  expectRefused(get(port(), "/small.mcap"), 404, "neither an API route");
}

TEST_F(ServeTest, LinksOutOfTheApplicationAreNotFollowed) {
  std::filesystem::create_symlink(files_->secret, files_->app_dir / "leak.html");
  expectRefused(get(port(), "/leak.html"), 404, "/leak.html");
  std::filesystem::remove(files_->app_dir / "leak.html");
}

TEST_F(ServeTest, UnknownRecordingsRoutesAndChannelsAreNotFound) {
  expectRefused(get(port(), "/api/recordings/1"), 404, "recording '1' does not exist");
  expectRefused(get(port(), "/api/recordings/zero"), 404, "recording 'zero'");
  expectRefused(get(port(), "/api/everything"), 404, "no API route '/api/everything'");
  expectRefused(get(port(), "/api/recordings/0/video"), 404, "expected messages, image");
  expectRefused(get(port(), "/missing.js"), 404, "/missing.js");
  expectRefused(get(port(), "/api/recordings/0/image?channel=/camera/left"), 404,
                "channel '/camera/left' has no messages in small.mcap; expected one of "
                "{/camera/image, /range, /truth/pose}");
}

TEST_F(ServeTest, BadQueryValuesNameTheValue) {
  expectRefused(get(port(), "/api/recordings/0/image?channel=/camera/image&t=1.5"), 400,
                "t = 1.5 s is outside the recording; expected seconds in [0, 0.9]");
  expectRefused(get(port(), "/api/recordings/0/image?channel=/camera/image&t=soon"), 400,
                "t = 'soon'");
  expectRefused(get(port(), "/api/recordings/0/image?channel=/range"), 400,
                "holds Double messages; expected an Image channel");
  expectRefused(get(port(), "/api/recordings/0/image"), 400, "'channel' is missing");
  expectRefused(get(port(), "/api/recordings/0/image?channel=/camera/image&colour=red"), 400,
                "'colour' is unknown here; expected one of {channel, t, max_width, quality}");
  expectRefused(get(port(), "/api/recordings/0/poses?channel=/range"), 400,
                "holds Double messages; expected PoseWithCovariance");
  expectRefused(get(port(), "/api/recordings/0/stream"), 400, "WebSocket endpoint");
  expectRefused(sendRaw(port(), "DELETE /api/recordings HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"), 405,
                "method DELETE");
}

TEST_F(ServeTest, MalformedOrOversizedRequestsAreRefused) {
  expectRefused(sendRaw(port(), "HELLO\r\n\r\n"), 400, "malformed HTTP request");
  expectRefused(sendRaw(port(), "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: " +
                                    std::string(10000, 'a') + "\r\n\r\n"),
                431, "header is larger than 8192 bytes");
  expectRefused(post(port(), "/api/recordings/0/messages", std::string(70000, ' ')), 413,
                "body is larger than 65536 bytes");
  expectRefused(post(port(), "/api/recordings/0/messages", R"({"channel": "/range", "t": )"), 400,
                "the body is not JSON (");
  expectRefused(post(port(), "/api/recordings/0/messages", R"({"channel": "/range", "t": "0"})"),
                400, R"("t" = "0": expected seconds)");
  expectRefused(post(port(), "/api/recordings/0/messages", R"({"chanel": "/range"})"), 400,
                R"(key "chanel" is unknown; expected one of {channel, t, count})");
  expectRefused(post(port(), "/api/recordings/0/messages", "channel=/range", "text/plain"), 415,
                "expected application/json");
}

TEST_F(ServeTest, AHostOtherThanLoopbackIsRefusedWithoutAToken) {
  // A page of another site reaching the server by DNS rebinding sends its own host name.
  const Reply r =
      sendRaw(port(), "GET /api/recordings HTTP/1.1\r\nHost: evil.example:8765\r\n\r\n");
  expectRefused(r, 403, "Host 'evil.example:8765' is not this server");
}

TEST(ServeToken, RequiredOnEveryRequestWhenSet) {
  const Files files = makeFiles("token");
  const std::string token = randomToken();
  ASSERT_EQ(token.size(), 32u);
  std::unique_ptr<Server> server = startServer(files, token);
  ASSERT_TRUE(server);
  const unsigned short port = server->port();
  for (const char* target : {"/", "/api/recordings", "/api/recordings/0"}) {
    const Reply none = get(port, target);
    EXPECT_EQ(none.status, 401) << target;
    EXPECT_NE(none.json().value("error", "").find("requires its token"), std::string::npos);
    EXPECT_EQ(get(port, target, {{"Authorization", "Bearer wrong"}}).status, 401) << target;
    EXPECT_EQ(get(port, std::string(target) + "?token=" + token + "x").status, 401) << target;
    EXPECT_EQ(get(port, target, {{"Authorization", "Bearer " + token}}).status, 200) << target;
    EXPECT_EQ(get(port, std::string(target) + "?token=" + token).status, 200) << target;
  }
  // The page opened with ?token= gets it as a cookie, which its own files and requests carry.
  const Reply page = get(port, "/?token=" + token);
  const std::string cookie = "cdff_token_" + std::to_string(port) + "=" + token;
  EXPECT_EQ(page.headers.at("Set-Cookie"), cookie + "; Path=/; HttpOnly; SameSite=Strict");
  EXPECT_EQ(get(port, "/api/recordings", {{"Cookie", "theme=dark; " + cookie}}).status, 200);
  EXPECT_EQ(get(port, "/api/recordings", {{"Cookie", "cdff_token_1=" + token + "0"}}).status, 401);
  // With a token, a Host other than loopback is expected (the server listens elsewhere).
  EXPECT_EQ(sendRaw(port, "GET /api/recordings?token=" + token +
                              " HTTP/1.1\r\nHost: groundstation:8765\r\n\r\n")
                .status,
            200);
}

TEST(ServeToken, ListeningBeyondLoopbackNeedsOne) {
  const Files files = makeFiles("listen");
  ServerOptions options;
  options.address = "0.0.0.0";
  options.port = 0;
  options.app_dir = files.app_dir;
  Result<std::unique_ptr<Server>> server = Server::start(options);
  ASSERT_FALSE(server.isOk());
  EXPECT_EQ(server.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(server.status().message().find("listening on 0.0.0.0 (not the loopback interface) "
                                           "needs a token"),
            std::string::npos)
      << server.status().message();
  EXPECT_TRUE(isLoopbackAddress("127.0.0.1"));
  EXPECT_TRUE(isLoopbackAddress("127.8.0.1"));
  EXPECT_TRUE(isLoopbackAddress("::1"));
  EXPECT_FALSE(isLoopbackAddress("0.0.0.0"));
  EXPECT_FALSE(isLoopbackAddress("192.168.1.4"));
}

TEST(ServeStart, BadOptionsNameTheValue) {
  const Files files = makeFiles("start");
  ServerOptions options;
  options.port = 0;
  options.app_dir = files.dir / "nowhere";
  Result<std::unique_ptr<Server>> server = Server::start(options);
  ASSERT_FALSE(server.isOk());
  EXPECT_NE(server.status().message().find("nowhere' (no index.html)"), std::string::npos);
  options.app_dir = files.app_dir;
  options.address = "localhost-ish";
  server = Server::start(options);
  ASSERT_FALSE(server.isOk());
  EXPECT_NE(server.status().message().find("'localhost-ish' is not an IP address"),
            std::string::npos);
  options.address = "127.0.0.1";
  options.recordings = {(files.dir / "missing.mcap").string()};
  server = Server::start(options);
  ASSERT_FALSE(server.isOk());
  EXPECT_NE(server.status().message().find("missing.mcap"), std::string::npos);
}

TEST(ParseTarget, SplitsAndDecodes) {
  Result<Target> t = parseTarget("/api/recordings/0/image?channel=%2Fcamera%2Fimage&t=1.5&a+b=c");
  ASSERT_TRUE(t.isOk()) << t.status().message();
  EXPECT_EQ(t->segments, (std::vector<std::string>{"api", "recordings", "0", "image"}));
  EXPECT_EQ(t->query.find("channel")->second, "/camera/image");
  EXPECT_EQ(t->query.find("a b")->second, "c");
  EXPECT_FALSE(parseTarget("relative/path").isOk());
  EXPECT_FALSE(parseTarget("/a//b").isOk());
  EXPECT_FALSE(parseTarget("/a/%00").isOk());
  EXPECT_FALSE(parseTarget("/a%2").isOk());
}

}  // namespace
}  // namespace cdff::serve::testing
