// `coins security init DIR`: the certificate authority, one identity per role, and the signed
// governance and permissions documents of a secured run (common/dds/security.h), made with the
// openssl command-line tool. `dds.security: DIR` then turns every process to DDS Security.
#pragma once

#include <CLI/CLI.hpp>

namespace coins {

// adds the `security` subcommand (with `init`); its exit code goes to *exit_code
void AddSecurityCommand(CLI::App& app, int* exit_code);

}  // namespace coins
