// Topic names of coins. Every topic's type is the IDL struct named beside it.
#pragma once

namespace coins::dds {

inline constexpr char kTransitionTopic[] = "coins.transitions";          // TransitionBatch, partition shard-K
inline constexpr char kWeightsTopic[] = "coins.weights";                 // PolicyWeights
inline constexpr char kHeartbeatTopic[] = "coins.status.heartbeat";      // ProcessHeartbeat
inline constexpr char kActorStatsTopic[] = "coins.status.actor";         // ActorStats
inline constexpr char kReplayStatsTopic[] = "coins.status.replay";       // ReplayStats
inline constexpr char kChainStatusTopic[] = "coins.status.chain";        // ChainStatus
inline constexpr char kScoresTopic[] = "coins.status.scores";            // InteractionScores
inline constexpr char kSampleRequestTopic[] = "coins.sample.request";    // SampleRequest
inline constexpr char kSampleReplyTopic[] = "coins.sample.reply";        // SampleReply
inline constexpr char kPriorityUpdateTopic[] = "coins.sample.priority";  // PriorityUpdate
inline constexpr char kControlTopic[] = "coins.control";                 // Control
inline constexpr char kChainCommandTopic[] = "coins.chain.command";      // ChainCommand (latched)
inline constexpr char kLearnerStatusTopic[] = "coins.status.learner";    // LearnerStatus

}  // namespace coins::dds
