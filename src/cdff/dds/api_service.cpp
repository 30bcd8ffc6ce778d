#include "cdff/dds/api_service.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <thread>

#include "cdff/dfpc/recording_streams.hpp"
#include "cdff/types/codec/codec.hpp"
#include "cdff_msgs.h"

namespace cdff::dds {

namespace {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

json vectorJson(const Eigen::Vector3d& v) {
  return json::array({v.x(), v.y(), v.z()});
}

json matrixJson(const Matrix6d& m) {
  json rows = json::array();
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) rows.push_back(m(r, c));
  return rows;
}

ApiReply failed(const Status& status) {
  return {false, status.message(), json(), Value()};
}

ApiReply answer(json result, Value value = Value()) {
  return {true, "", std::move(result), std::move(value)};
}

Result<api::StateRequest> parseStateRequest(const std::string& text) {
  for (api::StateRequest r : {api::StateRequest::kInitialize, api::StateRequest::kIdle,
                              api::StateRequest::kReset, api::StateRequest::kStop})
    if (text == api::toString(r)) return r;
  return invalidInput("setCDFFState('{}'): expected initialize, idle, reset or stop", text);
}

ApiReply dfpcState(api::Cdff& cdff, const std::string& dfpc) {
  Result<dfpc::DfpcStatus> s = cdff.getDFPCStatus(dfpc);
  if (!s) return failed(s.status());
  return answer(
      {{"dfpc", dfpc},
       {"state", dfpc::toString(s->state)},
       {"track_state", s->track_state ? json(std::string(toString(*s->track_state))) : json()}});
}

ApiReply velocity(const api::Cdff& cdff, const std::string& frame) {
  Result<api::VelocityWithCovariance> v = cdff.getTargetRelativeVelocity(frame);
  if (!v) return failed(v.status());
  return answer({{"stamp_us", v->stamp},
                 {"frame", v->frame},
                 {"target_frame", v->target_frame},
                 {"linear", vectorJson(v->twist.linear)},
                 {"angular", vectorJson(v->twist.angular)},
                 {"covariance", matrixJson(v->covariance)}});
}

ApiReply model(const api::Cdff& cdff) {
  Result<api::TargetModel> m = cdff.getModelOfTarget();
  if (!m) return failed(m.status());
  json result{{"product", m->product}, {"stamp_us", m->stamp}};
  if (m->mesh) {
    result["mesh"] = {{"vertices", m->mesh->vertexCount()},
                      {"triangles", m->mesh->triangleCount()}};
    return answer(result, Value::of(*m->mesh));
  }
  result["cloud"] = {{"points", m->cloud ? m->cloud->size() : 0}};
  return answer(result, m->cloud ? Value::of(*m->cloud) : Value());
}

// The methods that take no argument, and those that need one (a frame may be "").
const std::vector<std::string_view> kWithoutArgument = {"getCDFFState", "getModelOfTarget"};
const std::vector<std::string_view> kWithDfpc = {"getDFPCStatus", "initDFPC", "stopDFPC"};

ApiReply dispatch(api::Cdff& cdff, const std::string& method, const std::string& argument) {
  if (method == "getCDFFState") return answer({{"state", toString(cdff.getCDFFState())}});
  if (method == "setCDFFState") {
    Result<api::StateRequest> request = parseStateRequest(argument);
    if (!request) return failed(request.status());
    if (Status s = cdff.setCDFFState(*request); !s) return failed(s);
    return answer({{"state", toString(cdff.getCDFFState())}});
  }
  if (method == "getDFPCStatus") {
    Result<dfpc::DfpcStatus> s = cdff.getDFPCStatus(argument);
    return s ? answer(dfpc::statusRecord(*s)) : failed(s.status());
  }
  if (method == "initDFPC" || method == "stopDFPC") {
    const Status s = method == "initDFPC" ? cdff.initDFPC(argument) : cdff.stopDFPC(argument);
    return s ? dfpcState(cdff, argument) : failed(s);
  }
  if (method == "getTargetRelativePose") {
    Result<PoseWithCovariance> pose = cdff.getTargetRelativePose(argument);
    if (!pose) return failed(pose.status());
    return answer(codec::toJson(*pose), Value::of(*pose));
  }
  if (method == "getTargetRelativeVelocity") return velocity(cdff, argument);
  return model(cdff);  // getModelOfTarget: the methods were checked by callApi()
}

}  // namespace

const std::vector<std::string_view>& apiMethods() {
  static const std::vector<std::string_view> methods = {"getCDFFState",
                                                        "setCDFFState",
                                                        "getDFPCStatus",
                                                        "initDFPC",
                                                        "stopDFPC",
                                                        "getTargetRelativePose",
                                                        "getTargetRelativeVelocity",
                                                        "getModelOfTarget"};
  return methods;
}

