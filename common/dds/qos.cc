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

DataWriterQos StatusWriterQos() {
  DataWriterQos q = DATAWRITER_QOS_DEFAULT;
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.durability().kind = VOLATILE_DURABILITY_QOS;
  q.history().kind = KEEP_LAST_HISTORY_QOS;
  q.history().depth = 4;
  q.data_sharing().off();
  return q;
}

DataReaderQos StatusReaderQos() {
  DataReaderQos q = DATAREADER_QOS_DEFAULT;
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.durability().kind = VOLATILE_DURABILITY_QOS;
  q.history().kind = KEEP_LAST_HISTORY_QOS;
  q.history().depth = 4;
  q.data_sharing().off();
  return q;
}

DataWriterQos LatchedWriterQos() {
  DataWriterQos q = DATAWRITER_QOS_DEFAULT;
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.durability().kind = TRANSIENT_LOCAL_DURABILITY_QOS;
  q.history().kind = KEEP_LAST_HISTORY_QOS;
  q.history().depth = 1;
  q.publish_mode().kind = ASYNCHRONOUS_PUBLISH_MODE;  // blobs may exceed one datagram
  q.data_sharing().off();
  return q;
}

DataReaderQos LatchedReaderQos() {
  DataReaderQos q = DATAREADER_QOS_DEFAULT;
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.durability().kind = TRANSIENT_LOCAL_DURABILITY_QOS;
  q.history().kind = KEEP_LAST_HISTORY_QOS;
  q.history().depth = 1;
  q.data_sharing().off();
  return q;
}

DataWriterQos CommandWriterQos() {
  DataWriterQos q = DATAWRITER_QOS_DEFAULT;
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.durability().kind = VOLATILE_DURABILITY_QOS;
  q.history().kind = KEEP_LAST_HISTORY_QOS;
  q.history().depth = 64;
  q.publish_mode().kind = ASYNCHRONOUS_PUBLISH_MODE;
  q.data_sharing().off();
  return q;
}

DataReaderQos CommandReaderQos() {
  DataReaderQos q = DATAREADER_QOS_DEFAULT;
  q.reliability().kind = RELIABLE_RELIABILITY_QOS;
  q.durability().kind = VOLATILE_DURABILITY_QOS;
  q.history().kind = KEEP_LAST_HISTORY_QOS;
  q.history().depth = 64;
  q.data_sharing().off();
  return q;
}

}  // namespace coins::dds
