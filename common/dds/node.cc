#include "common/dds/node.h"

#include <cstdlib>
#include <mutex>
#include <sstream>

#include <fastrtps/xmlparser/XMLProfileManager.h>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/log/Log.hpp>

#include <spdlog/spdlog.h>

#include "common/dds/discovery.h"
#include "common/dds/participant_ids.h"
#include "common/dds/security.h"

namespace coins::dds {

using namespace eprosima::fastdds::dds;

eprosima::fastrtps::Duration_t ToDuration(std::chrono::nanoseconds d) {
  auto ns = d.count() < 0 ? 0 : d.count();
  return eprosima::fastrtps::Duration_t(static_cast<int32_t>(ns / 1000000000), static_cast<uint32_t>(ns % 1000000000));
}

std::string ShardPartition(int64_t shard) { return "shard-" + std::to_string(shard); }

std::string PublisherOf(const SampleInfo& info) {
  eprosima::fastrtps::rtps::GUID_t guid;
  eprosima::fastrtps::rtps::iHandle2GUID(guid, info.publication_handle);
  std::ostringstream out;
  out << guid;
  return out.str();
}

namespace {
// Process-wide Fast DDS settings, applied once before the first participant:
// - Fast DDS prints only its errors; COINS_FASTDDS_LOG=warning (or info, where compiled in) shows
//   more of its own log on stderr, for debugging discovery and transports.
// - No intraprocess delivery: two participants of one process (an actor's node and its
//   transition sink) talk through shared memory like any two processes. Fast DDS 2.9 keeps a raw
//   pointer to a matched reader of another participant in the same process; when that
//   participant is deleted first, deleting the next one's writers could send a gap through the
//   dangling pointer (seen: coins-actor exiting with SIGSEGV in StatefulWriter::intraprocess_gap
//   about one exit in 15 on a loaded machine).
void ConfigureFastDdsOnce() {
  static std::once_flag once;
  std::call_once(once, [] {
    eprosima::fastrtps::LibrarySettingsAttributes library;
    library.intraprocess_delivery = eprosima::fastrtps::INTRAPROCESS_OFF;
    eprosima::fastrtps::xmlparser::XMLProfileManager::library_settings(library);
    const char* level = std::getenv("COINS_FASTDDS_LOG");
    if (!level) return;
    if (std::string(level) == "warning") Log::SetVerbosity(Log::Warning);
    if (std::string(level) == "info") Log::SetVerbosity(Log::Info);
  });
}
}  // namespace

Result<std::unique_ptr<Node>> Node::Create(const DdsOptions& options, const std::string& name) {
  DomainParticipantQos qos = PARTICIPANT_QOS_DEFAULT;
  qos.name(name);
  COINS_RETURN_IF_ERROR(ConfigureParticipant(options, qos));
  COINS_RETURN_IF_ERROR(ApplySecurity(options, name, qos));
  return Open(options, qos);
}

Result<std::unique_ptr<Node>> Node::Join(const DdsOptions& options, const std::string& name) {
  auto node = Create(options, name);
  if (!node.ok()) return node;
  COINS_RETURN_IF_ERROR((*node)->AwaitDiscoveryServer());
  return node;
}

Result<std::unique_ptr<Node>> Node::CreateDiscoveryServer(const DdsOptions& options, int index) {
  DomainParticipantQos qos = PARTICIPANT_QOS_DEFAULT;
  qos.name("discovery-server-" + std::to_string(index));
  COINS_RETURN_IF_ERROR(ConfigureServer(options, index, qos));
  return Open(options, qos);
}

Result<std::unique_ptr<Node>> Node::Open(const DdsOptions& options, DomainParticipantQos& qos) {
  ConfigureFastDdsOnce();
  // an id whose ports no killed process left behind (participant_ids.h), chosen under the
  // machine-wide lock that lasts until this participant's ports are open
  const int domain = static_cast<int>(options.domain);
  const ParticipantIdLock id_lock(domain);
  if (!id_lock.held()) {
    static std::once_flag warned;
    std::call_once(warned, [&] {
      spdlog::warn(
          "dds: no lock of domain {}'s participant ids (/dev/shm); a process starting at the same moment "
          "may take the same id",
          domain);
    });
  }
  const int id = TakeParticipantId(domain);
  if (id >= 0) {
    qos.wire_protocol().participant_id = id;
  } else {
    static std::once_flag warned;
    std::call_once(warned, [&] {
      spdlog::warn(
          "dds: every participant id 0..{} of domain {} is held, some perhaps by ports of killed processes "
          "(`fastdds shm clean` removes those); this participant's id is Fast DDS's choice, and with local or "
          "peers discovery only participants it announces itself to will find it",
          kParticipantIdLimit - 1, domain);
    });
  }
  // the listener hears about remote participants only: its status mask leaves data and matching
  // to the entities' own wait sets
  auto events = std::make_unique<ParticipantEvents>(qos.name().to_string());
  DomainParticipant* p =
      DomainParticipantFactory::get_instance()->create_participant(domain, qos, events.get(), StatusMask::none());
  if (!p) {
    if (id >= 0) ReleaseParticipantId(domain, id);
    return Errorf("dds: cannot create participant '{}' on domain {} (discovery '{}')", qos.name().to_string(),
                  options.domain, options.discovery);
  }
  return std::unique_ptr<Node>(new Node(options, p, id, std::move(events)));
}

Status Node::AwaitDiscoveryServer() const {
  const std::chrono::duration<double> timeout(options_.server_wait_s);
  if (options_.discovery != "server" ||
      events_->AwaitServer(std::chrono::duration_cast<std::chrono::nanoseconds>(timeout)))
    return Status::Ok();
  return Errorf("dds: no discovery server answered at {} (dds.discovery_server) within {:g} s",
                options_.discovery_server, timeout.count());
}

Node::~Node() {
  // Fast DDS 2.9 releases a deleted writer's samples while they are still in its history, and its
  // periodic heartbeat, walking that history for holes, can then loop forever holding the
  // writer's lock (seen: an actor replacing a stalled transition writer hung with the heartbeat
  // thread at 100% CPU). An empty history gives the heartbeat nothing to walk.
  for (const auto& [partition, publisher] : publishers_) {
    std::vector<DataWriter*> writers;
    if (publisher) publisher->get_datawriters(writers);
    for (DataWriter* w : writers) {
      size_t removed = 0;
      w->clear_history(&removed);
    }
  }
  participant_->delete_contained_entities();
  DomainParticipantFactory::get_instance()->delete_participant(participant_);
  if (participant_id_ >= 0) ReleaseParticipantId(static_cast<int>(options_.domain), participant_id_);
}

Result<Topic*> Node::GetTopic(const std::string& topic, TypeSupport type) {
  auto it = topics_.find(topic);
  if (it != topics_.end()) return it->second;
  if (type.register_type(participant_) != eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK)
    return Errorf("dds: cannot register type {} for topic {}", type.get_type_name(), topic);
  Topic* t = participant_->create_topic(topic, type.get_type_name(), TOPIC_QOS_DEFAULT);
  if (!t) return Errorf("dds: cannot create topic {}", topic);
  topics_[topic] = t;
  return t;
}

Result<DataWriter*> Node::CreateWriter(const std::string& topic, TypeSupport type, const DataWriterQos& qos,
                                       const std::string& partition) {
  auto t = GetTopic(topic, type);
  if (!t.ok()) return t.status();
  Publisher*& pub = publishers_[partition];
  if (!pub) {
    PublisherQos pq = PUBLISHER_QOS_DEFAULT;
    if (!partition.empty()) pq.partition().push_back(partition.c_str());
    pub = participant_->create_publisher(pq);
    if (!pub) return Errorf("dds: cannot create a publisher for partition '{}'", partition);
  }
  DataWriter* w = pub->create_datawriter(*t, qos);
  if (!w) return Errorf("dds: cannot create a writer on {} (partition '{}')", topic, partition);
  return w;
}

Result<DataReader*> Node::CreateReader(const std::string& topic, TypeSupport type, const DataReaderQos& qos,
                                       const std::string& partition) {
  auto t = GetTopic(topic, type);
  if (!t.ok()) return t.status();
  Subscriber*& sub = subscribers_[partition];
  if (!sub) {
    SubscriberQos sq = SUBSCRIBER_QOS_DEFAULT;
    if (!partition.empty()) sq.partition().push_back(partition.c_str());
    sub = participant_->create_subscriber(sq);
    if (!sub) return Errorf("dds: cannot create a subscriber for partition '{}'", partition);
  }
  DataReader* r = sub->create_datareader(*t, qos);
  if (!r) return Errorf("dds: cannot create a reader on {} (partition '{}')", topic, partition);
  return r;
}

Status Node::DetachReaders(const std::string& partition) {
  auto it = subscribers_.find(partition);
  if (it == subscribers_.end() || !it->second) return Errorf("dds: no readers on partition '{}'", partition);
  SubscriberQos sq;
  it->second->get_qos(sq);
  sq.partition().clear();
  std::string detached = partition + ".detached." + std::to_string(reinterpret_cast<uintptr_t>(this));
  sq.partition().push_back(detached.c_str());
  if (it->second->set_qos(sq) != eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK)
    return Errorf("dds: cannot move the readers of partition '{}' away", partition);
  return Status::Ok();
}

}  // namespace coins::dds
