// Pictures of env states. Breakout draws itself with a small rasteriser (84 x 84 pixels,
// scaled up); pushing renders the MuJoCo scene offscreen through EGL (works with Mesa's
// software rasteriser, no GPU or display needed), from the model's fixed "top" camera,
// showing the table, negative reward regions, goal disc, cube and fingertip.
#pragma once

#include <memory>

#include "actors/envs/env.h"
#include "actors/envs/image_io.h"

namespace coins::envs {

class BreakoutEnv;

// draws a Breakout state, each game pixel as scale x scale pixels
Image RenderBreakout(const BreakoutEnv& env, int scale);

class FrameRenderer {
 public:
  virtual ~FrameRenderer() = default;
  // renders the env's current state; the env must be the kind this renderer was made for
  virtual Result<Image> Render(const Env& env) = 0;
};

// a renderer for this env: Breakout at `scale`, pushing at width x height (at most 640 x 480)
Result<std::unique_ptr<FrameRenderer>> MakeRenderer(const Env& env, int scale, int width, int height);

}  // namespace coins::envs
