// Node: one DDS participant of a coins process, with the transports of DdsOptions, and the
// topics, publishers, subscribers, writers and readers it created. Destroying the Node deletes
// every entity it made, in order.
//
// Writers and readers are returned as typed wrappers over DataWriter / DataReader; a publisher
// or subscriber is made per partition (a transition writer for shard k uses partition
// "shard-k"). Not thread-safe: create entities from one thread; the wrappers' Write/Take may
// be used from the thread that owns them.
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "common/dds/dds_options.h"
#include "common/dds/participant_events.h"
#include "common/status.h"

namespace coins::dds {

namespace fdds = eprosima::fastdds::dds;

// ThreadSanitizer happens-before annotations (no-ops in other builds): what a thread did before
// TsanPublished(p) happens before what another does after TsanReceived(p)
#if defined(__SANITIZE_THREAD__)
extern "C" void __tsan_acquire(void* addr);
extern "C" void __tsan_release(void* addr);
inline void TsanPublished(void* p) { __tsan_release(p); }
inline void TsanReceived(void* p) { __tsan_acquire(p); }
#else
inline void TsanPublished(void*) {}
inline void TsanReceived(void*) {}
#endif

eprosima::fastrtps::Duration_t ToDuration(std::chrono::nanoseconds d);
// the partition name of replay shard k
std::string ShardPartition(int64_t shard);
// the GUID of the writer that published a sample (its participant's prefix, then the writer's
// entity id), for log lines that name a sender
std::string PublisherOf(const fdds::SampleInfo& info);

// A generated TopicDataType whose getKey may be called from several threads at once. The
// generated getKey of a keyed type writes into buffers the type object owns (m_keyBuffer,
// m_md5), and a participant uses one registered type object for every writer and reader of a
// topic: a process that writes and reads a keyed topic (heartbeats in the orchestrator) then
// computes keys on its own thread and on the DDS receive thread into the same buffer (found by
// ThreadSanitizer). Node registers every type through this wrapper.
//
// Fast DDS hands the type object to its own threads through its internal atomics, which a
// ThreadSanitizer build cannot see (the library is not instrumented): the constructor and
// getKey tell it that construction happens before any getKey (TsanPublished/TsanReceived).
template <typename PubSubType>
class KeySafeType final : public PubSubType {
 public:
  KeySafeType() { TsanPublished(this); }
  bool getKey(void* data, eprosima::fastrtps::rtps::InstanceHandle_t* handle, bool force_md5) override {
    TsanReceived(this);
    std::lock_guard<std::mutex> lock(key_mu_);
    return PubSubType::getKey(data, handle, force_md5);
  }

 private:
  std::mutex key_mu_;
};

template <typename T>
class Writer {
 public:
  explicit Writer(fdds::DataWriter* w = nullptr) : w_(w) {}
  // publishes a copy of the sample; false when the writer timed out on a full history
  bool Write(const T& sample) { return w_->write(const_cast<T*>(&sample)); }
  fdds::DataWriter* raw() const { return w_; }
  // number of readers currently matched
  int matched() const {
    fdds::PublicationMatchedStatus s;
    w_->get_publication_matched_status(s);
    return s.current_count;
  }
  // waits until every sample written has been acknowledged by the matched readers
  bool WaitAcked(std::chrono::nanoseconds timeout) {
    return w_->wait_for_acknowledgments(ToDuration(timeout)) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
  }

 private:
  fdds::DataWriter* w_;
};

template <typename T>
class Reader {
 public:
  explicit Reader(fdds::DataReader* r = nullptr) : r_(r) {}
  // waits up to timeout for unread data; true when there is some
  bool Wait(std::chrono::nanoseconds timeout) { return r_->wait_for_unread_message(ToDuration(timeout)); }
  // takes every available sample (copying), calling fn(sample, info) for valid data
  template <typename Fn>
  int TakeAll(Fn&& fn) {
    T sample;
    return TakeAll(sample, std::forward<Fn>(fn));
  }
  // takes every available sample into `scratch` (reused, so its sequences keep their
  // capacity), calling fn(scratch, info) for valid data
  template <typename Fn>
  int TakeAll(T& scratch, Fn&& fn) {
    int n = 0;
    fdds::SampleInfo info;
    while (r_->take_next_sample(&scratch, &info) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      fn(scratch, info);
      ++n;
    }
    return n;
  }
  fdds::DataReader* raw() const { return r_; }
  // number of writers currently matched
  int matched() const {
    fdds::SubscriptionMatchedStatus s;
    r_->get_subscription_matched_status(s);
    return s.current_count;
  }

