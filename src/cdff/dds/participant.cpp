#include "cdff/dds/participant.hpp"

#include <fmt/format.h>

#include <cstdlib>

namespace cdff::dds {

Status ddsError(dds_return_t code, std::string_view what) {
  const StatusCode status =
      code == DDS_RETCODE_TIMEOUT ? StatusCode::kTimeout : StatusCode::kIoError;
  return {status, fmt::format("{}: {} (DDS return code {})", what, dds_strretcode(code), code)};
}

Result<std::unique_ptr<Participant>> Participant::create(int domain) {
  if (domain < 0 || domain > kMaxDomainId)
    return invalidParameter("DDS domain {}; expected 0 to {}", domain, kMaxDomainId);
  const char* uri = std::getenv("CYCLONEDDS_URI");
  if (uri == nullptr || *uri == '\0') {
    // The domain lives until the process ends; a second create() finds it there.
    const dds_entity_t created =
        dds_create_domain(static_cast<dds_domainid_t>(domain), kDefaultConfiguration);
    if (created < 0 && created != DDS_RETCODE_PRECONDITION_NOT_MET)
      return ddsError(created, fmt::format("configuring DDS domain {}", domain));
  }
  const dds_entity_t participant =
      dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
  if (participant < 0)
    return ddsError(participant, fmt::format("creating a participant in DDS domain {}", domain));
  return std::unique_ptr<Participant>(new Participant(participant, domain));
}

Participant::~Participant() {
  dds_delete(participant_);
}

Result<dds_entity_t> Participant::topic(const std::string& name,
                                        const dds_topic_descriptor_t* descriptor) {
  const std::string key = name + '\n' + descriptor->m_typename;
  if (auto found = topics_.find(key); found != topics_.end()) return found->second;
  const dds_entity_t topic =
      dds_create_topic(participant_, descriptor, name.c_str(), nullptr, nullptr);
  if (topic < 0)
    return ddsError(topic,
                    fmt::format("creating topic '{}' of type {}", name, descriptor->m_typename));
  topics_.emplace(key, topic);
  return topic;
}

namespace {

// Reliable, XCDR1: what ROS 2 on rmw_cyclonedds uses.
dds_qos_t* commonQos(double max_blocking_s) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE,
                       static_cast<dds_duration_t>(max_blocking_s * 1e9));
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(qos, 1, &xcdr1);
  return qos;
}

}  // namespace

Result<dds_entity_t> Participant::createWriter(dds_entity_t topic, const WriterQos& q) {
  dds_qos_t* qos = commonQos(q.max_blocking_s);
  if (q.durability == Durability::kTransientLocal && q.depth > 0) {
    dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, q.depth);
    // Cyclone keeps a transient-local writer's history for late joiners as deep as its
    // durability service says (1 by default).
    dds_qset_durability_service(qos, 0, DDS_HISTORY_KEEP_LAST, q.depth, DDS_LENGTH_UNLIMITED,
                                DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
  } else {
    dds_qset_durability(qos, q.durability == Durability::kTransientLocal
                                 ? DDS_DURABILITY_TRANSIENT_LOCAL
                                 : DDS_DURABILITY_VOLATILE);
    dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, DDS_LENGTH_UNLIMITED);
  }
  if (!q.user_data.empty()) dds_qset_userdata(qos, q.user_data.data(), q.user_data.size());
  const dds_entity_t writer = dds_create_writer(participant_, topic, qos, nullptr);
  dds_delete_qos(qos);
  if (writer < 0) return ddsError(writer, "creating a DDS writer");
  return writer;
}

Result<dds_entity_t> Participant::createReader(dds_entity_t topic, const ReaderQos& q) {
  dds_qos_t* qos = commonQos(0.1);
  dds_qset_durability(qos, q.durability == Durability::kTransientLocal
                               ? DDS_DURABILITY_TRANSIENT_LOCAL
                               : DDS_DURABILITY_VOLATILE);
  dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, DDS_LENGTH_UNLIMITED);
  const dds_entity_t reader = dds_create_reader(participant_, topic, qos, nullptr);
  dds_delete_qos(qos);
  if (reader < 0) return ddsError(reader, "creating a DDS reader");
  if (dds_return_t rc = dds_set_status_mask(reader, DDS_DATA_AVAILABLE_STATUS); rc < 0)
    return ddsError(rc, "enabling a reader's data-available status");
  return reader;
}

std::string userDataValue(std::string_view user_data, std::string_view key) {
  std::size_t at = 0;
  while (at < user_data.size()) {
    std::size_t end = user_data.find(';', at);
    if (end == std::string_view::npos) end = user_data.size();
    const std::string_view pair = user_data.substr(at, end - at);
    const std::size_t eq = pair.find('=');
    if (eq != std::string_view::npos && pair.substr(0, eq) == key)
      return std::string(pair.substr(eq + 1));
    at = end + 1;
  }
  return "";
}

}  // namespace cdff::dds
