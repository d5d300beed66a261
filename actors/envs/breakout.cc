#include "actors/envs/breakout.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "actors/envs/bytes.h"

namespace coins::envs {
namespace {

constexpr uint32_t kSaveMagic = 0x314b5242;  // "BRK1"
constexpr int kF = 5;                        // features per Breakout object

bool Overlap(int y0, int x0, int h0, int w0, int y1, int x1, int h1, int w1) {
  return y0 < y1 + h1 && y1 < y0 + h0 && x0 < x1 + w1 && x1 < x0 + w0;
}

int NumBlocks(BreakoutVariant v) {
  switch (v) {
    case BreakoutVariant::kBase: return 100;
    case BreakoutVariant::kSingle: return 1;
    case BreakoutVariant::kHard: return 60;
    case BreakoutVariant::kBig: return 1;
    case BreakoutVariant::kNeg: return 10;
    case BreakoutVariant::kCenter: return 45;
    case BreakoutVariant::kProx: return 60;
  }
  return 0;
}

FactorSpec ObjectFactor(const std::string& name, int instances, float attr_low, float attr_high) {
  FactorSpec f;
  f.name = name;
  f.features = kF;
  f.instances = instances;
  f.low = {0.0f, 0.0f, -2.0f, -1.0f, attr_low};
  f.high = {84.0f, 84.0f, 2.0f, 1.0f, attr_high};
  f.feature_names = {"y", "x", "vy", "vx", "attr"};
  return f;
}

FactorSpec ScalarFactor(const std::string& name, float low, float high, const std::string& feat) {
  FactorSpec f;
  f.name = name;
  f.features = 1;
  f.low = {low};
  f.high = {high};
  f.feature_names = {feat};
  return f;
}

}  // namespace

std::string BreakoutName(BreakoutVariant v) {
  switch (v) {
    case BreakoutVariant::kBase: return "breakout";
    case BreakoutVariant::kSingle: return "breakout-single";
    case BreakoutVariant::kHard: return "breakout-hard";
    case BreakoutVariant::kBig: return "breakout-big";
    case BreakoutVariant::kNeg: return "breakout-neg";
    case BreakoutVariant::kCenter: return "breakout-center";
    case BreakoutVariant::kProx: return "breakout-prox";
  }
  return "breakout";
}

BreakoutEnv::BreakoutEnv(BreakoutVariant variant) : variant_(variant) {
  // spec: action, paddle, ball, blocks, (target), done, reward
  spec_.name = BreakoutName(variant);
  spec_.factors.push_back(ObjectFactor("Action", 1, 0.0f, 3.0f));
  spec_.factors.push_back(ObjectFactor("Paddle", 1, -1.0f, 1.0f));
  spec_.factors.push_back(ObjectFactor("Ball", 1, -1.0f, 1.0f));
  spec_.factors.push_back(ObjectFactor("Block", NumBlocks(variant), -1.0f, 1.0f));
  spec_.factors.back().multi_instance = true;
  if (variant == BreakoutVariant::kProx) spec_.factors.push_back(ObjectFactor("Target", 1, -1.0f, 1.0f));
  spec_.factors.push_back(ScalarFactor("Done", 0.0f, 1.0f, "done"));
  spec_.factors.push_back(ScalarFactor("Reward", -10.0f, 5.0f, "reward"));
  spec_.action.discrete = true;
  spec_.action.n = 4;
  spec_.action.dim = 1;
  spec_.action.low = {0.0f};
  spec_.action.high = {3.0f};
  spec_.interactions = {{"Action", "Paddle"}, {"Paddle", "Ball"}, {"Ball", "Block"}};
  spec_.max_episode_steps = 0;

  block_offset_ = spec_.factor_offset(spec_.factor_index("Block"));
  if (variant == BreakoutVariant::kProx) target_offset_ = spec_.factor_offset(spec_.factor_index("Target"));
  done_offset_ = spec_.factor_offset(spec_.factor_index("Done"));
  reward_offset_ = spec_.factor_offset(spec_.factor_index("Reward"));
  blocks_.resize(NumBlocks(variant));
  obs_.assign(spec_.state_dim(), 0.0f);
  Reset(0, obs_);
}

void BreakoutEnv::BuildBoard() {
  auto set = [](Block& b, int y, int x, int h, int w, Kind kind, int attr) {
    b = Block{y, x, h, w, kind, static_cast<int8_t>(attr)};
  };
  switch (variant_) {
    case BreakoutVariant::kBase:
      for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 20; ++j) set(blocks_[i * 20 + j], 22 + 2 * i, 12 + 3 * j, 2, 3, Kind::kNormal, 1);
      break;
    case BreakoutVariant::kSingle:
      set(blocks_[0], rng_.UniformInt(17, 36), rng_.UniformInt(15, 65), 4, 6, Kind::kGoal, 1);
      break;
    case BreakoutVariant::kHard: {
      // all 60 slots empty, then one goal and ten hard blocks in distinct random slots
      for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 12; ++j) set(blocks_[i * 12 + j], 22 + 2 * i, 12 + 5 * j, 2, 5, Kind::kNormal, 0);
      int order[60];
      for (int k = 0; k < 60; ++k) order[k] = k;
      for (int k = 0; k < 11; ++k) std::swap(order[k], order[rng_.UniformInt(k, 59)]);
      blocks_[order[0]].kind = Kind::kGoal;
      blocks_[order[0]].attr = 1;
      for (int k = 1; k < 11; ++k) {
        blocks_[order[k]].kind = Kind::kHard;
        blocks_[order[k]].attr = -1;
      }
      break;
    }
    case BreakoutVariant::kBig: set(blocks_[0], 17, 15 + 15 * rng_.UniformInt(0, 3), 18, 12, Kind::kGoal, 1); break;
    case BreakoutVariant::kNeg: {
      for (int j = 0; j < 10; ++j) set(blocks_[j], 22, 12 + 6 * j, 4, 6, Kind::kNormal, 1);
      int order[10];
      for (int k = 0; k < 10; ++k) order[k] = k;
      for (int k = 0; k < 5; ++k) std::swap(order[k], order[rng_.UniformInt(k, 9)]);
      for (int k = 0; k < 5; ++k) {
        blocks_[order[k]].kind = Kind::kNegative;
        blocks_[order[k]].attr = -1;
      }
      break;
    }
    case BreakoutVariant::kCenter:
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 15; ++j) {
          const int x = 12 + 4 * j;
          const bool hard = x > 28 && x < 56;
          set(blocks_[i * 15 + j], 22 + 3 * i, x, 3, 4, hard ? Kind::kHard : Kind::kNormal, hard ? -1 : 1);
        }
      break;
    case BreakoutVariant::kProx:
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 15; ++j) set(blocks_[i * 15 + j], 22 + 2 * i, 12 + 4 * j, 2, 4, Kind::kNormal, 1);
      break;
  }
  // bounding rows of the board, for the quick miss test
  blocks_y0_ = kScreen;
  blocks_y1_ = 0;
  for (const Block& b : blocks_) {
    blocks_y0_ = std::min(blocks_y0_, b.y);
    blocks_y1_ = std::max(blocks_y1_, b.y + b.h);
  }
  board_cleared_ = false;
  target_ = -1;
  if (variant_ == BreakoutVariant::kProx) PickTarget();
}

