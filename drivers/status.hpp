#pragma once
// The error type every driver call returns: the caller must look at it ([[nodiscard]]:
// a dropped one is a compile error; `(void)` says "deliberately ignored", with a reason), and its
// message is written for a bench operator ("no reply from tcp://127.0.0.1:1502 unit 1
// after 3 tries").
#include <string>
#include <utility>
#include <variant>

namespace standcal::drivers {

enum class ErrorKind {
  none,
  timeout,      // no reply / no frame within the allowed time
  link,         // connection lost or cannot be opened
  protocol,     // malformed reply, Modbus exception, bad frame
  not_allowed,  // lifecycle forbids the call (e.g. motion while inactive)
  limit,        // angle outside an axis range
  fault,        // the device reports a fault
  estop,        // emergency stop active
  invalid_argument,
};

struct [[nodiscard]] Status {
  ErrorKind kind = ErrorKind::none;
  std::string message;

  static Status ok() { return {}; }
  static Status error(ErrorKind k, std::string msg) { return {k, std::move(msg)}; }
  explicit operator bool() const { return kind == ErrorKind::none; }
};

// A value or the Status explaining why there is none.
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}       // NOLINT: implicit by design
  Result(Status error) : v_(std::move(error)) {}  // NOLINT: implicit by design
  bool ok() const { return std::holds_alternative<T>(v_); }
  explicit operator bool() const { return ok(); }
  const T& value() const { return std::get<T>(v_); }
  T& value() { return std::get<T>(v_); }
  const Status& status() const {
    static const Status kOk{};
    return ok() ? kOk : std::get<Status>(v_);
  }

 private:
  std::variant<T, Status> v_;
};

}  // namespace standcal::drivers
