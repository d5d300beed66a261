#include "orchestrator/run_roles.h"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netinet/in.h>

#include <fmt/format.h>

namespace coins {

namespace {

const std::set<std::string> kRoles = {"discovery", "replay", "learner", "orchestrator", "actors"};

std::string Range(const std::vector<int64_t>& ids) {
  if (ids.empty()) return "none";
  return ids.size() == 1 ? std::to_string(ids[0]) : fmt::format("{}-{}", ids.front(), ids.back());
}

// "" (every id below n), "K" or "A-B"
Result<std::vector<int64_t>> ParseIds(const std::string& flag, const std::string& text, int64_t n) {
  std::vector<int64_t> ids;
  int64_t first = 0, last = n - 1;
  if (!text.empty()) {
    const size_t dash = text.find('-');
    auto number = [&](const std::string& s, int64_t* out) {
      if (s.empty() || s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos) return false;
      *out = std::stoll(s);
      return true;
    };
    bool ok = dash == std::string::npos ? number(text, &first) && number(text, &last)
                                        : number(text.substr(0, dash), &first) && number(text.substr(dash + 1), &last);
    if (!ok || first > last) return Errorf("{} '{}': expected K or A-B (ids counted from 0)", flag, text);
    if (last >= n) return Errorf("{} '{}': the run has {} (ids 0-{})", flag, text, n, n - 1);
  }
  for (int64_t i = first; i <= last; ++i) ids.push_back(i);
  return ids;
}

}  // namespace

Result<RunRoles> RunRoles::Parse(const std::string& role_list, const std::string& actor_ids,
                                 const std::string& shard_ids, int64_t actors, int64_t shards, bool discovery_server) {
  RunRoles r;
  r.all = role_list.empty();
  if (r.all) {
    r.roles = {"replay", "learner", "orchestrator", "actors"};
    if (discovery_server) r.roles.insert("discovery");
  } else {
    size_t from = 0;
    for (;;) {
      const size_t comma = role_list.find(',', from);
      const std::string role = role_list.substr(from, comma == std::string::npos ? std::string::npos : comma - from);
      if (!kRoles.count(role))
        return Errorf("--role '{}': unknown role '{}' (roles: discovery, replay, learner, orchestrator, actors)",
                      role_list, role);
      r.roles.insert(role);
      if (comma == std::string::npos) break;
      from = comma + 1;
    }
  }
  if (!actor_ids.empty() && !r.Has("actors")) return Errorf("--actor-ids without the actors role");
  if (!shard_ids.empty() && !r.Has("replay")) return Errorf("--shard-ids without the replay role");
  if (r.Has("discovery") && !discovery_server) return Errorf("--role discovery needs dds.discovery: server");
  if (r.Has("actors")) {
    auto ids = ParseIds("--actor-ids", actor_ids, actors);
    if (!ids.ok()) return ids.status();
    r.actor_ids = *ids;
  }
  if (r.Has("replay")) {
    auto ids = ParseIds("--shard-ids", shard_ids, shards);
    if (!ids.ok()) return ids.status();
    r.shard_ids = *ids;
  }
  return r;
}

std::string RunRoles::Describe() const {
  std::string out;
  for (const auto& role : roles) {
    out += out.empty() ? "" : ", ";
    out += role;
    if (role == "actors") out.append(" ").append(Range(actor_ids));
    if (role == "replay") out.append(" ").append(Range(shard_ids));
  }
  return out;
}

std::set<std::string> LocalAddresses() {
  std::set<std::string> out;
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return out;
  for (ifaddrs* a = list; a; a = a->ifa_next) {
    if (!a->ifa_addr || a->ifa_addr->sa_family != AF_INET) continue;
    char text[INET_ADDRSTRLEN];
    const auto* in = reinterpret_cast<const sockaddr_in*>(a->ifa_addr);
    if (::inet_ntop(AF_INET, &in->sin_addr, text, sizeof(text))) out.insert(text);
  }
  ::freeifaddrs(list);
  return out;
}

}  // namespace coins