void BreakoutEnv::Serve() {
  ball_y_ = rng_.UniformInt(43, 45);
  ball_x_ = rng_.UniformInt(14, 69);
  ball_vy_ = 1;
  ball_vx_ = rng_.UniformInt(0, 1) ? 1 : -1;
  since_touch_ = 0;
}

void BreakoutEnv::PickTarget() {
  int live = 0;
  for (const Block& b : blocks_) live += b.attr != 0;
  if (live == 0) {
    target_ = -1;
    return;
  }
  int k = rng_.UniformInt(0, live - 1);
  for (int i = 0; i < static_cast<int>(blocks_.size()); ++i) {
    if (blocks_[i].attr == 0) continue;
    if (k-- == 0) {
      target_ = i;
      return;
    }
  }
}

int BreakoutEnv::LiveNormalBlocks() const {
  int n = 0;
  for (const Block& b : blocks_) n += b.kind == Kind::kNormal && b.attr != 0;
  return n;
}

void BreakoutEnv::Reset(uint64_t seed, std::span<float> state) {
  rng_.Seed(seed);
  paddle_x_ = kPaddleX0;
  drops_ = 0;
  BuildBoard();
  StartEpisode(state);
}

void BreakoutEnv::ResetNext(std::span<float> state) {
  // the base board persists across drops; variants start each episode on a new board
  const bool rebuild = variant_ != BreakoutVariant::kBase || drops_ >= 5 || board_cleared_;
  if (rebuild) {
    drops_ = 0;
    BuildBoard();
  }
  StartEpisode(state);
}

