#pragma once
// The external API (seed §7.3, cdff/dfpc/api.hpp) over DDS, as a ROS 2 service `/cdff/api`
// (cdff_msgs/srv/Api, idl/cdff_msgs.idl): requests on rq/cdff/apiRequest, replies on
// rr/cdff/apiReply. A request names a method and one argument; the reply says ok or why not, the
// answer as JSON and, for a pose or a model, the value as recordings encode it.
//
//   method                       argument               result (JSON)
//   getCDFFState                 -                      {"state": "running"}
//   setCDFFState                 initialize|idle|reset|stop  {"state": the state after}
//   getDFPCStatus                DFPC                   the DfpcStatus (state, track state...)
//   initDFPC, stopDFPC           DFPC                   {"dfpc", "state", "track_state"}
//   getTargetRelativePose        frame ("" its own)     the PoseWithCovariance (+ its value)
//   getTargetRelativeVelocity    frame ("" its own)     twist and covariance in that frame
//   getModelOfTarget             -                      product, stamp, size (+ the mesh or cloud)
//
// Server (`cdff node`):
//   auto server = ApiServer::create(participant, cdff).value();
//   while (running) CDFF_RETURN_IF_ERROR(server->serve(0.05));
// Client (`cdff api`):
//   auto client = ApiClient::create(participant).value();
//   Result<ApiReply> reply = client->call("getDFPCStatus", "far_range_tracking", 5.0);
//
// A request is matched to its reply as rmw_cyclonedds does: the client's request-writer instance
// handle and a sequence number, repeated in the reply; a client reads only its own replies.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "cdff/dds/participant.hpp"
#include "cdff/dfpc/api.hpp"

namespace cdff::dds {

inline constexpr const char* kApiRequestTopic = "rq/cdff/apiRequest";
inline constexpr const char* kApiReplyTopic = "rr/cdff/apiReply";

/// The methods served.
const std::vector<std::string_view>& apiMethods();

struct ApiReply {
  bool ok = false;
  std::string error;      // why not, when not ok
  nlohmann::json result;  // the answer
  Value value;            // a pose or a model, when the answer has one
};

/// The answer of the API to one request: what the server sends back. An unknown method, a
/// missing or superfluous argument, and every error of the API are a reply that is not ok and
/// says why; never an exception.
ApiReply callApi(api::Cdff& cdff, const std::string& method, const std::string& argument);

class ApiServer {
 public:
  static Result<std::unique_ptr<ApiServer>> create(Participant& participant, api::Cdff& cdff);
  ~ApiServer();
  ApiServer(const ApiServer&) = delete;
  ApiServer& operator=(const ApiServer&) = delete;

  /// Waits up to `timeout_s` for requests and answers every one received.
  Status serve(double timeout_s);
  std::uint64_t served() const { return served_; }

 private:
  ApiServer(api::Cdff& cdff) : cdff_(cdff) {}
  Status reply(const void* request);

  api::Cdff& cdff_;
  dds_entity_t reader_ = 0, writer_ = 0, waitset_ = 0;
  std::uint64_t served_ = 0;
};

class ApiClient {
 public:
  static Result<std::unique_ptr<ApiClient>> create(Participant& participant);
  ~ApiClient();
  ApiClient(const ApiClient&) = delete;
  ApiClient& operator=(const ApiClient&) = delete;

  /// Waits (within `timeout_s` in all) for a server, sends the request and waits for its reply.
  /// An error when no server answers in time (the reply's own errors are in the ApiReply).
  Result<ApiReply> call(const std::string& method, const std::string& argument, double timeout_s);

 private:
  ApiClient() = default;
  Status waitForServer(double timeout_s);

  int domain_ = 0;
  dds_entity_t reader_ = 0, writer_ = 0, waitset_ = 0;
  std::uint64_t client_id_ = 0;
  std::int64_t sequence_ = 0;
};

}  // namespace cdff::dds
