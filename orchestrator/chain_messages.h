// The DDS side of the chain: conversions between the chain's plain types (chain_state.h) and the
// IDL messages (ChainCommand, ChainStatus, InteractionScores, LearnerStatus), and the per-level
// goal counts summed over actors.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "idl/control.h"
#include "idl/status.h"
#include "orchestrator/chain_machine.h"

namespace coins {

msg::LinkSpec ToMessage(const chain::LinkSpec& l);
msg::ChainCommand ToMessage(const chain::Command& c, const std::string& run_id);
chain::ScoresReport FromMessage(const msg::InteractionScores& m);
chain::LearnerReport FromMessage(const msg::LearnerStatus& m);
msg::InteractionScore ToMessage(const chain::Score& s);
// ChainStatus of the machine; message: what the chain is doing, one line
msg::ChainStatus ToChainStatus(const chain::ChainMachine& m, const std::string& run_id, const std::string& message);

// GoalCounter: cumulative goals started / reached per level, summed over actors. An actor whose
// counts drop (it restarted) continues from where its counts were, so sums never go back.
class GoalCounter {
 public:
  void Add(const msg::ActorStats& s);
  // (started, reached) of level (1-based)
  std::pair<uint64_t, uint64_t> Level(int level) const;
  int levels() const;

 private:
  struct Counts {
    std::vector<uint64_t> started, reached;                  // newest report
    std::vector<uint64_t> carried_started, carried_reached;  // from earlier incarnations
  };
  std::map<uint32_t, Counts> actors_;
};

}  // namespace coins
