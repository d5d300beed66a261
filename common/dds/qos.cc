#include "common/dds/qos.h"

namespace coins::dds {

using namespace eprosima::fastdds::dds;

namespace {

eprosima::fastrtps::Duration_t Seconds(double s) {
  int32_t sec = static_cast<int32_t>(s);
  uint32_t nsec = static_cast<uint32_t>((s - sec) * 1e9);
  return eprosima::fastrtps::Duration_t(sec, nsec);
}

}  // namespace

DataWriterQos TransitionWriterQos(const DdsOptions& options) {
  DataWriterQos q = DATAWRITER_QOS_DEFAULT;
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.reliability().max_blocking_time = Seconds(0.2);
  q.durability().kind = VOLATILE_DURABILITY_QOS;
  q.history().kind = KEEP_ALL_HISTORY_QOS;
  q.resource_limits().max_samples = static_cast<int32_t>(options.transition_history);
  q.resource_limits().max_instances = 1;
  q.resource_limits().max_samples_per_instance = static_cast<int32_t>(options.transition_history);
  q.resource_limits().allocated_samples = static_cast<int32_t>(options.transition_history);
  q.data_sharing().off();
  // history slots are freed by acknowledgements, which answer heartbeats: beat often
  q.reliable_writer_qos().times.heartbeatPeriod = Seconds(0.002);
  // payloads sized to what batches use (their bounds are far larger), reused once allocated
  q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  return q;
}

DataReaderQos TransitionReaderQos(const DdsOptions& options) {
  DataReaderQos q = DATAREADER_QOS_DEFAULT;
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.durability().kind = VOLATILE_DURABILITY_QOS;
  q.history().kind = KEEP_ALL_HISTORY_QOS;
  // every actor of the shard in one unkeyed instance, with room for several full writer histories
  int32_t depth = static_cast<int32_t>(options.transition_history) * 4;
  q.resource_limits().max_instances = 1;
  q.resource_limits().max_samples_per_instance = depth;
  q.resource_limits().max_samples = depth;
  q.resource_limits().allocated_samples = static_cast<int32_t>(options.transition_history);
  q.data_sharing().off();
  q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  q.reliable_reader_qos().times.heartbeatResponseDelay = Seconds(0.0);
  return q;
}

namespace {

// reliable, keep-last `depth`, no data-sharing; QoS is DataWriterQos or DataReaderQos
template <typename QoS>
QoS KeepLast(QoS q, int32_t depth, DurabilityQosPolicyKind durability) {
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.durability().kind = durability;
  q.history().kind = KEEP_LAST_HISTORY_QOS;
  q.history().depth = depth;
  q.data_sharing().off();
  return q;
}

// writers of large, rare samples publish asynchronously (a blob may exceed one datagram)
DataWriterQos Async(DataWriterQos q) {
  q.publish_mode().kind = ASYNCHRONOUS_PUBLISH_MODE;
  return q;
}

}  // namespace

DataWriterQos StatusWriterQos() { return KeepLast(DATAWRITER_QOS_DEFAULT, 4, VOLATILE_DURABILITY_QOS); }
DataReaderQos StatusReaderQos() { return KeepLast(DATAREADER_QOS_DEFAULT, 4, VOLATILE_DURABILITY_QOS); }

DataWriterQos LatchedWriterQos() { return Async(KeepLast(DATAWRITER_QOS_DEFAULT, 1, TRANSIENT_LOCAL_DURABILITY_QOS)); }
DataReaderQos LatchedReaderQos() { return KeepLast(DATAREADER_QOS_DEFAULT, 1, TRANSIENT_LOCAL_DURABILITY_QOS); }

DataWriterQos CommandWriterQos() { return Async(KeepLast(DATAWRITER_QOS_DEFAULT, 64, VOLATILE_DURABILITY_QOS)); }
DataReaderQos CommandReaderQos() { return KeepLast(DATAREADER_QOS_DEFAULT, 64, VOLATILE_DURABILITY_QOS); }

}  // namespace coins::dds
