#include "daemon/standcald/method_table.hpp"

#include <algorithm>

#include "protocol/jsonrpc/methods.hpp"

namespace standcal::daemon {

namespace {

namespace m = protocol::method;
using enum Access;
using enum Executor;

// `hello` is not here: the daemon sends it (a notification on connect); no client calls it.
constexpr MethodSpec kMethods[] = {
    {m::status, anyone, server},
    {m::run_status, anyone, server},
    {m::run_result, anyone, server},
    {m::runs_list, anyone, server},
    {m::subscribe, anyone, server},
    {m::auth, anyone, server},
    {m::run_diagnose, anyone, diagnose_worker},
    // An emergency stop is open to every client, whatever its access (docs/security.md).
    {m::estop, anyone, sequencer},
    {m::estop_reset, control, sequencer},
    {m::stand_enable, control, sequencer},
    {m::stand_disable, control, sequencer},
    {m::stand_home, control, sequencer},
    {m::stand_move, control, sequencer},
    {m::stand_stop, control, sequencer},
    {m::unit_read, control, sequencer},
    {m::run_start, control, sequencer},
    {m::run_pause, control, sequencer},
    {m::run_resume, control, sequencer},
    {m::run_abort, control, sequencer},
    {m::operator_confirm, control, sequencer},
};

}  // namespace

std::span<const MethodSpec> method_table() { return kMethods; }

const MethodSpec* find_method(std::string_view name) {
  const auto it = std::find_if(std::begin(kMethods), std::end(kMethods),
                               [&](const MethodSpec& s) { return s.name == name; });
  return it == std::end(kMethods) ? nullptr : &*it;
}

}  // namespace standcal::daemon
