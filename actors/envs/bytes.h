// ByteWriter / ByteReader: the little format envs use for SaveState/RestoreState.
//
// Values are trivially-copyable scalars and arrays copied in host byte order (saved states
// are for the same build on the same machine, e.g. resuming or branching a rollout). A reader
// never reads past its span; every Get reports failure instead.
#pragma once

#include <cstdint>
#include <cstring>
#include <span>
#include <type_traits>
#include <vector>

namespace coins::envs {

class ByteWriter {
 public:
  template <typename T>
  void Put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    Append(&v, sizeof(T));
  }
  template <typename T>
  void PutArray(const T* v, size_t n) {
    static_assert(std::is_trivially_copyable_v<T>);
    Put<uint64_t>(n);
    Append(v, n * sizeof(T));
  }
  std::vector<uint8_t> Take() { return std::move(bytes_); }

 private:
  void Append(const void* p, size_t n) {
    const size_t at = bytes_.size();
    bytes_.resize(at + n);
    if (n) std::memcpy(bytes_.data() + at, p, n);
  }
  std::vector<uint8_t> bytes_;
};

class ByteReader {
 public:
  explicit ByteReader(std::span<const uint8_t> bytes) : bytes_(bytes) {}

  template <typename T>
  bool Get(T* v) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (bytes_.size() - pos_ < sizeof(T)) return false;
    std::memcpy(v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return true;
  }
  // reads an array written by PutArray; its length must be exactly n
  template <typename T>
  bool GetArray(T* v, size_t n) {
    uint64_t len = 0;
    if (!Get(&len) || len != n) return false;
    if (bytes_.size() - pos_ < n * sizeof(T)) return false;
    if (n) std::memcpy(v, bytes_.data() + pos_, n * sizeof(T));
    pos_ += n * sizeof(T);
    return true;
  }
  bool done() const { return pos_ == bytes_.size(); }

 private:
  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
};

}  // namespace coins::envs
