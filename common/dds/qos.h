// QoS profiles of the coins topics. One function per kind of stream so that every process
// opening a topic uses the same, matching settings.
#pragma once

#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include "common/dds/dds_options.h"

namespace coins::dds {

// transitions: reliable, keep-all with a bounded history (back-pressure instead of loss), a
// short heartbeat so acknowledgements free history slots quickly. Data-sharing stays off: its
// readers acknowledge samples on arrival, after which the writer may reuse their memory while
// the shard still reads it (seen as corrupt and lost batches with Fast DDS 2.9).
eprosima::fastdds::dds::DataWriterQos TransitionWriterQos(const DdsOptions& options);
eprosima::fastdds::dds::DataReaderQos TransitionReaderQos(const DdsOptions& options);

// periodic status: reliable, keep the last few per instance, volatile
eprosima::fastdds::dds::DataWriterQos StatusWriterQos();
eprosima::fastdds::dds::DataReaderQos StatusReaderQos();

// latched state (weights, chain status): reliable, transient-local, last value per instance;
// late joiners get the newest sample
eprosima::fastdds::dds::DataWriterQos LatchedWriterQos();
eprosima::fastdds::dds::DataReaderQos LatchedReaderQos();

// commands and request/reply: reliable, keep-last 64, volatile
eprosima::fastdds::dds::DataWriterQos CommandWriterQos();
eprosima::fastdds::dds::DataReaderQos CommandReaderQos();

}  // namespace coins::dds
