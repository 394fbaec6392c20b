#include "protocol/jsonrpc/messages.hpp"

#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/methods.hpp"

namespace standcal::protocol {

namespace {

// Writes an optional parameter only when it is set: a request carries what the user gave.
template <typename T>
void put_if(json& j, const char* key, const std::optional<T>& v) {
  if (v) j[key] = *v;
}

[[noreturn]] void invalid(const std::string& message) {
  throw RpcError(ErrorCode::invalid_params, message);
}

}  // namespace

// ------------------------------------------------------------------ requests: the daemon's side

void parse_no_params(const json& params, const std::string& method) {
  Params(params, method).only({});
}

StandMoveParams StandMoveParams::parse(const json& params) {
  const Params p(params, method::stand_move);
  p.only({"alpha1_deg", "alpha2_deg", "wait"});
  StandMoveParams out{p.number("alpha1_deg"), p.number("alpha2_deg"),
                      p.optional_bool("wait", true)};
  if (!std::isfinite(out.alpha1_deg) || !std::isfinite(out.alpha2_deg))
    invalid("stand.move: angles must be finite");
  return out;
}

UnitReadParams UnitReadParams::parse(const json& params) {
  const Params p(params, method::unit_read);
  p.only({"seconds"});
  return {p.number("seconds")};
}

RunStartParams RunStartParams::parse(const json& params) {
  const Params p(params, method::run_start);
  p.only({"program", "dwell_s", "settle_s", "warmup_s", "unit_serial", "unit_type", "operator"});
  // Text fields go into the recording header, run.json and the records database: each
  // one line of printable text, counted in characters (protocol/jsonrpc/text.hpp).
  RunStartParams out;
  out.unit_serial = p.optional_text("unit_serial", text_limit::unit_serial).value_or("");
  if (out.unit_serial.empty())
    invalid("run.start: parameter \"unit_serial\" is required (1 to " +
            std::to_string(text_limit::unit_serial) + " characters)");
  out.unit_type = p.optional_text("unit_type", text_limit::unit_type);
  out.operator_name = p.optional_text("operator", text_limit::operator_name);
  const json* program = p.find("program");
  if (program == nullptr) invalid("run.start: parameter \"program\" is required");
  out.program = *program;
  out.dwell_s = p.optional_number("dwell_s");
  out.settle_s = p.optional_number("settle_s");
  out.warmup_s = p.optional_number("warmup_s");
  return out;
}

RunTargetParams RunTargetParams::parse(const json& params, const std::string& method) {
  const Params p(params, method);
  p.only({"run_id"});
  return {p.optional_text("run_id", text_limit::run_id)};
}

RunResultParams RunResultParams::parse(const json& params) {
  const Params p(params, method::run_result);
  p.only({"run_id"});
  return {p.string("run_id")};
}

RunDiagnoseParams RunDiagnoseParams::parse(const json& params) {
  const Params p(params, method::run_diagnose);
  p.only({"run_id", "report"});
  return {p.string("run_id"), p.optional_bool("report", false)};
}

RunsListParams RunsListParams::parse(const json& params) {
  const Params p(params, method::runs_list);
  p.only({"unit_serial", "before", "limit"});
  RunsListParams out;
  out.unit_serial = p.optional_text("unit_serial", text_limit::unit_serial);
  out.before = p.optional_text("before", text_limit::run_id);
  if (const auto limit = p.optional_integer("limit", 1, runs_list_max_limit))
    out.limit = static_cast<int>(*limit);
  return out;
}

SubscribeParams SubscribeParams::parse(const json& params) {
  const Params p(params, method::subscribe);
  p.only({"events"});
  const json* events = p.find("events");
  if (events == nullptr || (events->is_string() && (*events == "all" || *events == "*"))) return {};
  if (!events->is_array())
    invalid("subscribe: \"events\" must be a list of event names or \"all\"");
  std::vector<std::string> names;
  for (const json& e : *events) {
    if (!e.is_string()) invalid("subscribe: \"events\" must be a list of event names");
    names.push_back(e.get<std::string>());
  }
  return {std::move(names)};
}

AuthParams AuthParams::parse(const json& params) {
  const Params p(params, method::auth);
  p.only({"token"});
  return {p.string("token")};
}

// ------------------------------------------------------------------ requests: the CLI's side

void to_json(json& j, const StandMoveParams& p) {
  j = json{{"alpha1_deg", p.alpha1_deg}, {"alpha2_deg", p.alpha2_deg}, {"wait", p.wait}};
}

void to_json(json& j, const UnitReadParams& p) { j = json{{"seconds", p.seconds}}; }

void to_json(json& j, const RunStartParams& p) {
  j = json{{"program", p.program}, {"unit_serial", p.unit_serial}};
  put_if(j, "unit_type", p.unit_type);
  put_if(j, "dwell_s", p.dwell_s);
  put_if(j, "settle_s", p.settle_s);
  put_if(j, "warmup_s", p.warmup_s);
  put_if(j, "operator", p.operator_name);
}

void to_json(json& j, const RunTargetParams& p) {
  j = json::object();
  put_if(j, "run_id", p.run_id);
}

void to_json(json& j, const RunResultParams& p) { j = json{{"run_id", p.run_id}}; }

void to_json(json& j, const RunDiagnoseParams& p) {
  j = json{{"run_id", p.run_id}, {"report", p.report}};
}

void to_json(json& j, const RunsListParams& p) {
  j = json::object();
  put_if(j, "unit_serial", p.unit_serial);
  put_if(j, "limit", p.limit);
  put_if(j, "before", p.before);
}

void to_json(json& j, const SubscribeParams& p) {
  j = json::object();
  if (p.events)
    j["events"] = *p.events;
  else
    j["events"] = "all";
}

void to_json(json& j, const AuthParams& p) { j = json{{"token", p.token}}; }

// ------------------------------------------------------------------ results and events

void to_json(json& j, const AxisStatus& a) {
  if (a.error) {
    j = json{{"axis", a.axis}, {"error", *a.error}};
    return;
  }
  j = json{{"axis", a.axis},
           {"mode", a.mode},
           {"angle_deg", a.angle_deg},
           {"enabled", a.enabled},
           {"homed", a.homed},
           {"estop", a.estop},
           {"stopped_by_heartbeat", a.stopped_by_heartbeat},
           {"fault_code", a.fault_code},
           {"fault_text", a.fault_text}};
}

void from_json(const json& j, AxisStatus& a) {
  a = AxisStatus{};
  a.axis = j.value("axis", "");
  if (j.contains("error")) {
    a.error = j.at("error").get<std::string>();
    return;
  }
  a.mode = j.value("mode", "");
  a.angle_deg = j.value("angle_deg", 0.0);
  a.enabled = j.value("enabled", false);
  a.homed = j.value("homed", false);
  a.estop = j.value("estop", false);
  a.stopped_by_heartbeat = j.value("stopped_by_heartbeat", false);
  a.fault_code = j.value("fault_code", 0);
  a.fault_text = j.value("fault_text", "");
}

void to_json(json& j, const Hello& h) {
  j = json{{"daemon", h.daemon},
           {"version", h.version},
           {"protocol", h.protocol},
           {"max_request_bytes", h.max_request_bytes}};
  put_if(j, "estop_only", h.estop_only);
  put_if(j, "message", h.message);
}

void from_json(const json& j, Hello& h) {
  h = Hello{};
  h.daemon = j.value("daemon", "");
  h.version = j.value("version", "");
  h.protocol = j.value("protocol", "");
  h.max_request_bytes = j.value("max_request_bytes", std::int64_t{0});
  if (j.contains("estop_only")) h.estop_only = j.at("estop_only").get<bool>();
  if (j.contains("message")) h.message = j.at("message").get<std::string>();
}

void to_json(json& j, const FaultEvent& e) {
  j = json{{"message", e.message}};
  put_if(j, "run_id", e.run_id);
  put_if(j, "position", e.position);
  put_if(j, "source", e.source);
}

void from_json(const json& j, FaultEvent& e) {
  e = FaultEvent{};
  e.message = j.value("message", "");
  if (j.contains("run_id")) e.run_id = j.at("run_id").get<std::string>();
  if (j.contains("position")) e.position = j.at("position").get<int>();
  if (j.contains("source")) e.source = j.at("source").get<std::string>();
}

}  // namespace standcal::protocol