 private:
  fdds::DataReader* r_;
};

class Node {
 public:
  // creates the participant; `name` identifies the process in DDS tools
  static Result<std::unique_ptr<Node>> Create(const DdsOptions& options, const std::string& name);
  // Create, then (dds.discovery: server) AwaitDiscoveryServer for dds.server_wait_s: a process
  // that cannot reach its discovery server stops with an error naming the addresses
  static Result<std::unique_ptr<Node>> Join(const DdsOptions& options, const std::string& name);
  // discovery server number `index` of options.discovery_server (common/dds/discovery.h)
  static Result<std::unique_ptr<Node>> CreateDiscoveryServer(const DdsOptions& options, int index);
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  template <typename PubSubType>
  Result<Writer<typename PubSubType::type>> MakeWriter(const std::string& topic, const fdds::DataWriterQos& qos,
                                                       const std::string& partition = "") {
    auto w = CreateWriter(topic, fdds::TypeSupport(new KeySafeType<PubSubType>()), qos, partition);
    if (!w.ok()) return w.status();
    return Writer<typename PubSubType::type>(*w);
  }
  template <typename PubSubType>
  Result<Reader<typename PubSubType::type>> MakeReader(const std::string& topic, const fdds::DataReaderQos& qos,
                                                       const std::string& partition = "") {
    auto r = CreateReader(topic, fdds::TypeSupport(new KeySafeType<PubSubType>()), qos, partition);
    if (!r.ok()) return r.status();
    return Reader<typename PubSubType::type>(*r);
  }

  // moves the readers of `partition` to a partition of their own, so that they unmatch every
  // writer: nothing more is received (or acknowledged), while samples already received stay
  // readable. A stopping shard does this before its last take.
  Status DetachReaders(const std::string& partition);

  fdds::DomainParticipant* participant() const { return participant_; }
  const DdsOptions& options() const { return options_; }
  // the participant id it took (common/dds/participant_ids.h); -1 when Fast DDS chose one
  int participant_id() const { return participant_id_; }
  // remote participants refused by DDS Security (authentication failed); 0 without security
  uint64_t refused_participants() const { return events_->refused(); }
  // remote participants DDS Security authenticated and authorized so far; 0 without security
  uint64_t authorized_participants() const { return events_->authorized(); }
  // with dds.discovery: server, waits up to dds.server_wait_s until a discovery server of
  // dds.discovery_server answers; the error names the addresses (other modes: Ok at once)
  Status AwaitDiscoveryServer() const;

 private:
  Node(const DdsOptions& options, fdds::DomainParticipant* p, int participant_id,
       std::unique_ptr<ParticipantEvents> events)
      : options_(options), events_(std::move(events)), participant_(p), participant_id_(participant_id) {}
  // creates the participant of `qos` with a participant id of its own and its listener
  static Result<std::unique_ptr<Node>> Open(const DdsOptions& options, fdds::DomainParticipantQos& qos);
  Result<fdds::Topic*> GetTopic(const std::string& topic, fdds::TypeSupport type);
  Result<fdds::DataWriter*> CreateWriter(const std::string& topic, fdds::TypeSupport type,
                                         const fdds::DataWriterQos& qos, const std::string& partition);
  Result<fdds::DataReader*> CreateReader(const std::string& topic, fdds::TypeSupport type,
                                         const fdds::DataReaderQos& qos, const std::string& partition);

  DdsOptions options_;
  std::unique_ptr<ParticipantEvents> events_;  // outlives the participant (declared first)
  fdds::DomainParticipant* participant_;
  int participant_id_;  // -1: chosen by Fast DDS
  std::map<std::string, fdds::Topic*> topics_;
  std::map<std::string, fdds::Publisher*> publishers_;
  std::map<std::string, fdds::Subscriber*> subscribers_;
};

}  // namespace coins::dds