void BreakoutEnv::StartEpisode(std::span<float> state) {
  Serve();
  bounces_ = hits_ = 0;
  last_action_ = 0;
  last_reward_ = last_done_ = 0.0f;
  episode_over_ = false;
  SyncAll();
  GetState(state);
}

void BreakoutEnv::HitBlock(int i, StepResult* r) {
  Block& b = blocks_[i];
  r->interactions |= kBallBlock;
  ++hits_;
  switch (variant_) {
    case BreakoutVariant::kBase:
      r->reward += b.attr;
      b.attr = 0;
      if (LiveNormalBlocks() == 0) {
        board_cleared_ = true;
        r->done = true;
      }
      break;
    case BreakoutVariant::kSingle:
    case BreakoutVariant::kBig:
      r->reward += 1.0f;
      b.attr = 0;
      r->done = true;
      break;
    case BreakoutVariant::kHard:
      if (b.kind == Kind::kGoal) {
        r->reward += 1.0f;
        b.attr = 0;
        r->done = true;
      }
      break;
    case BreakoutVariant::kNeg:
      r->reward += b.attr;
      b.attr = 0;  // restored at the end of the step
      if (hits_ >= 5) r->done = true;
      break;
    case BreakoutVariant::kCenter:
      if (b.kind == Kind::kNormal) {
        b.attr = 0;
        if (LiveNormalBlocks() == 0) {
          r->reward += 5.0f;
          r->done = true;
        }
      }
      break;
    case BreakoutVariant::kProx: {
      const Block& t = blocks_[target_ >= 0 ? target_ : i];
      // l1 distance between centres (doubled coordinates keep it integer)
      const float d = 0.5f * static_cast<float>(std::abs((2 * b.y + b.h) - (2 * t.y + t.h)) +
                                                std::abs((2 * b.x + b.w) - (2 * t.x + t.w)));
      r->reward += 2.0f * (std::exp(-d / 10.0f) - 0.2f);
      b.attr = 0;
      if (hits_ >= 60) r->done = true;
      break;
    }
  }
  SyncBlock(i);
}

void BreakoutEnv::ApplyRestores() {
  if (variant_ == BreakoutVariant::kNeg) {
    for (int i = 0; i < static_cast<int>(blocks_.size()); ++i) {
      Block& b = blocks_[i];
      const int8_t want = b.kind == Kind::kNegative ? -1 : 1;
      if (b.attr != want) {
        b.attr = want;
        SyncBlock(i);
      }
    }
  } else if (variant_ == BreakoutVariant::kProx) {
    for (int j = 0; j < 15; ++j)
      if (blocks_[j].attr == 0) {
        blocks_[j].attr = 1;
        SyncBlock(j);
      }
  }
}

namespace {

// a step's arguments, checked before the step touches anything
Status CheckStep(const std::string& env, std::span<const float> action, size_t state_size, size_t obs_size,
                 bool episode_over) {
  if (action.size() != 1) return Errorf("{}: action must be 1 float (a discrete index), got {}", env, action.size());
  const float a = action[0];
  if (!std::isfinite(a)) return Errorf("{}: action {} is not a finite number", env, a);
  if (a != std::floor(a)) return Errorf("{}: action {} is not an integer index", env, a);
  if (a < 0.0f || a > 3.0f) return Errorf("{}: action {} out of range [0, 3]", env, a);
  if (state_size != obs_size) return Errorf("{}: state buffer has {} floats, expected {}", env, state_size, obs_size);
  if (episode_over) return Errorf("{}: the episode is over; call ResetNext or Reset", env);
  return Status::Ok();
}

}  // namespace

bool BreakoutEnv::BounceOffPaddle(int ny, int nx, StepResult* r) {
  if (ball_vy_ <= 0 || !Overlap(ny, nx, kBallSize, kBallSize, kPaddleY, paddle_x_, kPaddleH, kPaddleW)) return false;
  // the offset of the ball's next x on the paddle picks one of four angles
  const int rel = nx - paddle_x_;
  if (rel <= 0)
    ball_vy_ = -1, ball_vx_ = -1;
  else if (rel <= 2)
    ball_vy_ = -2, ball_vx_ = -1;
  else if (rel <= 4)
    ball_vy_ = -2, ball_vx_ = 1;
  else
    ball_vy_ = -1, ball_vx_ = 1;
  r->interactions |= kPaddleBall;
  since_touch_ = -1;
  ++bounces_;
  if (variant_ == BreakoutVariant::kSingle || variant_ == BreakoutVariant::kHard ||
      variant_ == BreakoutVariant::kCenter)
    r->reward -= 1.0f;
  if (variant_ == BreakoutVariant::kHard && bounces_ >= 10) r->done = true;
  return true;
}

