// Building, checking, hashing and decoding TransitionBatch samples (idl/transition.idl).
//
// BatchBuilder fills a batch row by row: the first row's state whole, later rows as the
// features that changed since the row before. Finish() stamps the header and the payload hash.
// ValidateBatch() is what a receiver runs before it stores anything: schema version, sizes
// within bounds and consistent, delta indices in range, finite values and the payload hash;
// its error names the batch and the first thing wrong.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "idl/transition.h"

namespace coins {

using msg::TransitionBatch;

// identifies an env name together with the batch dimensions
uint32_t LayoutHash(std::string_view env_name, uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim);

// 64-bit checksum of bytes (Fletcher-style lane sums folded through a 64-bit mixer); `seed` chains
// calls. Chained calls hash the same only when split at the same places, so sender and
// receiver hash the same pieces. It detects corruption and double counting, not attacks.
uint64_t HashBytes(const void* data, size_t n, uint64_t seed = 0xcbf29ce484222325ULL);
// the batch's provenance as one fixed block: command_seq, then COINS_MAX_LEVELS policy versions
// (zero-padded); stores keep it beside the columns
inline constexpr size_t kProvenanceWords = 1 + COINS_MAX_LEVELS;
void ProvenanceBlock(const TransitionBatch& b, uint64_t out[kProvenanceWords]);
// hash over the batch's sequences, one piece per sequence in IDL order, then the provenance block
// hash of every field of the batch but payload_hash itself: the header (HeaderHash) seeds the
// chain, then one piece per sequence in IDL order. A changed actor, incarnation, sequence
// number, env, layout, size or episode counter fails the check like a changed value does.
uint64_t PayloadHash(const TransitionBatch& b);

// true when none of the n floats is NaN or infinite
bool AllFinite(const float* v, size_t n);

// checks a received batch; expected_layout 0 accepts any layout. check_hash false leaves the
// payload hash to the caller (a store that hashes its own copy).
Status ValidateBatch(const TransitionBatch& b, uint32_t expected_layout = 0, bool check_hash = true);

// transitions in a batch: rows without ROW_SEGMENT_START
uint32_t CountTransitions(const TransitionBatch& b);

// Delta-encoded rows (the one implementation every reader uses: the batch codec, the replay
// store, the sampler and the sampling client). A row's deltas are pairs (index, value):
// state[index[k]] = value[k] for k in [0, n), in order, so a later write of a feature wins.
// Indices must be below the state's size (ValidateBatch checks received batches).
inline void ApplyDeltas(const uint16_t* index, const float* value, size_t n, float* state) {
  for (size_t k = 0; k < n; ++k) state[index[k]] = value[k];
}
// decodes n_rows states of dim floats (row-major) into out: row 0 is first_state, row r is row
// r-1 with the deltas [delta_end[r-1], delta_end[r]) applied
void DecodeDeltaRows(const float* first_state, uint32_t dim, uint32_t n_rows, const uint32_t* delta_end,
                     const uint16_t* delta_index, const float* delta_value, float* out);

// writes the batch's n_rows x state_dim states (row-major) into out; the batch must be valid
void DecodeStates(const TransitionBatch& b, float* out);

struct BatchHeader {
  uint32_t actor_id = 0;
  uint64_t incarnation = 0;
  uint64_t seq = 0;
  uint32_t env_id = 0;
  uint32_t layout_hash = 0;
  uint32_t state_dim = 0;
  uint32_t action_dim = 0;
  uint32_t goal_dim = 0;
  uint64_t episode_base = 0;
  uint64_t command_seq = 0;
  uint64_t policy_versions[COINS_MAX_LEVELS] = {};
};

// the header part of PayloadHash: schema version, the header fields and n_rows (what a store
// keeps beside the columns, so that it can hash its stored copy the same way)
uint64_t HeaderHash(uint32_t schema_version, const BatchHeader& h, uint32_t n_rows);

class BatchBuilder {
 public:
  // starts filling `batch` (not owned; its sequences keep their capacity across batches)
  // with at most max_rows rows (0 or more than the bound: COINS_BATCH_MAX_ROWS)
  void Begin(TransitionBatch* batch, const BatchHeader& header, uint32_t max_rows);
  // appends a row; the caller checks full() first
  void AddRow(std::span<const float> state, std::span<const float> action, std::span<const float> goal, float reward,
              uint16_t flags, uint8_t skill_level, uint32_t interactions);
  // true when the next row might not fit (rows, or room for a row of all-changed features)
  bool full() const;
  uint32_t rows() const { return rows_; }
  uint32_t max_rows() const { return max_rows_; }
  // the command and the weights versions that produced the rows (stamped by Finish)
  void SetProvenance(uint64_t command_seq, std::span<const uint64_t> policy_versions);
  // the sequence number the batch goes out with (stamped by Finish, covered by the hash)
  void set_seq(uint64_t seq) { h_.seq = seq; }
  // stamps the header and the payload hash; returns the hash
  uint64_t Finish();

 private:
  TransitionBatch* b_ = nullptr;
  BatchHeader h_;
  uint32_t max_rows_ = 0;
  uint32_t rows_ = 0;
  std::vector<float> prev_;  // state of the last row added
};

}  // namespace coins
