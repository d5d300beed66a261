#include "orchestrator/security_command.h"

#include <sys/stat.h>

#include <csignal>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "common/dds/security.h"
#include "orchestrator/child_process.h"

namespace coins {

namespace {

namespace fs = std::filesystem;

struct InitFlags {
  std::string dir;
  int days = 365;
  bool force = false;
};

// runs openssl with `args` in `dir`; an error names the command and the last line openssl said
Status Openssl(const fs::path& dir, const std::vector<std::string>& args) {
  std::vector<std::string> argv = {"/usr/bin/openssl"};
  argv.insert(argv.end(), args.begin(), args.end());
  const std::string log = (dir / "openssl.log").string();
  auto child = ChildProcess::Spawn("openssl", argv, log, /*append=*/true);
  if (!child.ok()) return child.status().WithContext("openssl (install the openssl package)");
  if (!child->WaitFor(std::chrono::seconds(60))) {
    child->Signal(SIGKILL);
    child->WaitFor(std::chrono::seconds(5));
    return Errorf("openssl {} did not finish within 60 s", args[0]);
  }
  if (child->succeeded()) return Status::Ok();
  std::string command = "openssl";
  for (const auto& a : args) command += " " + a;
  return Errorf("`{}` {} (see {})", command, child->Describe(), log);
}

Status Write(const fs::path& file, const std::string& text) {
  std::ofstream out(file);
  out << text;
  out.close();
  if (!out) return Errorf("cannot write {}", file.string());
  return Status::Ok();
}

// the CA, then per role a key, a request and a certificate signed by the CA, then the documents
Status Init(const InitFlags& f) {
  const fs::path dir(f.dir);
  std::error_code ec;
  if (fs::exists(dir / "ca.pem", ec) && !f.force)
    return Errorf("{} already holds a security set-up (ca.pem); --force makes a new one", f.dir);
  fs::create_directories(dir, ec);
  if (ec) return Errorf("cannot create {}: {}", f.dir, ec.message());
  ::chmod(f.dir.c_str(), 0700);  // private keys inside
  const std::string days = std::to_string(f.days);
  const std::vector<std::string> ec_key = {"-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"};
  auto with = [](std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
  };
  COINS_RETURN_IF_ERROR(Openssl(dir, with(with({"req", "-x509"}, ec_key),
                                          {"-keyout", (dir / "ca.key").string(), "-out", (dir / "ca.pem").string(),
                                           "-days", days, "-subj", "/O=coins/CN=coins CA"})));
  for (const auto& role : dds::SecurityRoles()) {
    const std::string r = role.name;
    const std::string csr = (dir / (r + ".csr")).string();
    COINS_RETURN_IF_ERROR(Openssl(dir, with(with({"req"}, ec_key), {"-keyout", (dir / (r + ".key")).string(), "-out",
                                                                    csr, "-subj", "/O=coins/CN=" + r})));
    COINS_RETURN_IF_ERROR(
        Openssl(dir, {"x509", "-req", "-in", csr, "-CA", (dir / "ca.pem").string(), "-CAkey", (dir / "ca.key").string(),
                      "-CAcreateserial", "-out", (dir / (r + ".pem")).string(), "-days", days}));
    fs::remove(csr, ec);
    const fs::path xml = dir / (r + "-permissions.xml");
    COINS_RETURN_IF_ERROR(Write(xml, dds::PermissionsXml(role, f.days)));
    COINS_RETURN_IF_ERROR(
        Openssl(dir, {"smime", "-sign", "-in", xml.string(), "-text", "-out", (dir / (r + "-permissions.p7s")).string(),
                      "-signer", (dir / "ca.pem").string(), "-inkey", (dir / "ca.key").string()}));
  }
  const fs::path gov = dir / "governance.xml";
  COINS_RETURN_IF_ERROR(Write(gov, dds::GovernanceXml()));
  return Openssl(dir, {"smime", "-sign", "-in", gov.string(), "-text", "-out", (dir / "governance.p7s").string(),
                       "-signer", (dir / "ca.pem").string(), "-inkey", (dir / "ca.key").string()});
}

}  // namespace

void AddSecurityCommand(CLI::App& app, int* exit_code) {
  CLI::App* sec = app.add_subcommand("security", "DDS Security set-up of a run (see common/dds/security.h).");
  sec->require_subcommand(1);
  auto flags = std::make_shared<InitFlags>();
  CLI::App* init = sec->add_subcommand(
      "init", "Write a CA, one identity per role and the signed governance and permissions into DIR.");
  init->add_option("dir", flags->dir, "directory to write (then: --set dds.security=DIR)")->required();
  init->add_option("--days", flags->days, "validity of the certificates and permissions")->check(CLI::Range(1, 3650));
  init->add_flag("--force", flags->force, "replace an existing set-up in DIR");
  init->callback([flags, exit_code] {
    Status s = Init(*flags);
    if (!s.ok()) {
      std::cerr << "coins security init: " << s.message() << "\n";
      *exit_code = 1;
      return;
    }
    std::cout << "coins security init: CA, " << dds::SecurityRoles().size() << " identities (";
    for (size_t i = 0; i < dds::SecurityRoles().size(); ++i)
      std::cout << (i ? ", " : "") << dds::SecurityRoles()[i].name;
    std::cout << "), governance and permissions signed in " << flags->dir << "; use --set dds.security=" << flags->dir
              << "\n";
  });
}

}  // namespace coins
