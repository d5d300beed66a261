#include "common/dds/heartbeat.h"

#include <unistd.h>

#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "idl/statusPubSubTypes.h"

namespace coins::dds {

Result<Heartbeat> Heartbeat::Create(Node& node, const std::string& name, const std::string& role) {
  auto w = node.MakeWriter<msg::ProcessHeartbeatPubSubType>(kHeartbeatTopic, StatusWriterQos());
  if (!w.ok()) return w.status();
  msg::ProcessHeartbeat s;
  s.schema_version(msg::STATUS_SCHEMA);
  s.name(name);
  s.role(role);
  char host[256] = {0};
  gethostname(host, sizeof(host) - 1);
  s.host(host);
  s.pid(static_cast<uint32_t>(getpid()));
  return Heartbeat(*w, std::move(s));
}

void Heartbeat::Publish(const std::string& state) {
  sample_.state(state);
  sample_.uptime_s(std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
  writer_.Write(sample_);
}

}  // namespace coins::dds
