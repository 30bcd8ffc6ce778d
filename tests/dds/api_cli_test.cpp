// The external API (seed §7.3) over DDS: `cdff node dfpcs/pose_filtering.yaml` serves it on
// rq/cdff/apiRequest / rr/cdff/apiReply; this test feeds the node pose measurements over DDS and
// calls it with `cdff api` (and the ApiClient the command uses): the CDFF's and the DFPC's
// status, the target's pose and velocity, a DFPC stopped; unknown methods, DFPCs, states and
// frames get error replies that say what and which value; no node is a timeout that says so.
#include <nlohmann/json.hpp>

#include "cdff/dds/api_service.hpp"
#include "cdff/dds/publisher.hpp"
#include "dds/cli_support.hpp"

namespace {

namespace fs = std::filesystem;
using namespace cdff::testing;
using nlohmann::json;

constexpr int kMeasurements = 20;

struct Call {
  int status;
  json result;        // the answer (stdout) when the call succeeded
  std::string error;  // the output otherwise
};

Call api(int domain, const std::string& call) {
  const auto r = runCdff(fmt::format("api {} --domain {} --timeout 10", call, domain));
  Call out{r.status, json(), r.output};
  if (r.status == 0) out.result = json::parse(r.output, nullptr, false);
  return out;
}

TEST(DdsApi, ANodeAnswersTheExternalApiOverDds) {
  const fs::path dir = scratchDirectory("cdff_dds_api");
  fs::current_path(CDFF_SOURCE_DIR);
  const int domain = claimTestDomain();
  const fs::path log = dir / "node.log";
  const pid_t node =
      spawnCdff({"node", "dfpcs/pose_filtering.yaml", "--domain", std::to_string(domain)}, log);
  ASSERT_TRUE(waitForText(log, "external API on rq/cdff/apiRequest", 20)) << readFile(log);
  EXPECT_EQ(api(domain, "getCDFFState").result, json({{"state", "running"}}));
  publishMeasurements(domain, 0, kMeasurements);

  // The DFPC's status: running, every measurement delivered (the node takes them in its time).
  json status;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  do {
    const Call c = api(domain, "getDFPCStatus pose_filtering");
    ASSERT_EQ(c.status, 0) << c.error;
    status = c.result;
  } while (status["messages"] != kMeasurements && std::chrono::steady_clock::now() < deadline);
  EXPECT_EQ(status["name"], "pose_filtering");
  EXPECT_EQ(status["state"], "running");
  EXPECT_EQ(status["messages"], kMeasurements) << status.dump();
  EXPECT_GT(status["products"].get<int>(), 0) << status.dump();
  EXPECT_EQ(status["instances"][0]["dfn"], "EstimationFilter");

  // The target's pose and velocity: the filter's last state, in the camera frame.
  const Call pose = api(domain, "getTargetRelativePose");
  ASSERT_EQ(pose.status, 0) << pose.error;
  EXPECT_EQ(pose.result["pose"]["parent_frame"], "camera");
  EXPECT_EQ(pose.result["pose"]["child_frame"], "target");
  EXPECT_NEAR(pose.result["pose"]["translation"][2].get<double>(), 10.0, 0.01) << pose.result;
  EXPECT_NEAR(pose.result["pose"]["translation"][0].get<double>(), 0.19, 0.05) << pose.result;
  const Call velocity = api(domain, "getTargetRelativeVelocity camera");
  ASSERT_EQ(velocity.status, 0) << velocity.error;
  EXPECT_EQ(velocity.result["frame"], "camera");
  EXPECT_NEAR(velocity.result["linear"][0].get<double>(), 0.2, 0.1) << velocity.result;

  // The client library gets the pose as a value too (its recording codec's bytes).
  auto participant = cdff::dds::Participant::create(domain);
  ASSERT_TRUE(participant.isOk());
  auto client = cdff::dds::ApiClient::create(**participant);
  ASSERT_TRUE(client.isOk()) << client.status().message();
  auto reply = (*client)->call("getTargetRelativePose", "", 10);
  ASSERT_TRUE(reply.isOk()) << reply.status().message();
  ASSERT_TRUE(reply->ok) << reply->error;
  const auto* value = reply->value.get<cdff::PoseWithCovariance>();
  ASSERT_NE(value, nullptr);
  EXPECT_EQ(value->pose.stamp, pose.result["pose"]["stamp_us"].get<cdff::Timestamp>());
  EXPECT_EQ(value->pose.translation.z(), pose.result["pose"]["translation"][2].get<double>());

  // Stopping the DFPC.
  const Call stopped = api(domain, "stopDFPC pose_filtering");
  ASSERT_EQ(stopped.status, 0) << stopped.error;
  EXPECT_EQ(stopped.result["state"], "stopped");
  EXPECT_EQ(api(domain, "getDFPCStatus pose_filtering").result["state"], "stopped");

  // Errors: what was asked, which value, what is accepted.
  const std::vector<std::pair<std::string, std::string>> errors = {
      {"getDFPCStatus lidar_tracking",
       "error: no DFPC 'lidar_tracking'; expected one of {pose_filtering}"},
      {"stopDFPC pose_filtering", "error: DFPC 'pose_filtering' is stopped; expected running"},
      {"getPose",
       "error: unknown method 'getPose'; expected one of getCDFFState, setCDFFState, "
       "getDFPCStatus, initDFPC, stopDFPC, getTargetRelativePose, "
       "getTargetRelativeVelocity, getModelOfTarget"},
      {"setCDFFState pause",
       "error: setCDFFState('pause'): expected initialize, idle, reset or "
       "stop"},
      {"setCDFFState initialize",
       "error: setCDFFState(initialize) in state running; accepted here: idle, reset, stop (it is "
       "running already)"},
      {"getDFPCStatus", "error: getDFPCStatus needs a DFPC's name; got none"},
      {"getTargetRelativePose servicer", "error: no transform from 'camera' to 'servicer'"},
      {"getModelOfTarget", "error: no DFPC output has role target_model"}};
  for (const auto& [call, message] : errors) {
    const Call c = api(domain, call);
    EXPECT_EQ(c.status, 1) << call;
    EXPECT_NE(c.error.find(message), std::string::npos) << call << ": " << c.error;
  }
  // Another domain has no node: the client says so.
  const auto none =
      runCdff(fmt::format("api getCDFFState --domain {} --timeout 0.5", claimTestDomain()));
  EXPECT_EQ(none.status, 1);
  EXPECT_NE(none.output.find("no CDFF API server on DDS domain"), std::string::npos) << none.output;

  EXPECT_EQ(stopProcess(node), 0) << readFile(log);
  EXPECT_NE(readFile(log).find(" API requests"), std::string::npos) << readFile(log);
}

}  // namespace
