// standcald's request framing and validation (protocol/jsonrpc: LineBuffer, parse_request,
// Params, make_result/make_error): arbitrary bytes from a client, in arbitrary pieces.
// The server's dispatch (Server::handle_line) is private to the daemon and needs a live
// sequencer, so it is not covered here.
//
// Input: byte 0 sets the piece size (1..64) the bytes arrive in; the rest is the stream.
// Properties: no line handed out contains a newline; every answer (result echoing the
// params, or the error for a bad request) is one line of valid JSON that echoes the id;
// parameter access only ever throws RpcError.
#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>
#include <variant>

#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/line_buffer.hpp"

namespace rpc = standcal::protocol;
using nlohmann::json;

namespace {

void check_answer(const std::string& line, const json& id) {
  standcal::fuzz::require(line.find('\n') == std::string::npos,
                          "jsonrpc_request: an answer contains a newline");
  const json answer = json::parse(line, nullptr, /*allow_exceptions=*/false);
  standcal::fuzz::require(!answer.is_discarded(),
                          "jsonrpc_request: an answer is not valid JSON: " + line);
  standcal::fuzz::require(answer.contains("id") && answer["id"] == id,
                          "jsonrpc_request: an answer lost the id");
}

// Typed parameter access as the daemon's methods do it; RpcError is the documented rejection.
void access_params(const rpc::Request& req) {
  const rpc::Params p(req.params, req.method);
  const char* keys[] = {"axis",   "angle_deg", "program", "run_id",
                        "events", "dwell_s",   "follow",  "limit"};
  for (const char* key : keys) {
    try {
      (void)p.optional_number(key);
    } catch (const rpc::RpcError&) {
    }
    try {
      (void)p.optional_integer(key, 1, 1000);
    } catch (const rpc::RpcError&) {
    }
    try {
      (void)p.optional_string(key);
    } catch (const rpc::RpcError&) {
    }
    try {
      (void)p.optional_bool(key, false);
    } catch (const rpc::RpcError&) {
    }
  }
  try {
    p.only({"axis", "angle_deg"});
  } catch (const rpc::RpcError&) {
  }
}

void handle(const std::string& line) {
  standcal::fuzz::require(line.find('\n') == std::string::npos,
                          "jsonrpc_request: a framed line contains a newline");
  const auto parsed = rpc::parse_request(line);
  if (const auto* bad = std::get_if<rpc::BadRequest>(&parsed)) {
    check_answer(rpc::make_error(bad->id, bad->error.code(), bad->error.what(), bad->error.data()),
                 bad->id);
    return;
  }
  const auto& req = std::get<rpc::Request>(parsed);
  access_params(req);
  check_answer(rpc::make_result(req.id, req.params), req.id);
  check_answer(rpc::make_error(req.id, static_cast<int>(rpc::ErrorCode::method_not_found),
                               "unknown method '" + req.method + "'"),
               req.id);
}

}  // namespace

int standcal_fuzz_jsonrpc_request(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  return standcal::fuzz::expect_no_exceptions("jsonrpc_request", [&] {
    const std::size_t piece = 1 + data[0] % 64;
    rpc::LineBuffer in(rpc::kMaxRequestBytes);
    const std::string_view stream = standcal::fuzz::as_text(data + 1, size - 1);
    for (std::size_t at = 0; at < stream.size(); at += piece) {
      in.append(stream.substr(at, std::min(piece, stream.size() - at)));
      while (auto line = in.next_line()) handle(*line);
      if (in.overflowed()) return;  // the daemon answers and closes the connection
    }
  });
}
