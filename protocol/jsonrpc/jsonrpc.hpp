#pragma once
// JSON-RPC 2.0 as standcald speaks it (docs/protocol.md): one JSON object per line, an
// `id` echoed back, error objects with the standard codes plus the application codes
// below, and notifications (no `id`) for the greeting and events.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>

namespace standcal::protocol {

inline constexpr const char* kProtocolVersion = "1";
inline constexpr std::size_t kMaxRequestBytes = 64 * 1024;  // one line, newline excluded

// Error codes: JSON-RPC's standard ones and standcald's application codes.
enum class ErrorCode : int {
  parse_error = -32700,
  invalid_request = -32600,
  method_not_found = -32601,
  invalid_params = -32602,
  internal_error = -32603,
  busy = -32001,            // a run or another stand command is in progress
  not_homed = -32002,       // motion asked of an axis that has not found its reference
  limit = -32003,           // an angle outside an axis range
  estop_active = -32004,    // emergency stop latched: estop.reset first
  hardware_fault = -32005,  // the stand or unit failed, timed out or lost its link
  not_found = -32006,       // no such run / programme
  invalid_state = -32007,   // not possible now (pause with no run, resume a finished run)
  too_many_clients = -32008,
  not_permitted =
      -32009,  // refused by access control (docs/security.md): control needs group or `auth`
};

// Short name of a code ("busy", "parse error"), for CLI output and logs.
const char* error_code_name(int code);

// `text` with its control bytes escaped: NUL as \0, the others as \xNN. A client's value
// quoted in a message keeps all of itself (a NUL used to end the message at what()) and
// cannot start a new line in the journal.
std::string printable(std::string_view text);

// An error to send back: code, operator-readable message (control bytes escaped, see
// printable), optional data.
class RpcError : public std::runtime_error {
 public:
  RpcError(ErrorCode code, const std::string& message, nlohmann::json data = nullptr)
      : std::runtime_error(printable(message)),
        code_(static_cast<int>(code)),
        data_(std::move(data)) {}
  RpcError(int code, const std::string& message, nlohmann::json data = nullptr)
      : std::runtime_error(printable(message)), code_(code), data_(std::move(data)) {}
  int code() const { return code_; }
  const nlohmann::json& data() const { return data_; }

 private:
  int code_;
  nlohmann::json data_;
};

// A valid request or notification from a client.
struct Request {
  // As sent (string, number or null); null for a notification (no reply is sent).
  nlohmann::json id;
  bool is_notification = false;
  bool positional_params = false;  // `params` was an array: valid JSON-RPC, but no method takes it
  std::string method;
  nlohmann::json params = nlohmann::json::object();
};

// What a line parsed into: a request, or the error response to send (id null when the
// id could not be read).
struct BadRequest {
  nlohmann::json id;
  RpcError error;
};
std::variant<Request, BadRequest> parse_request(std::string_view line);

// Serialised messages, each one line WITHOUT the trailing newline.
std::string make_request(const nlohmann::json& id, const std::string& method,
                         const nlohmann::json& params);
std::string make_result(const nlohmann::json& id, const nlohmann::json& result);
std::string make_error(const nlohmann::json& id, int code, const std::string& message,
                       const nlohmann::json& data = nullptr);
std::string make_notification(const std::string& method, const nlohmann::json& params);

// Typed access to `params`, throwing RpcError(invalid_params) that names the parameter.
class Params {
 public:
  Params(const nlohmann::json& params, std::string method)
      : p_(params), method_(std::move(method)) {}
  double number(const char* key) const;
  std::optional<double> optional_number(const char* key) const;
  // A whole number (5 or 5.0, not 5.5) within [min, max]; the error names the range.
  std::optional<std::int64_t> optional_integer(const char* key, std::int64_t min,
                                               std::int64_t max) const;
  std::string string(const char* key) const;
  std::optional<std::string> optional_string(const char* key) const;
  // A text field: one line of printable text of at most `max_chars` characters (UTF-8
  // code points); the error names the parameter and says why (protocol/jsonrpc/text.hpp).
  std::optional<std::string> optional_text(const char* key, std::size_t max_chars) const;
  bool optional_bool(const char* key, bool fallback) const;
  const nlohmann::json* find(const char* key) const;  // nullptr when absent or null
  // Rejects any key not in `allowed` (a misspelt parameter must not be silently ignored).
  void only(std::initializer_list<const char*> allowed) const;

 private:
  [[noreturn]] void wrong(const char* key, const char* expected) const;
  const nlohmann::json& p_;
  std::string method_;
};

}  // namespace standcal::protocol
