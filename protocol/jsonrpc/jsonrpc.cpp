#include "protocol/jsonrpc/jsonrpc.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "protocol/jsonrpc/text.hpp"

namespace standcal::protocol {

using nlohmann::json;

const char* error_code_name(int code) {
  switch (static_cast<ErrorCode>(code)) {
    case ErrorCode::parse_error:
      return "parse error";
    case ErrorCode::invalid_request:
      return "invalid request";
    case ErrorCode::method_not_found:
      return "method not found";
    case ErrorCode::invalid_params:
      return "invalid params";
    case ErrorCode::internal_error:
      return "internal error";
    case ErrorCode::busy:
      return "busy";
    case ErrorCode::not_homed:
      return "not homed";
    case ErrorCode::limit:
      return "limit";
    case ErrorCode::estop_active:
      return "estop active";
    case ErrorCode::hardware_fault:
      return "hardware fault";
    case ErrorCode::not_found:
      return "not found";
    case ErrorCode::invalid_state:
      return "invalid state";
    case ErrorCode::too_many_clients:
      return "too many clients";
    case ErrorCode::not_permitted:
      return "not permitted";
  }
  return "error";
}

namespace {

// JSON-RPC 2.0: "a String, Number, or NULL value" (fractions and null are discouraged,
// not forbidden).
bool valid_id(const json& id) { return id.is_string() || id.is_number() || id.is_null(); }

BadRequest invalid(json id, const std::string& why) {
  return BadRequest{std::move(id), RpcError(ErrorCode::invalid_request, why)};
}

}  // namespace

std::variant<Request, BadRequest> parse_request(std::string_view line) {
  json doc = json::parse(line.begin(), line.end(), nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) {
    return BadRequest{nullptr, RpcError(ErrorCode::parse_error, "request is not valid JSON")};
  }
  if (doc.is_array()) {
    // One answer for the whole array, as the specification gives for an empty one.
    return invalid(
        nullptr,
        "batches (JSON arrays of requests) are not supported: send one request object per line");
  }
  if (!doc.is_object()) return invalid(nullptr, "request must be a JSON object");
  json id = nullptr;
  const bool has_id = doc.contains("id");
  if (has_id) {
    if (!valid_id(doc["id"])) return invalid(nullptr, "\"id\" must be a string, a number or null");
    id = doc["id"];
  }
  if (!doc.contains("jsonrpc") || doc["jsonrpc"] != "2.0") {
    return invalid(id, "\"jsonrpc\" must be \"2.0\"");
  }
  if (!doc.contains("method") || !doc["method"].is_string()) {
    return invalid(id, "\"method\" must be a string");
  }
  Request r;
  r.id = id;
  r.is_notification = !has_id;
  r.method = doc["method"].get<std::string>();
  if (doc.contains("params")) {
    const json& p = doc["params"];
    if (p.is_object()) {
      r.params = p;
    } else if (p.is_array()) {
      // A valid request (possibly a notification) that no standcald method can take: the
      // server answers it -32602 unless it is a notification.
      r.positional_params = true;
    } else {
      return invalid(id, "\"params\" must be an object of named parameters (or left out)");
    }
  }
  return r;
}

namespace {

// Throws naming the first text in `j` (a string, or an object's key) that is not UTF-8, by
// its path from the parameters ("program/1/name"; the parameter's name at the top). A key
// is named by its object's path, not echoed: its bytes are what is wrong.
void require_utf8_texts(const std::string& method, const json& j, const std::string& path) {
  const auto refuse = [&](const std::string& what, std::size_t at) {
    throw std::invalid_argument(method + ": " + what + " must be UTF-8 text: byte " +
                                std::to_string(at + 1) + " is not");
  };
  if (j.is_string()) {
    if (const auto at = first_non_utf8_byte(j.get_ref<const std::string&>()))
      refuse("parameter \"" + path + "\"", *at);
  } else if (j.is_object()) {
    for (const auto& [key, value] : j.items()) {
      if (const auto at = first_non_utf8_byte(key))
        refuse(path.empty() ? "a parameter's name" : "a key of parameter \"" + path + "\"", *at);
      require_utf8_texts(method, value, path.empty() ? key : path + "/" + key);
    }
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i)
      require_utf8_texts(method, j[i], path + "/" + std::to_string(i));
  }
}

}  // namespace

