#include "actors/envs/render.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cstring>

#include "actors/envs/breakout.h"
#include "actors/envs/pushing.h"

namespace coins::envs {
namespace {

struct Rgb {
  uint8_t r, g, b;
};

// fills game pixels [y, y+h) x [x, x+w); inset shrinks it by image pixels (block outlines)
void FillRect(Image& img, int scale, int y, int x, int h, int w, Rgb c, int inset = 0) {
  const int y0 = std::max(0, y * scale + inset), y1 = std::min(img.height, (y + h) * scale - inset);
  const int x0 = std::max(0, x * scale + inset), x1 = std::min(img.width, (x + w) * scale - inset);
  for (int py = y0; py < y1; ++py)
    for (int px = x0; px < x1; ++px) {
      uint8_t* p = img.rgb.data() + (static_cast<size_t>(py) * img.width + px) * 3;
      p[0] = c.r, p[1] = c.g, p[2] = c.b;
    }
}

// a one-game-pixel frame around a rectangle
void OutlineRect(Image& img, int scale, int y, int x, int h, int w, Rgb c) {
  FillRect(img, scale, y - 1, x - 1, 1, w + 2, c);
  FillRect(img, scale, y + h, x - 1, 1, w + 2, c);
  FillRect(img, scale, y, x - 1, h, 1, c);
  FillRect(img, scale, y, x + w, h, 1, c);
}

class BreakoutRenderer final : public FrameRenderer {
 public:
  explicit BreakoutRenderer(int scale) : scale_(scale) {}
  Result<Image> Render(const Env& env) override {
    const auto* b = dynamic_cast<const BreakoutEnv*>(&env);
    if (!b) return Errorf("render: {} is not a Breakout env", env.spec().name);
    return RenderBreakout(*b, scale_);
  }

 private:
  int scale_;
};

// EGL display + pbuffer context, and MuJoCo's scene and GPU context, owned together
class MujocoRenderer final : public FrameRenderer {
 public:
  ~MujocoRenderer() override {
    if (ctx_ready_) mjr_freeContext(&con_);
    if (scene_ready_) mjv_freeScene(&scn_);
    if (display_ != EGL_NO_DISPLAY) {
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (surface_ != EGL_NO_SURFACE) eglDestroySurface(display_, surface_);
      if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
      eglTerminate(display_);
    }
  }

  Status Init(const mjModel* m, int width, int height) {
    m_ = m;
    width_ = width;
    height_ = height;
    if (width > m->vis.global.offwidth || height > m->vis.global.offheight || width < 16 || height < 16)
      return Errorf("render: size {}x{} must be within 16x16 .. {}x{}", width, height, m->vis.global.offwidth,
                    m->vis.global.offheight);
    // egl: Mesa's surfaceless platform (no X, no GPU), else the default display; an
    // RGBA/depth pbuffer config and a desktop OpenGL context
    EGLint major = 0, minor = 0;
    display_ = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display_ != EGL_NO_DISPLAY && !eglInitialize(display_, &major, &minor)) display_ = EGL_NO_DISPLAY;
    if (display_ == EGL_NO_DISPLAY) {
      display_ = eglGetDisplay(EGL_DEFAULT_DISPLAY);
      if (display_ == EGL_NO_DISPLAY || !eglInitialize(display_, &major, &minor)) {
        display_ = EGL_NO_DISPLAY;
        return Errorf("render: EGL has no usable display (eglInitialize error 0x{:x})", eglGetError());
      }
    }
    const EGLint cfg_attr[] = {EGL_SURFACE_TYPE,
                               EGL_PBUFFER_BIT,
                               EGL_RED_SIZE,
                               8,
                               EGL_GREEN_SIZE,
                               8,
                               EGL_BLUE_SIZE,
                               8,
                               EGL_ALPHA_SIZE,
                               8,
                               EGL_DEPTH_SIZE,
                               24,
                               EGL_STENCIL_SIZE,
                               8,
                               EGL_RENDERABLE_TYPE,
                               EGL_OPENGL_BIT,
                               EGL_NONE};
    EGLConfig cfg;
    EGLint n = 0;
    if (!eglChooseConfig(display_, cfg_attr, &cfg, 1, &n) || n < 1)
      return Errorf("render: no EGL config with OpenGL and a pbuffer (0x{:x})", eglGetError());
    if (!eglBindAPI(EGL_OPENGL_API)) return Errorf("render: EGL cannot bind OpenGL (0x{:x})", eglGetError());
    const EGLint pb_attr[] = {EGL_WIDTH, width, EGL_HEIGHT, height, EGL_NONE};
    surface_ = eglCreatePbufferSurface(display_, cfg, pb_attr);
    context_ = eglCreateContext(display_, cfg, EGL_NO_CONTEXT, nullptr);
    if (surface_ == EGL_NO_SURFACE || context_ == EGL_NO_CONTEXT ||
        !eglMakeCurrent(display_, surface_, surface_, context_))
      return Errorf("render: cannot create or bind the EGL context (0x{:x})", eglGetError());
    // mujoco: scene, GPU context, offscreen buffer, scratch data, fixed camera
    data_.reset(mj_makeData(m));
    mjv_defaultCamera(&cam_);
    mjv_defaultOption(&opt_);
    mjv_defaultScene(&scn_);
    mjr_defaultContext(&con_);
    mjvScene* scn = &scn_;
    mjrContext* con = &con_;
    COINS_RETURN_IF_ERROR(MujocoGuarded("render setup", [m, scn, con] {
      mjv_makeScene(m, scn, 2000);
      mjr_makeContext(m, con, mjFONTSCALE_100);
      mjr_setBuffer(mjFB_OFFSCREEN, con);
    }));
    scene_ready_ = ctx_ready_ = true;
    const int cam = mj_name2id(m, mjOBJ_CAMERA, "top");
    if (cam >= 0) {
      cam_.type = mjCAMERA_FIXED;
      cam_.fixedcamid = cam;
    }
    return Status::Ok();
  }