ApiReply callApi(api::Cdff& cdff, const std::string& method, const std::string& argument) {
  const auto& methods = apiMethods();
  if (std::find(methods.begin(), methods.end(), method) == methods.end())
    return failed(
        invalidInput("unknown method '{}'; expected one of {}", method, fmt::join(methods, ", ")));
  const auto in = [&](const std::vector<std::string_view>& list) {
    return std::find(list.begin(), list.end(), method) != list.end();
  };
  if (in(kWithoutArgument) && !argument.empty())
    return failed(invalidInput("{} takes no argument; got '{}'", method, argument));
  if (in(kWithDfpc) && argument.empty())
    return failed(invalidInput("{} needs a DFPC's name; got none", method));
  try {
    return dispatch(cdff, method, argument);
  } catch (const std::exception& e) {
    return failed(Status(StatusCode::kInternal, fmt::format("{}('{}'): unexpected exception: {}",
                                                            method, argument, e.what())));
  }
}

// ---- server ---------------------------------------------------------------------------------

namespace {

// The reader and writer of a service side: `in` is read, `out` written.
Status openEndpoints(Participant& participant, const char* in_topic,
                     const dds_topic_descriptor_t* in_type, const char* out_topic,
                     const dds_topic_descriptor_t* out_type, dds_entity_t& reader,
                     dds_entity_t& writer, dds_entity_t& waitset) {
  Result<dds_entity_t> in = participant.topic(in_topic, in_type);
  if (!in) return in.status();
  Result<dds_entity_t> out = participant.topic(out_topic, out_type);
  if (!out) return out.status();
  Result<dds_entity_t> r = participant.createReader(*in, {});
  if (!r) return r.status().withContext(in_topic);
  reader = *r;
  Result<dds_entity_t> w = participant.createWriter(*out, {});
  if (!w) return w.status().withContext(out_topic);
  writer = *w;
  waitset = dds_create_waitset(participant.handle());
  if (waitset < 0) return ddsError(waitset, "creating a DDS waitset");
  if (dds_return_t rc = dds_waitset_attach(waitset, reader, reader); rc < 0)
    return ddsError(rc, fmt::format("waiting on '{}'", in_topic));
  return Status::ok();
}

void deleteEndpoints(dds_entity_t reader, dds_entity_t writer, dds_entity_t waitset) {
  if (waitset > 0) dds_delete(waitset);
  if (reader > 0) dds_delete(reader);
  if (writer > 0) dds_delete(writer);
}

}  // namespace

Result<std::unique_ptr<ApiServer>> ApiServer::create(Participant& participant, api::Cdff& cdff) {
  std::unique_ptr<ApiServer> server(new ApiServer(cdff));
  CDFF_RETURN_IF_ERROR(openEndpoints(
      participant, kApiRequestTopic, &cdff_msgs_srv_dds__Api_Request__desc, kApiReplyTopic,
      &cdff_msgs_srv_dds__Api_Response__desc, server->reader_, server->writer_, server->waitset_));
  return server;
}

ApiServer::~ApiServer() {
  deleteEndpoints(reader_, writer_, waitset_);
}

Status ApiServer::reply(const void* sample) {
  const auto& request = *static_cast<const cdff_msgs_srv_dds__Api_Request_*>(sample);
  const std::string method = request.method ? request.method : "";
  const std::string argument = request.argument ? request.argument : "";
  const ApiReply r = callApi(cdff_, method, argument);
  const std::string result = r.result.is_null() ? "" : r.result.dump();
  std::vector<std::uint8_t> data;
  std::string type_name, encoding;
  if (r.value) {
    const TypeInfo& info = r.value.type().info();
    codec::Encoded encoded;
    CDFF_RETURN_IF_ERROR(info.encode(r.value.raw(), 0, encoded));
    data = encoded.flatten();
    type_name = info.name;
    encoding = info.messageEncoding();
  }
  cdff_msgs_srv_dds__Api_Response_ out{};
  out.client_id = request.client_id;
  out.sequence_number = request.sequence_number;
  out.ok = r.ok;
  out.error = const_cast<char*>(r.error.c_str());
  out.result = const_cast<char*>(result.c_str());
  out.type_name = const_cast<char*>(type_name.c_str());
  out.encoding = const_cast<char*>(encoding.c_str());
  const auto size = static_cast<std::uint32_t>(data.size());
  out.data = {size, size, data.data(), false};
  if (dds_return_t rc = dds_write(writer_, &out); rc < 0)
    return ddsError(rc,
                    fmt::format("replying to {}('{}') on '{}'", method, argument, kApiReplyTopic));
  ++served_;
  return Status::ok();
}

Status ApiServer::serve(double timeout_s) {
  const dds_return_t woken =
      dds_waitset_wait(waitset_, nullptr, 0, static_cast<dds_duration_t>(timeout_s * 1e9));
  if (woken < 0) return ddsError(woken, "waiting for API requests");
  void* samples[16] = {};
  dds_sample_info_t infos[16];
  for (;;) {
    const dds_return_t n = dds_take(reader_, samples, infos, 16, 16);
    if (n < 0) return ddsError(n, fmt::format("taking requests from '{}'", kApiRequestTopic));
    if (n == 0) return Status::ok();
    Status status;
    for (dds_return_t i = 0; i < n && status.isOk(); ++i)
      if (infos[i].valid_data) status = reply(samples[i]);
    dds_return_loan(reader_, samples, n);
    CDFF_RETURN_IF_ERROR(status);
  }
}

