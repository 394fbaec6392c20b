#pragma once
// What the sequencer's source files share (sequencer.cpp: the command queue and thread;
// sequencer_stand.cpp: stand and unit commands; sequencer_run.cpp: runs): the axes, and
// the one mapping from a driver's error to the protocol error the operator sees, and the
// names the three files use. Not for use outside daemon/standcald.
#include <chrono>
#include <string>
#include <utility>

#include "drivers/clock.hpp"
#include "drivers/stand.hpp"
#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/methods.hpp"

namespace standcal::daemon::detail {

using drivers::StandAxis;
using nlohmann::json;
using protocol::ErrorCode;
using protocol::RpcError;
namespace m = protocol::method;
namespace st = protocol::run_state;
namespace ev = protocol::event;

inline constexpr drivers::StandAxis kAxes[] = {drivers::StandAxis::outer,
                                               drivers::StandAxis::inner};

// Real (wall) time, for what an operator waits on (the ETA): the steady clock's.
inline double now_real_s() { return drivers::steady_clock()->now_s(); }

inline protocol::ErrorCode code_for(drivers::ErrorKind kind) {
  using protocol::ErrorCode;
  switch (kind) {
    case drivers::ErrorKind::limit:
      return ErrorCode::limit;
    case drivers::ErrorKind::estop:
      return ErrorCode::estop_active;
    case drivers::ErrorKind::invalid_argument:
      return ErrorCode::invalid_params;
    case drivers::ErrorKind::not_allowed:
      return ErrorCode::invalid_state;
    default:
      return ErrorCode::hardware_fault;
  }
}

// Turns a failed driver call into the protocol error the operator sees.
inline void check(const drivers::Status& s) {
  if (!s) throw protocol::RpcError(code_for(s.kind), s.message);
}
template <class T>
const T& check(const drivers::Result<T>& r) {
  if (!r) throw protocol::RpcError(code_for(r.status().kind), r.status().message);
  return r.value();
}
// A wait that ended early: an axis that lost its drive mid-move is a hardware fault, not a
// refused request.
template <class T>
T check_wait(drivers::Result<T> r) {
  if (!r) {
    const drivers::ErrorKind kind = r.status().kind;
    throw protocol::RpcError(kind == drivers::ErrorKind::not_allowed
                                 ? protocol::ErrorCode::hardware_fault
                                 : code_for(kind),
                             r.status().message);
  }
  return std::move(r.value());
}

}  // namespace standcal::daemon::detail
