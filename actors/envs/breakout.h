// Factored Breakout (shared/reference/breakout.md) and its six transfer variants.
//
// Pixel geometry on an 84 x 84 screen, integer positions (top-left corners) and velocities.
// Factors, in state order, each instance [y_center, x_center, vy, vx, attr]:
//   Action (1), Paddle (1), Ball (1), Block (n: 100 base, 1 single/big, 60 hard/prox,
//   10 neg, 45 center), Target (1, prox only: the block to aim at), then Done [d] and
//   Reward [r] of the last step.
// Actions: 0, 1 no-op, 2 left, 3 right. Interaction bits: 0 Action->Paddle (the paddle
// moved), 1 Paddle->Ball (paddle bounce), 2 Ball->Block (a block was hit, hard blocks too).
// A step: move the paddle, test the ball's next position against walls, then paddle, then
// the first live block; velocities change, and the ball moves by its new velocity (it never
// enters what it bounced off). Drops (and the variants' episode rules) set done; ResetNext
// re-serves the ball, keeping the base board across drops (its lives) and rebuilding every
// variant's board.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "actors/envs/env.h"
#include "actors/envs/rng.h"

namespace coins::envs {

enum class BreakoutVariant : int32_t { kBase, kSingle, kHard, kBig, kNeg, kCenter, kProx };

// "breakout", "breakout-single", ... for a variant
std::string BreakoutName(BreakoutVariant v);

class BreakoutEnv final : public Env {
 public:
  // geometry of the reference (pixels)
  static constexpr int kScreen = 84;
  static constexpr int kTopWallY = 4, kBottomWallY = 80, kLeftWallX = 8, kRightWallX = 72;
  static constexpr int kWallThickness = 4;
  static constexpr int kPaddleY = 71, kPaddleX0 = 42, kPaddleW = 7, kPaddleH = 2;
  static constexpr int kPaddleMinX = 4, kPaddleMaxX = 72, kPaddleStep = 2;
  static constexpr int kBallSize = 2;
  static constexpr int kNoTouchReserve = 1000;
  enum Bit : uint32_t { kActionPaddle = 1u << 0, kPaddleBall = 1u << 1, kBallBlock = 1u << 2 };

  // a block's kind decides what a hit does; attr is what the state shows
  enum class Kind : int8_t { kNormal, kNegative, kHard, kGoal };
  struct Block {
    int y = 0, x = 0, h = 0, w = 0;
    Kind kind = Kind::kNormal;
    int8_t attr = 0;  // 1 alive, 0 gone, -1 negative or hard
  };

  explicit BreakoutEnv(BreakoutVariant variant);

  const EnvSpec& spec() const override { return spec_; }
  void Reset(uint64_t seed, std::span<float> state) override;
  void ResetNext(std::span<float> state) override;
  Status Step(std::span<const float> action, std::span<float> next_state, StepResult* result) override;
  void GetState(std::span<float> state) const override;
  std::vector<uint8_t> SaveState() const override;
  Status RestoreState(std::span<const uint8_t> bytes) override;

  // read-only views for tests, rendering and the CLI
  BreakoutVariant variant() const { return variant_; }
  int ball_y() const { return ball_y_; }
  int ball_x() const { return ball_x_; }
  int ball_vy() const { return ball_vy_; }
  int ball_vx() const { return ball_vx_; }
  int paddle_x() const { return paddle_x_; }
  int drops() const { return drops_; }
  int target() const { return target_; }  // prox: index of the target block, else -1
  const std::vector<Block>& blocks() const { return blocks_; }
  // test hook: puts the ball somewhere (positions are top-left corners) and the paddle at px
  void SetBallForTest(int y, int x, int vy, int vx);
  void SetPaddleForTest(int x);
  void SetBlockAttrForTest(int i, int attr);

 private:
  void BuildBoard();                          // lays out blocks for the variant (random parts from rng_)
  void Serve();                               // puts the ball at a serve position
  void StartEpisode(std::span<float> state);  // serves and clears the episode counters; writes the state
  void ApplyRestores();                       // per-step restores (neg: all blocks, prox: top row)
  void PickTarget();                          // prox: a new target among live blocks
  void HitBlock(int i, StepResult* r);
  // the ball's next position (ny, nx) meets the paddle: sets the bounce angle and its reward
  // and labels; false when it does not meet it
  bool BounceOffPaddle(int ny, int nx, StepResult* r);
  // the first live block the ball's next position overlaps bounces it and is hit
  void BounceOffBlocks(int ny, int nx, StepResult* r);
  int LiveNormalBlocks() const;
  void SyncBlock(int i);  // copies block i into obs_
  void SyncAll();         // rebuilds all of obs_
  void SyncDynamic();     // action, paddle, ball, target, done, reward into obs_

  BreakoutVariant variant_;
  EnvSpec spec_;
  int block_offset_ = 0;  // offset of the Block factor in the state
  int target_offset_ = -1;
  int done_offset_ = 0, reward_offset_ = 0;

  Rng rng_;
  std::vector<Block> blocks_;
  int paddle_x_ = kPaddleX0;
  int ball_y_ = 0, ball_x_ = 0, ball_vy_ = 1, ball_vx_ = 1;
  int last_action_ = 0;
  int drops_ = 0;        // base: drops since the board was built
  int bounces_ = 0;      // paddle bounces this episode
  int hits_ = 0;         // block hits this episode
  int since_touch_ = 0;  // steps since the paddle last touched the ball (or a serve)
  int target_ = -1;
  bool episode_over_ = false;
  bool board_cleared_ = false;
  float last_reward_ = 0.0f;
  float last_done_ = 0.0f;
  // block bounding box, to skip block tests when the ball is far from every block
  int blocks_y0_ = 0, blocks_y1_ = 0;
  std::vector<float> obs_;  // the factored state, kept current so a step is one copy
};

}  // namespace coins::envs