  Result<Image> Render(const Env& env) override {
    const auto* p = dynamic_cast<const PushingEnv*>(&env);
    if (!p || p->model() != m_)
      return Errorf("render: {} is not the pushing env this renderer was made for", env.spec().name);
    // copy the positions into scratch data and recompute poses; the env itself is untouched
    const mjModel* m = m_;
    mjData* d = data_.get();
    const mjData* src = p->data();
    std::memcpy(d->qpos, src->qpos, sizeof(mjtNum) * m->nq);
    std::memcpy(d->mocap_pos, src->mocap_pos, sizeof(mjtNum) * 3 * m->nmocap);
    std::memcpy(d->mocap_quat, src->mocap_quat, sizeof(mjtNum) * 4 * m->nmocap);
    Image img;
    img.width = width_;
    img.height = height_;
    img.rgb.resize(static_cast<size_t>(width_) * height_ * 3);
    std::vector<uint8_t> raw(img.rgb.size());
    const mjrRect viewport = {0, 0, width_, height_};
    mjvScene* scn = &scn_;
    mjrContext* con = &con_;
    mjvCamera* cam = &cam_;
    mjvOption* opt = &opt_;
    uint8_t* buf = raw.data();
    COINS_RETURN_IF_ERROR(MujocoGuarded("render", [m, d, scn, con, cam, opt, buf, viewport] {
      mj_kinematics(m, d);
      mj_camlight(m, d);
      mjv_updateScene(m, d, opt, nullptr, cam, mjCAT_ALL, scn);
      mjr_render(viewport, scn, con);
      mjr_readPixels(buf, nullptr, viewport, con);
    }));
    // OpenGL rows run bottom-up
    const size_t row = static_cast<size_t>(width_) * 3;
    for (int y = 0; y < height_; ++y) std::memcpy(img.rgb.data() + y * row, raw.data() + (height_ - 1 - y) * row, row);
    return img;
  }

 private:
  const mjModel* m_ = nullptr;
  int width_ = 0, height_ = 0;
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLSurface surface_ = EGL_NO_SURFACE;
  EGLContext context_ = EGL_NO_CONTEXT;
  DataPtr data_;
  mjvCamera cam_;
  mjvOption opt_;
  mjvScene scn_;
  mjrContext con_;
  bool scene_ready_ = false, ctx_ready_ = false;
};

}  // namespace

Image RenderBreakout(const BreakoutEnv& env, int scale) {
  using B = BreakoutEnv;
  Image img;
  img.width = img.height = B::kScreen * scale;
  img.rgb.assign(static_cast<size_t>(img.width) * img.height * 3, 0);
  const Rgb wall{142, 142, 142};
  FillRect(img, scale, B::kTopWallY, 0, B::kWallThickness, B::kScreen, wall);
  FillRect(img, scale, B::kBottomWallY, 0, B::kWallThickness, B::kScreen, Rgb{90, 40, 40});
  FillRect(img, scale, B::kTopWallY, B::kLeftWallX, B::kScreen, B::kWallThickness, wall);
  FillRect(img, scale, B::kTopWallY, B::kRightWallX, B::kScreen, B::kWallThickness, wall);
  // blocks: rows in rainbow colours, hard grey, negative red, goals green
  const Rgb rows[] = {{200, 72, 72}, {198, 108, 58}, {180, 122, 48}, {162, 162, 42}, {72, 160, 72}, {66, 72, 200}};
  const auto& blocks = env.blocks();
  for (const auto& b : blocks) {
    if (b.attr == 0) continue;
    Rgb c = rows[std::clamp((b.y - 22) / std::max(1, b.h), 0, 5)];
    if (b.kind == B::Kind::kHard) c = {110, 110, 120};
    if (b.kind == B::Kind::kNegative) c = {230, 30, 30};
    if (b.kind == B::Kind::kGoal) c = {40, 220, 90};
    FillRect(img, scale, b.y, b.x, b.h, b.w, c, scale >= 3 ? 1 : 0);
  }
  if (env.target() >= 0) {
    const auto& t = blocks[env.target()];
    OutlineRect(img, scale, t.y, t.x, t.h, t.w, Rgb{255, 230, 0});
  }
  FillRect(img, scale, B::kPaddleY, env.paddle_x(), B::kPaddleH, B::kPaddleW, Rgb{72, 140, 230});
  FillRect(img, scale, env.ball_y(), env.ball_x(), B::kBallSize, B::kBallSize, Rgb{255, 255, 255});
  return img;
}

Result<std::unique_ptr<FrameRenderer>> MakeRenderer(const Env& env, int scale, int width, int height) {
  if (dynamic_cast<const BreakoutEnv*>(&env)) {
    if (scale < 1 || scale > 16) return Errorf("render: scale {} must be in [1, 16]", scale);
    return std::unique_ptr<FrameRenderer>(std::make_unique<BreakoutRenderer>(scale));
  }
  if (const auto* p = dynamic_cast<const PushingEnv*>(&env)) {
    auto r = std::make_unique<MujocoRenderer>();
    COINS_RETURN_IF_ERROR(r->Init(p->model(), width, height));
    return std::unique_ptr<FrameRenderer>(std::move(r));
  }
  return Errorf("render: no renderer for env {}", env.spec().name);
}

}  // namespace coins::envs