void BreakoutEnv::BounceOffBlocks(int ny, int nx, StepResult* r) {
  if (ny >= blocks_y1_ || ny + kBallSize <= blocks_y0_) return;
  // only the first live block hit counts
  for (int i = 0; i < static_cast<int>(blocks_.size()); ++i) {
    const Block& b = blocks_[i];
    if (b.attr == 0 || !Overlap(ny, nx, kBallSize, kBallSize, b.y, b.x, b.h, b.w)) continue;
    if (ball_y_ == b.y)
      ball_vx_ = -ball_vx_;  // level with the block's top: a side hit
    else
      ball_vy_ = -ball_vy_;
    HitBlock(i, r);
    break;
  }
}

Status BreakoutEnv::Step(std::span<const float> action, std::span<float> next_state, StepResult* result) {
  COINS_RETURN_IF_ERROR(CheckStep(spec_.name, action, next_state.size(), obs_.size(), episode_over_));
  StepResult r;
  const int act = static_cast<int>(action[0]);
  last_action_ = act;

  // paddle
  int px = paddle_x_ + (act == 2 ? -kPaddleStep : act == 3 ? kPaddleStep : 0);
  px = std::clamp(px, kPaddleMinX, kPaddleMaxX);
  if (px != paddle_x_) r.interactions |= kActionPaddle;
  paddle_x_ = px;

  // walls, tested with the ball's next position
  const int ny = ball_y_ + ball_vy_, nx = ball_x_ + ball_vx_;
  bool drop = false;
  if (nx < kLeftWallX + kWallThickness && ball_vx_ < 0) ball_vx_ = -ball_vx_;
  if (nx + kBallSize > kRightWallX && ball_vx_ > 0) ball_vx_ = -ball_vx_;
  if (ny < kTopWallY + kWallThickness && ball_vy_ < 0) {
    if (variant_ == BreakoutVariant::kBig)
      drop = true;  // big: one bounce to hit the block
    else
      ball_vy_ = -ball_vy_;
  }

  // paddle bounce, else a drop below the paddle
  if (!BounceOffPaddle(ny, nx, &r) && ny + kBallSize > kBottomWallY) drop = true;

  if (!drop) BounceOffBlocks(ny, nx, &r);

  // move, or drop
  if (drop) {
    ball_y_ = ny;
    ball_x_ = nx;
    r.reward += variant_ == BreakoutVariant::kHard ? -2.0f : -10.0f;
    r.done = true;
    ++drops_;
  } else {
    ball_y_ += ball_vy_;
    ball_x_ += ball_vx_;
  }

  // per-step restores, prox target, and the no-touch re-serve
  if (r.interactions & kBallBlock) {
    ApplyRestores();
    if (variant_ == BreakoutVariant::kProx) PickTarget();
  }
  if (!r.done && ++since_touch_ >= kNoTouchReserve) Serve();

  episode_over_ = r.done || r.truncated;
  last_reward_ = r.reward;
  last_done_ = r.done ? 1.0f : 0.0f;
  SyncDynamic();
  std::memcpy(next_state.data(), obs_.data(), obs_.size() * sizeof(float));
  *result = r;
  return Status::Ok();
}

void BreakoutEnv::SyncBlock(int i) {
  const Block& b = blocks_[i];
  float* o = obs_.data() + block_offset_ + kF * i;
  o[0] = b.y + 0.5f * b.h;
  o[1] = b.x + 0.5f * b.w;
  o[2] = 0.0f;
  o[3] = 0.0f;
  o[4] = b.attr;
}

