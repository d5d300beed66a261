// What this machine offers, for checks made before a process commits to a size.
#pragma once

#include <cstdint>
#include <string>

namespace coins {

// physical memory in bytes (0 when it cannot be told)
int64_t PhysicalMemoryBytes();
// bytes in a short human form: "512 MB", "23.4 GB"
std::string HumanBytes(double bytes);

}  // namespace coins
