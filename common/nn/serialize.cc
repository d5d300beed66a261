#include "common/nn/serialize.h"

#include <array>
#include <bit>
#include <cstring>
#include <fstream>
#include <iterator>

namespace coins::nn {
namespace {

static_assert(std::endian::native == std::endian::little, "weights format assumes little-endian");
constexpr char kMagic[4] = {'C', 'N', 'N', 'W'};

std::array<uint32_t, 256> MakeCrcTable() {
  std::array<uint32_t, 256> table{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}

template <typename T>
void Put(std::vector<uint8_t>* out, T value) {
  const size_t at = out->size();
  out->resize(at + sizeof(T));
  std::memcpy(out->data() + at, &value, sizeof(T));
}

// bounds-checked reader over a blob
class Reader {
 public:
  Reader(std::span<const uint8_t> bytes, const std::string& source) : bytes_(bytes), source_(source) {}
  template <typename T>
  Status Get(T* value, const char* what) {
    COINS_RETURN_IF_ERROR(Need(sizeof(T), what));
    std::memcpy(value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return Status::Ok();
  }
  Status GetBytes(void* dst, size_t n, const char* what) {
    COINS_RETURN_IF_ERROR(Need(n, what));
    if (n > 0) std::memcpy(dst, bytes_.data() + pos_, n);
    pos_ += n;
    return Status::Ok();
  }
  size_t pos() const { return pos_; }

 private:
  Status Need(size_t n, const char* what) {
    if (bytes_.size() - pos_ < n)
      return Errorf("{}: truncated: {} bytes needed for {} at offset {}, only {} left", source_, n, what, pos_,
                    bytes_.size() - pos_);
    return Status::Ok();
  }
  std::span<const uint8_t> bytes_;
  const std::string& source_;
  size_t pos_ = 0;
};

}  // namespace

uint32_t Crc32(std::span<const uint8_t> bytes) {
  static const std::array<uint32_t, 256> table = MakeCrcTable();
  uint32_t c = 0xFFFFFFFFu;
  for (uint8_t b : bytes) c = table[(c ^ b) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::vector<uint8_t> ToBlob(const ParamSet& params) {
  const ParamSet* one[1] = {&params};
  return ToBlob(std::span<const ParamSet* const>(one, 1));
}

Status FromBlob(std::span<const uint8_t> blob, ParamSet* params, const std::string& source) {
  ParamSet* one[1] = {params};
  return FromBlob(blob, std::span<ParamSet* const>(one, 1), source);
}

std::vector<uint8_t> ToBlob(std::span<const ParamSet* const> sets) {
  size_t blocks = 0, floats = 0;
  for (const ParamSet* p : sets) {
    blocks += p->blocks().size();
    floats += size_t(p->size());
  }
  std::vector<uint8_t> out;
  out.reserve(64 + blocks * 32 + floats * 4);
  for (int i = 0; i < 4; ++i) out.push_back(uint8_t(kMagic[i]));
  Put<uint32_t>(&out, kWeightsVersion);
  Put<uint32_t>(&out, uint32_t(blocks));
  for (const ParamSet* p : sets)
    for (const ParamBlock& b : p->blocks()) {
      Put<uint16_t>(&out, uint16_t(b.name.size()));
      out.insert(out.end(), b.name.begin(), b.name.end());
      Put<uint32_t>(&out, uint32_t(b.rows));
      Put<uint32_t>(&out, uint32_t(b.cols));
    }
  Put<uint64_t>(&out, uint64_t(floats));
  for (const ParamSet* p : sets) {
    const size_t at = out.size();
    out.resize(at + size_t(p->size()) * sizeof(float));
    if (p->size() > 0) std::memcpy(out.data() + at, p->values.data(), size_t(p->size()) * 4);
  }
  Put<uint32_t>(&out, Crc32(out));
  return out;
}

Status FromBlob(std::span<const uint8_t> blob, std::span<ParamSet* const> sets, const std::string& source) {
  // header: magic and version before anything else
  if (blob.size() < 12)
    return Errorf("{}: truncated: {} bytes is shorter than the 12-byte header", source, blob.size());
  if (std::memcmp(blob.data(), kMagic, 4) != 0) return Errorf("{}: bad magic (not a coins weights file)", source);
  Reader r(blob, source);
  char magic[4];
  COINS_RETURN_IF_ERROR(r.GetBytes(magic, 4, "magic"));
  uint32_t version = 0, count = 0;
  COINS_RETURN_IF_ERROR(r.Get(&version, "version"));
  if (version != kWeightsVersion)
    return Errorf("{}: unsupported version {} (this build reads version {})", source, version, kWeightsVersion);
  COINS_RETURN_IF_ERROR(r.Get(&count, "block count"));
  if (blob.size() < 4) return Errorf("{}: truncated", source);
  // checksum over everything but the trailing 4 bytes
  uint32_t stored = 0;
  std::memcpy(&stored, blob.data() + blob.size() - 4, 4);
  const bool crc_ok = Crc32(blob.first(blob.size() - 4)) == stored;

  // block table
  struct Entry {
    std::string name;
    uint32_t rows, cols;
  };
  std::vector<Entry> entries;
  for (uint32_t i = 0; i < count; ++i) {
    uint16_t len = 0;
    COINS_RETURN_IF_ERROR(r.Get(&len, "block name length"));
    Entry e;
    e.name.resize(len);
    COINS_RETURN_IF_ERROR(r.GetBytes(e.name.data(), len, "block name"));
    COINS_RETURN_IF_ERROR(r.Get(&e.rows, "block rows"));
    COINS_RETURN_IF_ERROR(r.Get(&e.cols, "block cols"));
    entries.push_back(std::move(e));
    if (entries.size() > blob.size()) return Errorf("{}: corrupt block table", source);
  }
  uint64_t floats = 0;
  COINS_RETURN_IF_ERROR(r.Get(&floats, "float count"));
  if (floats > blob.size() / 4 + 1)
    return Errorf("{}: truncated: header promises {} floats but the file has {} bytes", source, floats, blob.size());
  if (blob.size() - r.pos() != floats * 4 + 4)
    return Errorf(
        "{}: truncated or oversized: {} bytes after the header, expected {} values + "
        "4-byte checksum",
        source, blob.size() - r.pos(), floats);
  if (!crc_ok) return Errorf("{}: checksum mismatch (file is corrupt)", source);

  // shapes against the destination networks, in order
  size_t want_blocks = 0;
  int64_t want_floats = 0;
  for (const ParamSet* p : sets) {
    want_blocks += p->blocks().size();
    want_floats += p->size();
  }
  if (entries.size() != want_blocks)
    return Errorf("{}: shape mismatch: {} blocks stored, the network(s) have {}", source, entries.size(), want_blocks);
  size_t i = 0;
  for (const ParamSet* p : sets)
    for (const ParamBlock& b : p->blocks()) {
      const Entry& e = entries[i];
      if (e.name != b.name || int(e.rows) != b.rows || int(e.cols) != b.cols)
        return Errorf("{}: shape mismatch at block {}: stored {} {}x{}, network has {} {}x{}", source, i, e.name,
                      e.rows, e.cols, b.name, b.rows, b.cols);
      ++i;
    }
  if (int64_t(floats) != want_floats)
    return Errorf("{}: shape mismatch: {} values stored, the network(s) have {}", source, floats, want_floats);
  for (ParamSet* p : sets) COINS_RETURN_IF_ERROR(r.GetBytes(p->values.data(), size_t(p->size()) * 4, "values"));
  return Status::Ok();
}

Status SaveWeights(const std::string& path, const ParamSet& params) {
  const std::vector<uint8_t> blob = ToBlob(params);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return Errorf("{}: cannot open for writing", path);
  out.write(reinterpret_cast<const char*>(blob.data()), std::streamsize(blob.size()));
  out.close();
  if (!out) return Errorf("{}: write failed", path);
  return Status::Ok();
}

Status LoadWeights(const std::string& path, ParamSet* params) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Errorf("{}: cannot open for reading", path);
  std::vector<uint8_t> blob((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return FromBlob(blob, params, path);
}

}  // namespace coins::nn