// ---- client ---------------------------------------------------------------------------------

Result<std::unique_ptr<ApiClient>> ApiClient::create(Participant& participant) {
  std::unique_ptr<ApiClient> client(new ApiClient());
  client->domain_ = participant.domain();
  CDFF_RETURN_IF_ERROR(openEndpoints(
      participant, kApiReplyTopic, &cdff_msgs_srv_dds__Api_Response__desc, kApiRequestTopic,
      &cdff_msgs_srv_dds__Api_Request__desc, client->reader_, client->writer_, client->waitset_));
  if (dds_return_t rc = dds_get_instance_handle(client->writer_, &client->client_id_); rc < 0)
    return ddsError(rc, "reading the request writer's instance handle");
  return client;
}

ApiClient::~ApiClient() {
  deleteEndpoints(reader_, writer_, waitset_);
}

Status ApiClient::waitForServer(double timeout_s) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    dds_publication_matched_status_t requests{};
    dds_subscription_matched_status_t replies{};
    dds_get_publication_matched_status(writer_, &requests);
    dds_get_subscription_matched_status(reader_, &replies);
    if (requests.current_count > 0 && replies.current_count > 0) return Status::ok();
    if (Clock::now() > deadline)
      return Status(StatusCode::kTimeout,
                    fmt::format("no CDFF API server on DDS domain {} after {} s (requests "
                                "matched by {} readers, replies by {} writers); expected a "
                                "`cdff node` on that domain",
                                domain_, timeout_s, requests.current_count, replies.current_count));
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

namespace {

// The reply's value, decoded by its recording codec.
Result<Value> replyValue(const cdff_msgs_srv_dds__Api_Response_& reply) {
  const std::string name = reply.type_name ? reply.type_name : "";
  if (name.empty()) return Value();
  const TypeId type = findType(name);
  if (!type)
    return corruptData("API reply with a value of type '{}': expected one of {}", name,
                       typeNames());
  auto bytes = std::make_shared<std::vector<std::uint8_t>>(reply.data._buffer,
                                                           reply.data._buffer + reply.data._length);
  Result<Value> value = type.info().decode(Bytes(*bytes), bytes);
  if (!value) return value.status().withContext(fmt::format("API reply's {}", name));
  return value;
}

Result<ApiReply> readReply(const cdff_msgs_srv_dds__Api_Response_& reply) {
  ApiReply out;
  out.ok = reply.ok;
  out.error = reply.error ? reply.error : "";
  const std::string result = reply.result ? reply.result : "";
  if (!result.empty()) {
    out.result = json::parse(result, nullptr, false);
    if (out.result.is_discarded())
      return corruptData("API reply's result is not JSON: '{}'", result.substr(0, 200));
  }
  Result<Value> value = replyValue(reply);
  if (!value) return value.status();
  out.value = std::move(value).value();
  return out;
}

}  // namespace

Result<ApiReply> ApiClient::call(const std::string& method, const std::string& argument,
                                 double timeout_s) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
  CDFF_RETURN_IF_ERROR(waitForServer(timeout_s));
  cdff_msgs_srv_dds__Api_Request_ request{};
  request.client_id = client_id_;
  request.sequence_number = ++sequence_;
  request.method = const_cast<char*>(method.c_str());
  request.argument = const_cast<char*>(argument.c_str());
  if (dds_return_t rc = dds_write(writer_, &request); rc < 0)
    return ddsError(rc,
                    fmt::format("sending {}('{}') on '{}'", method, argument, kApiRequestTopic));
  void* samples[16] = {};
  dds_sample_info_t infos[16];
  while (Clock::now() < deadline) {
    const auto left = std::chrono::duration<double>(deadline - Clock::now()).count();
    const dds_return_t woken = dds_waitset_wait(
        waitset_, nullptr, 0, static_cast<dds_duration_t>(std::max(0.0, left) * 1e9));
    if (woken < 0) return ddsError(woken, "waiting for the API reply");
    const dds_return_t n = dds_take(reader_, samples, infos, 16, 16);
    if (n < 0) return ddsError(n, fmt::format("taking replies from '{}'", kApiReplyTopic));
    std::optional<Result<ApiReply>> mine;
    for (dds_return_t i = 0; i < n; ++i) {
      const auto& reply = *static_cast<const cdff_msgs_srv_dds__Api_Response_*>(samples[i]);
      // Other clients' replies, and late replies to this client's earlier requests, are not ours.
      if (infos[i].valid_data && reply.client_id == client_id_ &&
          reply.sequence_number == sequence_)
        mine = readReply(reply);
    }
    if (n > 0) dds_return_loan(reader_, samples, n);
    if (mine) return *mine;
  }
  return Status(StatusCode::kTimeout,
                fmt::format("{}('{}'): no reply on '{}' after {} s (the server on DDS domain {} "
                            "matched the request)",
                            method, argument, kApiReplyTopic, timeout_s, domain_));
}

}  // namespace cdff::dds
