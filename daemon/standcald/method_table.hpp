#pragma once
// Every method standcald answers, in one table: who may call it and which thread answers
// it. The server checks access and routes by this table; the sequencer binds a handler to
// each of its rows (Sequencer::handles); tests/daemon's MethodTable cases check that the
// handlers, this table and docs/protocol.md name the same methods.
#include <span>
#include <string_view>

namespace standcal::daemon {

// Who may call a method: any connected client (read-only views, estop, auth), or one that
// has control (docs/security.md: the control group, or a TCP client after auth).
enum class Access { anyone, control };

// Which thread answers.
enum class Executor {
  server,           // the socket thread, from thread-safe views (status, run.status, ...)
  diagnose_worker,  // a worker thread that waits on a child process (run.diagnose)
  sequencer,        // the hardware thread (Sequencer): stand, unit and run commands
};

struct MethodSpec {
  std::string_view name;
  Access access;
  Executor executor;
};

std::span<const MethodSpec> method_table();
// The row of `name`, or nullptr for a method standcald does not have.
const MethodSpec* find_method(std::string_view name);

}  // namespace standcal::daemon
