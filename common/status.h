// Status and Result<T>: how runtime failures travel in coins.
//
// Contract: functions that can fail for reasons outside the program (bad input, files, DDS,
// MuJoCo) return Status or Result<T>; a non-ok Status always carries a one-line message that
// names the offending thing. Broken invariants use assertions, never these types. Exceptions
// are not used as control flow; the few third-party calls that throw are wrapped where called.
#pragma once

#include <cassert>
#include <optional>
#include <string>
#include <utility>

#include <fmt/format.h>

namespace coins {

class [[nodiscard]] Status {
 public:
  Status() = default;
  static Status Ok() { return Status(); }
  static Status Error(std::string message) { return Status(std::move(message)); }

  bool ok() const { return !message_.has_value(); }
  explicit operator bool() const { return ok(); }
  // the error message; empty for an ok status
  const std::string& message() const {
    static const std::string kEmpty;
    return message_ ? *message_ : kEmpty;
  }
  // returns this status with "context: " put in front of the message (ok stays ok)
  Status WithContext(const std::string& context) const { return ok() ? *this : Status(context + ": " + *message_); }

 private:
  explicit Status(std::string message) : message_(std::move(message)) {}
  std::optional<std::string> message_;
};

// builds an error Status from a fmt format string
template <typename... Args>
Status Errorf(fmt::format_string<Args...> format, Args&&... args) {
  return Status::Error(fmt::format(format, std::forward<Args>(args)...));
}

// Result<T>: a value or an error Status.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)) {}         // NOLINT: implicit by design
  Result(Status status) : status_(std::move(status)) {  // NOLINT: implicit by design
    assert(!status_.ok() && "Result built from an ok Status needs a value");
  }

  bool ok() const { return status_.ok(); }
  const Status& status() const { return status_; }
  T& value() & {
    assert(ok());
    return *value_;
  }
  const T& value() const& {
    assert(ok());
    return *value_;
  }
  T&& value() && {
    assert(ok());
    return std::move(*value_);
  }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() { return value(); }

 private:
  Status status_;
  std::optional<T> value_;
};

}  // namespace coins

// returns early from the enclosing function with the status when it is not ok
#define COINS_RETURN_IF_ERROR(expr)                \
  do {                                             \
    ::coins::Status coins_status_ = (expr);        \
    if (!coins_status_.ok()) return coins_status_; \
  } while (0)