std::string make_request(const json& id, const std::string& method, const json& params) {
  // Not replaced as the answers' bytes are: a serial or operator name given on the command
  // line in Latin-1 would reach the daemon changed. Refused, naming the parameter (it printed
  // only nlohmann's "type_error.316 invalid UTF-8 byte"), however deep it lies (a
  // programme's position names).
  require_utf8_texts(method, params, "");
  return json{{"jsonrpc", "2.0"}, {"id", id}, {"method", method}, {"params", params}}.dump();
}

std::string make_result(const json& id, const json& result) {
  // Serialised piecewise rather than as one json{...}: that would deep-copy the result,
  // and a large answer (a runs.list page, a diagnosis) would then sit in memory twice.
  constexpr auto replace = json::error_handler_t::replace;
  return R"({"id":)" + id.dump(-1, ' ', false, replace) + R"(,"jsonrpc":"2.0","result":)" +
         result.dump(-1, ' ', false, replace) + "}";
}

std::string printable(std::string_view text) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  for (const char ch : text) {
    const auto byte = static_cast<unsigned char>(ch);
    if (byte == 0) {
      out += "\\0";
    } else if (byte < 0x20 || byte == 0x7f) {
      out += "\\x";
      out += kHex[byte >> 4];
      out += kHex[byte & 0xf];
    } else {
      out += ch;
    }
  }
  return out;
}

std::string make_error(const json& id, int code, const std::string& message, const json& data) {
  json err{{"code", code}, {"message", message}};
  if (!data.is_null()) err["data"] = data;
  return json{{"jsonrpc", "2.0"}, {"id", id}, {"error", err}}.dump(-1, ' ', false,
                                                                   json::error_handler_t::replace);
}

std::string make_notification(const std::string& method, const json& params) {
  return json{{"jsonrpc", "2.0"}, {"method", method}, {"params", params}}.dump(
      -1, ' ', false, json::error_handler_t::replace);
}

void Params::wrong(const char* key, const char* expected) const {
  throw RpcError(ErrorCode::invalid_params,
                 method_ + ": parameter \"" + key + "\" must be " + expected);
}

const json* Params::find(const char* key) const {
  auto it = p_.find(key);
  if (it == p_.end() || it->is_null()) return nullptr;
  return &*it;
}

double Params::number(const char* key) const {
  const json* v = find(key);
  if (v == nullptr) {
    throw RpcError(ErrorCode::invalid_params, method_ + ": parameter \"" + key + "\" is required");
  }
  if (!v->is_number()) wrong(key, "a number");
  return v->get<double>();
}

std::optional<double> Params::optional_number(const char* key) const {
  if (find(key) == nullptr) return std::nullopt;
  return number(key);
}

std::optional<std::int64_t> Params::optional_integer(const char* key, std::int64_t min,
                                                     std::int64_t max) const {
  const json* v = find(key);
  if (v == nullptr) return std::nullopt;
  const std::string range =
      "a whole number from " + std::to_string(min) + " to " + std::to_string(max);
  if (!v->is_number()) wrong(key, range.c_str());
  const double x = v->get<double>();
  if (!(x >= static_cast<double>(min) && x <= static_cast<double>(max)) || x != std::floor(x)) {
    throw RpcError(ErrorCode::invalid_params,
                   method_ + ": parameter \"" + key + "\" must be " + range + ", not " + v->dump());
  }
  return static_cast<std::int64_t>(x);
}

std::string Params::string(const char* key) const {
  const json* v = find(key);
  if (v == nullptr) {
    throw RpcError(ErrorCode::invalid_params, method_ + ": parameter \"" + key + "\" is required");
  }
  if (!v->is_string()) wrong(key, "a string");
  return v->get<std::string>();
}

std::optional<std::string> Params::optional_string(const char* key) const {
  if (find(key) == nullptr) return std::nullopt;
  return string(key);
}

std::optional<std::string> Params::optional_text(const char* key, std::size_t max_chars) const {
  std::optional<std::string> text = optional_string(key);
  if (text) require_text_field(method_ + ": parameter \"" + key + "\"", *text, max_chars);
  return text;
}

bool Params::optional_bool(const char* key, bool fallback) const {
  const json* v = find(key);
  if (v == nullptr) return fallback;
  if (!v->is_boolean()) wrong(key, "true or false");
  return v->get<bool>();
}

void Params::only(std::initializer_list<const char*> allowed) const {
  for (auto it = p_.begin(); it != p_.end(); ++it) {
    bool known = false;
    for (const char* a : allowed) known = known || it.key() == a;
    if (!known) {
      throw RpcError(ErrorCode::invalid_params,
                     method_ + ": unknown parameter \"" + it.key() + "\"");
    }
  }
}

}  // namespace standcal::protocol
