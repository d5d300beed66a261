#include "actors/envs/pushing.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "actors/envs/bytes.h"

namespace coins::envs {
namespace {

constexpr uint32_t kSaveMagic = 0x31485350;  // "PSH1"
constexpr int kSettleSubsteps = 20;
constexpr double kStartZ = 0.085;   // fingertip joint z at reset (centre 0.1 m up)
constexpr double kMovedEps = 1e-4;  // commanded displacement that counts as a move

FactorSpec Vec3(const std::string& name, int instances, std::array<float, 3> lo, std::array<float, 3> hi) {
  FactorSpec f;
  f.name = name;
  f.features = 3;
  f.instances = instances;
  f.low.assign(lo.begin(), lo.end());
  f.high.assign(hi.begin(), hi.end());
  f.feature_names = {"x", "y", "z"};
  return f;
}

int Id(const mjModel* m, mjtObj type, const char* name) { return mj_name2id(m, type, name); }

}  // namespace

Result<std::unique_ptr<PushingEnv>> PushingEnv::Create(bool easy) {
  Result<const mjModel*> m = SharedPushingModel();
  if (!m.ok()) return m.status();
  return std::unique_ptr<PushingEnv>(new PushingEnv(*m, easy));
}

PushingEnv::PushingEnv(const mjModel* m, bool easy)
    : m_(m), d_(mj_makeData(m)), easy_(easy), horizon_(easy ? 30 : 300) {
  // spec
  spec_.name = easy ? "pushing-easy" : "pushing";
  spec_.factors.push_back(Vec3("Action", 1, {-1, -1, -1}, {1, 1, 1}));
  spec_.factors.push_back(Vec3("Gripper", 1, {-0.2f, -0.2f, 0.015f}, {0.2f, 0.2f, 0.215f}));
  spec_.factors.push_back(Vec3("Block", 1, {-0.25f, -0.25f, 0.0f}, {0.25f, 0.25f, 0.1f}));
  if (!easy) {
    spec_.factors.push_back(Vec3("Obstacle", kRegions, {-0.15f, -0.15f, 0.0f}, {0.15f, 0.15f, 0.05f}));
    spec_.factors.back().multi_instance = true;
  }
  spec_.factors.push_back(Vec3("Target", 1, {-0.15f, -0.15f, 0.0f}, {0.15f, 0.15f, 0.05f}));
  for (const char* n : {"Done", "Reward"}) {
    FactorSpec f;
    f.name = n;
    f.features = 1;
    f.low = {n[0] == 'D' ? 0.0f : -2.0f};
    f.high = {n[0] == 'D' ? 1.0f : 0.0f};
    f.feature_names = {n[0] == 'D' ? "done" : "reward"};
    spec_.factors.push_back(f);
  }
  spec_.action.discrete = false;
  spec_.action.n = 0;
  spec_.action.dim = 3;
  spec_.action.low = {-1, -1, -1};
  spec_.action.high = {1, 1, 1};
  spec_.interactions = {{"Action", "Gripper"}, {"Gripper", "Block"}};
  spec_.max_episode_steps = horizon_;
  spec_.done_means = "the block reached the goal";
  spec_.penalty_means = "the block in a negative region or out of bounds";
  spec_.penalty_reward = -2.0f;

  // model addresses
  gx_adr_ = m->jnt_qposadr[Id(m, mjOBJ_JOINT, "gx")];
  const int cube_j = Id(m, mjOBJ_JOINT, "cube");
  cube_adr_ = m->jnt_qposadr[cube_j];
  cube_dof_ = m->jnt_dofadr[cube_j];
  finger_geom_ = Id(m, mjOBJ_GEOM, "finger");
  cube_geom_ = Id(m, mjOBJ_GEOM, "cube");
  goal_mocap_ = m->body_mocapid[Id(m, mjOBJ_BODY, "goal")];
  for (int k = 0; k < kRegions; ++k)
    region_mocap_[k] = m->body_mocapid[Id(m, mjOBJ_BODY, fmt::format("nrr{}", k).c_str())];
  regions_.reserve(kRegions);
  std::vector<float> scratch(spec_.state_dim());
  Reset(0, scratch);
}

int PushingEnv::CellOf(double x, double y) {
  const int c = std::clamp(static_cast<int>(std::floor((x + kHalfSpawn) / kCell)), 0, kGrid - 1);
  const int r = std::clamp(static_cast<int>(std::floor((y + kHalfSpawn) / kCell)), 0, kGrid - 1);
  return r * kGrid + c;
}

std::array<double, 2> PushingEnv::CellCentre(int cell) {
  return {-kHalfSpawn + kCell * (cell % kGrid + 0.5), -kHalfSpawn + kCell * (cell / kGrid + 0.5)};
}

bool PushingEnv::FreePath(uint32_t region_mask, int a, int b) {
  if ((region_mask >> a & 1) || (region_mask >> b & 1)) return false;
  // breadth-first search over free cells
  uint32_t seen = 1u << a;
  int queue[kGrid * kGrid], head = 0, tail = 0;
  queue[tail++] = a;
  while (head < tail) {
    const int c = queue[head++];
    if (c == b) return true;
    const int r = c / kGrid, col = c % kGrid;
    const int nbr[4][2] = {{r - 1, col}, {r + 1, col}, {r, col - 1}, {r, col + 1}};
    for (const auto& n : nbr) {
      if (n[0] < 0 || n[0] >= kGrid || n[1] < 0 || n[1] >= kGrid) continue;
      const int k = n[0] * kGrid + n[1];
      if ((seen >> k & 1) || (region_mask >> k & 1)) continue;
      seen |= 1u << k;
      queue[tail++] = k;
    }
  }
  return false;
}

bool PushingEnv::InRegion(double x, double y) const {
  if (std::abs(x) >= kHalfSpawn || std::abs(y) >= kHalfSpawn) return false;
  return region_mask_ >> CellOf(x, y) & 1;
}

void PushingEnv::Sample() {
  // cube and goal uniform in the spawn square, the goal not already reached
  cube_start_ = {rng_.Uniform(-kHalfSpawn, kHalfSpawn), rng_.Uniform(-kHalfSpawn, kHalfSpawn)};
  do {
    goal_ = {rng_.Uniform(-kHalfSpawn, kHalfSpawn), rng_.Uniform(-kHalfSpawn, kHalfSpawn)};
  } while (std::hypot(goal_[0] - cube_start_[0], goal_[1] - cube_start_[1]) < kSuccess);
  regions_.clear();
  region_mask_ = 0;
  if (easy_) return;
  // 15 region cells, never on the cube's or goal's cell, re-sampled until a free path exists
  const int cc = CellOf(cube_start_[0], cube_start_[1]), gc = CellOf(goal_[0], goal_[1]);
  int pool[kGrid * kGrid], n = 0;
  for (int k = 0; k < kGrid * kGrid; ++k)
    if (k != cc && k != gc) pool[n++] = k;
  do {
    region_mask_ = 0;
    for (int k = 0; k < kRegions; ++k) {
      std::swap(pool[k], pool[rng_.UniformInt(k, n - 1)]);
      region_mask_ |= 1u << pool[k];
    }
  } while (!FreePath(region_mask_, cc, gc));
  for (int k = 0; k < kGrid * kGrid; ++k)
    if (region_mask_ >> k & 1) regions_.push_back(k);
}

void PushingEnv::Place() {
  mjData* d = d_.get();
  const mjModel* m = m_;
  mj_resetData(m, d);
  // fingertip above the centre, servo holding it there
  d->qpos[gx_adr_ + 0] = 0.0;
  d->qpos[gx_adr_ + 1] = 0.0;
  d->qpos[gx_adr_ + 2] = kStartZ;
  d->ctrl[0] = 0.0;
  d->ctrl[1] = 0.0;
  d->ctrl[2] = kStartZ;
  // cube resting on the table
  mjtNum* q = d->qpos + cube_adr_;
  q[0] = cube_start_[0], q[1] = cube_start_[1], q[2] = kCubeHalf;
  q[3] = 1.0, q[4] = q[5] = q[6] = 0.0;
  // goal disc and regions (unused regions hidden under the table)
  mjtNum* g = d->mocap_pos + 3 * goal_mocap_;
  g[0] = goal_[0], g[1] = goal_[1], g[2] = 0.0008;
  for (int k = 0; k < kRegions; ++k) {
    mjtNum* p = d->mocap_pos + 3 * region_mocap_[k];
    if (k < static_cast<int>(regions_.size())) {
      const auto c = CellCentre(regions_[k]);
      p[0] = c[0], p[1] = c[1], p[2] = 0.0005;
    } else {
      p[0] = p[1] = 0.0, p[2] = -1.0;
    }
  }
  // settle the contacts before the episode starts
  sim_error_ = MujocoGuarded("pushing reset", [m, d] {
    mj_forward(m, d);
    for (int i = 0; i < kSettleSubsteps; ++i) mj_step(m, d);
  });
  steps_ = 0;
  last_action_ = {0, 0, 0};
  last_reward_ = last_done_ = 0.0f;
  episode_over_ = false;
}

void PushingEnv::Reset(uint64_t seed, std::span<float> state) {
  rng_.Seed(seed);
  Sample();
  Place();
  WriteState(state);
}

void PushingEnv::ResetNext(std::span<float> state) {
  Sample();
  Place();
  WriteState(state);
}

Status PushingEnv::Step(std::span<const float> action, std::span<float> next_state, StepResult* result) {
  // validate before touching anything
  if (action.size() != 3) return Errorf("{}: action must have 3 floats, got {}", spec_.name, action.size());
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(action[i]))
      return Errorf("{}: action[{}] = {} is not a finite number", spec_.name, i, action[i]);
    if (action[i] < -1.0f || action[i] > 1.0f)
      return Errorf("{}: action[{}] = {} out of range [-1, 1]", spec_.name, i, action[i]);
  }
  if (next_state.size() != static_cast<size_t>(spec_.state_dim()))
    return Errorf("{}: state buffer has {} floats, expected {}", spec_.name, next_state.size(), spec_.state_dim());
  if (!sim_error_.ok()) return sim_error_;
  if (episode_over_) return Errorf("{}: the episode is over; call ResetNext or Reset", spec_.name);

  const mjModel* m = m_;
  mjData* d = d_.get();
  StepResult r;
  double ramp_from[3], ramp_to[3];
  // servo targets: current joint position plus the scaled action, within the joint ranges
  for (int i = 0; i < 3; ++i) {
    const int j = gx_adr_ + i;
    const double lo = m->jnt_range[2 * i], hi = m->jnt_range[2 * i + 1];
    const double target = std::clamp(d->qpos[j] + kMaxMove * action[i], lo, hi);
    if (std::abs(target - d->qpos[j]) > kMovedEps) r.interactions |= kActionGripper;
    ramp_from[i] = d->ctrl[i];
    ramp_to[i] = target;
    last_action_[i] = action[i];
  }
  // physics substeps, watching the contact list for fingertip-cube contacts
  int bad_before = 0;
  for (int w : {mjWARN_BADQPOS, mjWARN_BADQVEL, mjWARN_BADQACC}) bad_before += d->warning[w].number;
  bool touched = false;
  const int fg = finger_geom_, cg = cube_geom_;
  Status st = MujocoGuarded("pushing step", [m, d, fg, cg, &touched, &ramp_from, &ramp_to] {
    for (int s = 0; s < kSubsteps; ++s) {
      // the servo set-point moves linearly to the target over the control step
      const double w = static_cast<double>(s + 1) / kSubsteps;
      for (int i = 0; i < 3; ++i) d->ctrl[i] = ramp_from[i] + w * (ramp_to[i] - ramp_from[i]);
      mj_step(m, d);
      for (int c = 0; c < d->ncon; ++c) {
        const mjContact& con = d->contact[c];
        if ((con.geom1 == fg && con.geom2 == cg) || (con.geom1 == cg && con.geom2 == fg)) touched = true;
      }
    }
  });
  int bad_after = 0;
  for (int w : {mjWARN_BADQPOS, mjWARN_BADQVEL, mjWARN_BADQACC}) bad_after += d->warning[w].number;
  if (st.ok() && bad_after != bad_before)
    st = Errorf("{}: simulation became unstable (MuJoCo reset the state): {}", spec_.name, detail::LastMujocoWarning());
  if (!st.ok()) {
    sim_error_ = st;
    return st;
  }
  if (touched) r.interactions |= kGripperBlock;

  // reward and episode end
  ++steps_;
  const mjtNum* q = d->qpos + cube_adr_;
  const double cx = q[0], cy = q[1];
  const bool out = std::max(std::abs(cx), std::abs(cy)) >= kBounds;
  r.reward = (out || InRegion(cx, cy)) ? -2.0f : -0.1f;
  r.done = std::hypot(cx - goal_[0], cy - goal_[1]) < kSuccess;
  r.truncated = !r.done && steps_ >= horizon_;
  episode_over_ = r.done || r.truncated;
  last_reward_ = r.reward;
  last_done_ = r.done ? 1.0f : 0.0f;
  WriteState(next_state);
  *result = r;
  return Status::Ok();
}

