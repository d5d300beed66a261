// Versioned binary format for network weights, as a file or as a byte blob (PolicyWeights).
//
// Layout, little-endian:
//   magic "CNNW" (4 bytes) | u32 version (= kWeightsVersion) | u32 block count
//   per block: u16 name length, name bytes, u32 rows, u32 cols
//   u64 float count | float32 values (column-major per block, blocks in order)
//   u32 CRC-32 (IEEE) of every preceding byte
// Loading checks, in order: size, magic, version, truncation, checksum, then that every block
// name and shape matches the destination ParamSet. Errors name the source (file path or
// "blob") and what is wrong. Only values travel; gradients and optimiser state do not.
// A set of networks (PolicyWeights "a network or a set of them") is one blob whose block table
// is the networks' tables one after another, values likewise.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/nn/params.h"
#include "common/status.h"

namespace coins::nn {

inline constexpr uint32_t kWeightsVersion = 1;

// CRC-32 (IEEE 802.3, reflected, as in zlib)
uint32_t Crc32(std::span<const uint8_t> bytes);

std::vector<uint8_t> ToBlob(const ParamSet& params);
// reads a blob into params (whose shapes must match); source names the blob in errors
Status FromBlob(std::span<const uint8_t> blob, ParamSet* params, const std::string& source = "blob");

// a set of networks in one blob, in order; loading needs the same networks in the same order
std::vector<uint8_t> ToBlob(std::span<const ParamSet* const> sets);
Status FromBlob(std::span<const uint8_t> blob, std::span<ParamSet* const> sets, const std::string& source = "blob");

Status SaveWeights(const std::string& path, const ParamSet& params);
Status LoadWeights(const std::string& path, ParamSet* params);

}  // namespace coins::nn
