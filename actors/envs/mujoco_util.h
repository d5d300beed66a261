// MuJoCo adapters: RAII owners, the shared read-only pushing model, and MuJoCo errors as
// Status.
//
// MuJoCo reports fatal errors through mju_user_error and, by default, exits the process.
// InstallMujocoHandlers() (idempotent, thread-safe) sets handlers that record the message in
// a thread-local slot; inside MujocoGuard::Run they jump back to Run, which returns the error
// as a Status. Outside any guard the handler only records the message (callers always run
// MuJoCo inside a guard). Code run under a guard must not own objects with destructors in
// the frames a jump would skip: keep guarded lambdas to plain MuJoCo calls.
#pragma once

#include <csetjmp>
#include <memory>
#include <string>

#include <mujoco/mujoco.h>

#include "common/status.h"

namespace coins::envs {

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

void InstallMujocoHandlers();

namespace detail {
// the innermost guard of this thread, and the last MuJoCo error / warning text
std::jmp_buf*& GuardSlot();
std::string& LastMujocoError();
std::string& LastMujocoWarning();
}  // namespace detail

// runs fn() with MuJoCo errors turned into a Status naming `what`
template <typename F>
Status MujocoGuarded(const char* what, F&& fn) {
  std::jmp_buf buf;
  std::jmp_buf* prev = detail::GuardSlot();
  detail::GuardSlot() = &buf;
  if (setjmp(buf) == 0) {
    fn();
    detail::GuardSlot() = prev;
    return Status::Ok();
  }
  detail::GuardSlot() = prev;
  return Errorf("{}: MuJoCo error: {}", what, detail::LastMujocoError());
}

// the pushing scene, embedded at build time from actors/envs/assets/pushing.xml
const char* PushingXml();
// compiles an MJCF text from memory; the error carries MuJoCo's message
Result<ModelPtr> LoadModelFromString(const std::string& xml, const std::string& name);
// the one shared read-only pushing model (compiled on first use, thread-safe)
Result<const mjModel*> SharedPushingModel();

}  // namespace coins::envs