std::array<double, 3> PushingEnv::gripper() const {
  const mjtNum* q = d_->qpos + gx_adr_;
  return {q[0], q[1], kFingerRestZ + q[2]};
}

std::array<double, 3> PushingEnv::cube() const {
  const mjtNum* q = d_->qpos + cube_adr_;
  return {q[0], q[1], q[2]};
}

void PushingEnv::WriteState(std::span<float> out) const {
  float* o = out.data();
  const mjtNum* g = d_->qpos + gx_adr_;
  const mjtNum* c = d_->qpos + cube_adr_;
  *o++ = last_action_[0], *o++ = last_action_[1], *o++ = last_action_[2];
  *o++ = static_cast<float>(g[0]), *o++ = static_cast<float>(g[1]);
  *o++ = static_cast<float>(kFingerRestZ + g[2]);
  *o++ = static_cast<float>(c[0]), *o++ = static_cast<float>(c[1]), *o++ = static_cast<float>(c[2]);
  if (!easy_) {
    for (int k = 0; k < kRegions; ++k) {
      const auto cc = CellCentre(regions_[k]);
      *o++ = static_cast<float>(cc[0]), *o++ = static_cast<float>(cc[1]), *o++ = 0.0f;
    }
  }
  *o++ = static_cast<float>(goal_[0]), *o++ = static_cast<float>(goal_[1]), *o++ = 0.0f;
  *o++ = last_done_;
  *o++ = last_reward_;
}

