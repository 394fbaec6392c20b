#pragma once
// The unit's CAN layout from a DBC file, the CAN database format that unit vendors and
// CAN tools (Vector CANdb++, cantools, SavvyCAN) ship. Only what a frame decoder needs
// is read: the messages (BO_), their signals (SG_) and which signals are floats
// (SIG_VALTYPE_); comments, attributes, value tables and nodes are skipped.
// docs/unit-can.md, "The layout as a DBC file".
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/socketcan/frame_layout.hpp"

namespace standcal::drivers::can {

// One SG_ line as written, before a role is given to it.
struct DbcSignal {
  std::string message;  // the BO_ name
  int message_dlc = 0;  // the BO_ payload length, bytes
  int line = 0;         // 1-based line of the SG_ in the file
  bool multiplexed = false;
  bool is_float = false;  // SIG_VALTYPE_ 1 or 2
  SignalSpec spec;        // role not yet set; unit normalised (°C -> degC, m/s^2 -> m/s2)
};

// Parses DBC text; errors name `source`, the line and what was not understood.
Result<std::vector<DbcSignal>> parse_dbc(std::string_view text, const std::string& source);

// Which DBC signal plays which role: keys are a signal name, or MESSAGE.SIGNAL where a
// name repeats across messages. Empty: the signals named force_x, force_y, force_z,
// temperature, counter or counter_* take those roles.
using DbcRoles = std::map<std::string, SignalRole>;

// The layout made of the signals `roles` names (every name must exist, every signal must
// fit its message's DLC, multiplexed and float signals are refused), validated as a JSON
// layout is. Signals with no role are ignored: a vendor's file carries status signals.
Result<FrameLayout> layout_from_dbc(std::string_view text, const std::string& source,
                                    const DbcRoles& roles = {});

}  // namespace standcal::drivers::can
