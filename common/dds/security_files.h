// Checks of a `coins security init` directory before a participant uses it, so that a bad file is
// named in one line instead of Fast DDS refusing the participant without saying why:
//   ca.pem                a PEM certificate
//   ROLE.pem              a PEM certificate signed by ca.pem, valid now (not expired, not early)
//   ROLE.key              its private key
//   governance.p7s,       S/MIME documents signed by ca.pem; a permissions document also must be
//   ROLE-permissions.p7s  valid now (its <validity> dates)
#pragma once

#include <string>

#include "common/status.h"

namespace coins::dds {

// the files of `role` in `dir`; the error names the file and what is wrong with it
Status CheckSecurityFiles(const std::string& dir, const std::string& role);

}  // namespace coins::dds