void PushingEnv::GetState(std::span<float> state) const { WriteState(state); }

std::vector<uint8_t> PushingEnv::SaveState() const {
  const mjData* d = d_.get();
  const mjModel* m = m_;
  ByteWriter w;
  w.Put(kSaveMagic);
  w.Put(static_cast<int32_t>(easy_));
  w.PutArray(rng_.state(), 4);
  w.PutArray(cube_start_.data(), 2);
  w.PutArray(goal_.data(), 2);
  w.PutArray(regions_.data(), regions_.size());
  w.PutArray(last_action_.data(), 3);
  w.Put(last_reward_);
  w.Put(last_done_);
  w.Put(static_cast<int32_t>(steps_));
  w.Put(static_cast<int32_t>(episode_over_));
  // the simulator: everything mj_step reads, including the solver's warm start
  w.Put(d->time);
  w.PutArray(d->qpos, m->nq);
  w.PutArray(d->qvel, m->nv);
  w.PutArray(d->act, m->na);
  w.PutArray(d->ctrl, m->nu);
  w.PutArray(d->qacc_warmstart, m->nv);
  w.PutArray(d->mocap_pos, 3 * m->nmocap);
  w.PutArray(d->mocap_quat, 4 * m->nmocap);
  return w.Take();
}

Status PushingEnv::RestoreState(std::span<const uint8_t> bytes) {
  // check the whole record first, against a scratch copy
  const mjModel* m = m_;
  ByteReader rd(bytes);
  uint32_t magic = 0;
  int32_t easy = -1, steps = 0, over = 0;
  uint64_t rng[4];
  std::array<double, 2> cube_start{}, goal{};
  std::vector<int> regions(easy_ ? 0 : kRegions);
  std::array<float, 3> last_action{};
  float reward = 0, done = 0;
  mjtNum time = 0;
  std::vector<mjtNum> qpos(m->nq), qvel(m->nv), act(m->na), ctrl(m->nu), warm(m->nv), mpos(3 * m->nmocap),
      mquat(4 * m->nmocap);
  if (!rd.Get(&magic) || magic != kSaveMagic) return Errorf("{}: saved state is not a pushing state", spec_.name);
  if (!rd.Get(&easy) || easy != static_cast<int32_t>(easy_))
    return Errorf("{}: saved state is from the other pushing variant", spec_.name);
  if (!rd.GetArray(rng, 4) || !rd.GetArray(cube_start.data(), 2) || !rd.GetArray(goal.data(), 2) ||
      !rd.GetArray(regions.data(), regions.size()) || !rd.GetArray(last_action.data(), 3) || !rd.Get(&reward) ||
      !rd.Get(&done) || !rd.Get(&steps) || !rd.Get(&over) || !rd.Get(&time) || !rd.GetArray(qpos.data(), qpos.size()) ||
      !rd.GetArray(qvel.data(), qvel.size()) || !rd.GetArray(act.data(), act.size()) ||
      !rd.GetArray(ctrl.data(), ctrl.size()) || !rd.GetArray(warm.data(), warm.size()) ||
      !rd.GetArray(mpos.data(), mpos.size()) || !rd.GetArray(mquat.data(), mquat.size()) || !rd.done())
    return Errorf("{}: saved state is truncated or has the wrong size", spec_.name);
  uint32_t mask = 0;
  for (int c : regions) {
    if (c < 0 || c >= kGrid * kGrid) return Errorf("{}: saved state has a bad region cell {}", spec_.name, c);
    mask |= 1u << c;
  }

  // commit
  std::memcpy(rng_.mutable_state(), rng, sizeof(rng));
  cube_start_ = cube_start, goal_ = goal, regions_ = regions, region_mask_ = mask;
  last_action_ = last_action, last_reward_ = reward, last_done_ = done;
  steps_ = steps, episode_over_ = over != 0;
  mjData* d = d_.get();
  d->time = time;
  std::copy(qpos.begin(), qpos.end(), d->qpos);
  std::copy(qvel.begin(), qvel.end(), d->qvel);
  std::copy(act.begin(), act.end(), d->act);
  std::copy(ctrl.begin(), ctrl.end(), d->ctrl);
  std::copy(warm.begin(), warm.end(), d->qacc_warmstart);
  std::copy(mpos.begin(), mpos.end(), d->mocap_pos);
  std::copy(mquat.begin(), mquat.end(), d->mocap_quat);
  // positions only: a full mj_forward would rewrite the solver warm start and break replay
  sim_error_ = MujocoGuarded("pushing restore", [m, d] { mj_kinematics(m, d); });
  return sim_error_;
}

void PushingEnv::SetCubeForTest(double x, double y) {
  mjtNum* q = d_->qpos + cube_adr_;
  q[0] = x, q[1] = y, q[2] = kCubeHalf;
  q[3] = 1.0, q[4] = q[5] = q[6] = 0.0;
  for (int i = 0; i < 6; ++i) d_->qvel[cube_dof_ + i] = 0.0;
}

double PushingEnv::cube_speed() const {
  const mjtNum* v = d_->qvel + cube_dof_;
  return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

}  // namespace coins::envs
