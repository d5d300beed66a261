// The sampling service's topics and QoS, shared by coins-replay and the learner's client.
//   coins.sample.request   SampleRequest   client -> shards (every shard reads, shard_id selects)
//   coins.sample.reply     SampleReply     shards -> clients (matched by correlation_id)
//   coins.sample.priority  PriorityUpdate  client -> shards (shard_id selects)
// Reliable, keep-last, volatile; replies can be megabytes, so writers publish asynchronously
// and both sides size payloads dynamically (the bounds in sampling.idl are far above use).
#pragma once

#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include "common/dds/topics.h"

namespace coins::dds {

inline eprosima::fastdds::dds::DataWriterQos SamplingWriterQos(int depth) {
  namespace f = eprosima::fastdds::dds;
  f::DataWriterQos q = f::DATAWRITER_QOS_DEFAULT;
  q.reliability().kind = f::RELIABLE_RELIABILITY_QOS;
  q.reliability().max_blocking_time = eprosima::fastrtps::Duration_t(1, 0);
  q.durability().kind = f::VOLATILE_DURABILITY_QOS;
  q.history().kind = f::KEEP_LAST_HISTORY_QOS;
  q.history().depth = depth;
  q.publish_mode().kind = f::ASYNCHRONOUS_PUBLISH_MODE;
  q.data_sharing().off();
  q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  q.reliable_writer_qos().times.heartbeatPeriod = eprosima::fastrtps::Duration_t(0, 5'000'000);
  return q;
}

inline eprosima::fastdds::dds::DataReaderQos SamplingReaderQos(int depth) {
  namespace f = eprosima::fastdds::dds;
  f::DataReaderQos q = f::DATAREADER_QOS_DEFAULT;
  q.reliability().kind = f::RELIABLE_RELIABILITY_QOS;
  q.durability().kind = f::VOLATILE_DURABILITY_QOS;
  q.history().kind = f::KEEP_LAST_HISTORY_QOS;
  q.history().depth = depth;
  q.data_sharing().off();
  q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  q.reliable_reader_qos().times.heartbeatResponseDelay = eprosima::fastrtps::Duration_t(0, 0);
  return q;
}

}  // namespace coins::dds