void BreakoutEnv::SyncDynamic() {
  float* o = obs_.data();
  // action
  o[0] = o[1] = o[2] = o[3] = 0.0f;
  o[4] = static_cast<float>(last_action_);
  // paddle (velocity is always zero)
  o[5] = kPaddleY + 0.5f * kPaddleH;
  o[6] = paddle_x_ + 0.5f * kPaddleW;
  o[7] = o[8] = 0.0f;
  o[9] = 1.0f;
  // ball
  o[10] = ball_y_ + 0.5f * kBallSize;
  o[11] = ball_x_ + 0.5f * kBallSize;
  o[12] = static_cast<float>(ball_vy_);
  o[13] = static_cast<float>(ball_vx_);
  o[14] = 1.0f;
  if (target_offset_ >= 0) {
    float* t = obs_.data() + target_offset_;
    if (target_ >= 0) {
      const Block& b = blocks_[target_];
      t[0] = b.y + 0.5f * b.h;
      t[1] = b.x + 0.5f * b.w;
      t[4] = 1.0f;
    } else {
      t[0] = t[1] = t[4] = 0.0f;
    }
    t[2] = t[3] = 0.0f;
  }
  obs_[done_offset_] = last_done_;
  obs_[reward_offset_] = last_reward_;
}

void BreakoutEnv::SyncAll() {
  for (int i = 0; i < static_cast<int>(blocks_.size()); ++i) SyncBlock(i);
  SyncDynamic();
}

void BreakoutEnv::GetState(std::span<float> state) const {
  assert(state.size() == obs_.size());
  std::memcpy(state.data(), obs_.data(), obs_.size() * sizeof(float));
}

std::vector<uint8_t> BreakoutEnv::SaveState() const {
  ByteWriter w;
  w.Put(kSaveMagic);
  w.Put(static_cast<int32_t>(variant_));
  w.PutArray(rng_.state(), 4);
  w.PutArray(blocks_.data(), blocks_.size());
  const int32_t ints[] = {paddle_x_, ball_y_, ball_x_,      ball_vy_, ball_vx_,      last_action_,  drops_,
                          bounces_,  hits_,   since_touch_, target_,  episode_over_, board_cleared_};
  w.PutArray(ints, std::size(ints));
  w.Put(last_reward_);
  w.Put(last_done_);
  return w.Take();
}

Status BreakoutEnv::RestoreState(std::span<const uint8_t> bytes) {
  // read everything into temporaries; the env changes only when all of it checks out
  ByteReader rd(bytes);
  uint32_t magic = 0;
  int32_t variant = -1;
  uint64_t rng[4];
  std::vector<Block> blocks(blocks_.size());
  int32_t ints[13];
  float reward = 0, done = 0;
  if (!rd.Get(&magic) || magic != kSaveMagic) return Errorf("{}: saved state is not a Breakout state", spec_.name);
  if (!rd.Get(&variant) || variant != static_cast<int32_t>(variant_))
    return Errorf("{}: saved state is from another Breakout variant ({})", spec_.name, variant);
  if (!rd.GetArray(rng, 4) || !rd.GetArray(blocks.data(), blocks.size()) || !rd.GetArray(ints, 13) ||
      !rd.Get(&reward) || !rd.Get(&done) || !rd.done())
    return Errorf("{}: saved state is truncated or has the wrong size", spec_.name);
  if (ints[10] < -1 || ints[10] >= static_cast<int32_t>(blocks.size()))
    return Errorf("{}: saved state has a bad target index {}", spec_.name, ints[10]);

  std::memcpy(rng_.mutable_state(), rng, sizeof(rng));
  blocks_ = std::move(blocks);
  paddle_x_ = ints[0], ball_y_ = ints[1], ball_x_ = ints[2], ball_vy_ = ints[3], ball_vx_ = ints[4];
  last_action_ = ints[5], drops_ = ints[6], bounces_ = ints[7], hits_ = ints[8];
  since_touch_ = ints[9], target_ = ints[10], episode_over_ = ints[11] != 0, board_cleared_ = ints[12] != 0;
  last_reward_ = reward;
  last_done_ = done;
  blocks_y0_ = kScreen;
  blocks_y1_ = 0;
  for (const Block& b : blocks_) {
    blocks_y0_ = std::min(blocks_y0_, b.y);
    blocks_y1_ = std::max(blocks_y1_, b.y + b.h);
  }
  SyncAll();
  return Status::Ok();
}

void BreakoutEnv::SetBallForTest(int y, int x, int vy, int vx) {
  ball_y_ = y, ball_x_ = x, ball_vy_ = vy, ball_vx_ = vx;
  SyncDynamic();
}

void BreakoutEnv::SetPaddleForTest(int x) {
  paddle_x_ = x;
  SyncDynamic();
}

void BreakoutEnv::SetBlockAttrForTest(int i, int attr) {
  blocks_[i].attr = static_cast<int8_t>(attr);
  SyncBlock(i);
}

}  // namespace coins::envs
