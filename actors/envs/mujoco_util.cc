#include "actors/envs/mujoco_util.h"

#include <cstring>
#include <mutex>

namespace coins::envs {
namespace detail {

std::jmp_buf*& GuardSlot() {
  thread_local std::jmp_buf* slot = nullptr;
  return slot;
}
std::string& LastMujocoError() {
  thread_local std::string s;
  return s;
}
std::string& LastMujocoWarning() {
  thread_local std::string s;
  return s;
}

}  // namespace detail

namespace {

void OnMujocoError(const char* msg) {
  detail::LastMujocoError() = msg ? msg : "unknown error";
  if (std::jmp_buf* buf = detail::GuardSlot()) std::longjmp(*buf, 1);
}

void OnMujocoWarning(const char* msg) { detail::LastMujocoWarning() = msg ? msg : ""; }

}  // namespace

void InstallMujocoHandlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_error = OnMujocoError;
    mju_user_warning = OnMujocoWarning;
  });
}

Result<ModelPtr> LoadModelFromString(const std::string& xml, const std::string& name) {
  InstallMujocoHandlers();
  // a heap VFS (the struct is large) holding the one file
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  const std::string file = name + ".xml";
  if (mj_makeEmptyFileVFS(vfs.get(), file.c_str(), static_cast<int>(xml.size())) != 0)
    return Errorf("{}: cannot create the in-memory MJCF file", name);
  const int i = mj_findFileVFS(vfs.get(), file.c_str());
  std::memcpy(vfs->filedata[i], xml.data(), xml.size());
  // compile under a guard
  char err[1000] = "";
  mjModel* m = nullptr;
  mjVFS* v = vfs.get();
  const char* fname = file.c_str();
  Status st = MujocoGuarded("load model", [&] { m = mj_loadXML(fname, v, err, sizeof(err)); });
  mj_deleteVFS(vfs.get());
  if (!st.ok()) return st.WithContext(name);
  if (!m) return Errorf("{}: MJCF does not compile: {}", name, err);
  return ModelPtr(m);
}

Result<const mjModel*> SharedPushingModel() {
  static std::once_flag once;
  static ModelPtr model;
  static Status status;
  std::call_once(once, [] {
    Result<ModelPtr> r = LoadModelFromString(PushingXml(), "pushing");
    if (r.ok())
      model = std::move(r).value();
    else
      status = r.status();
  });
  if (!status.ok()) return status;
  return static_cast<const mjModel*>(model.get());
}

}  // namespace coins::envs
