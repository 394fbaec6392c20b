#pragma once
// Faults the emulator injects, from --fault flags or a control file re-read when it
// changes. One fault per line (docs/stand-modbus.md "Emulator"):
//   stuck outer|inner          the axis does not follow its command (→ following error)
//   slow outer|inner FACTOR    rate and acceleration limits divided by FACTOR
//   overshoot outer|inner DEG  the drive settles DEG past every move target (in the
//                              direction of motion) and still reports "in position"
//   drive_fault outer|inner    trips the drive once (fault code 3)
//   delay_ms N [COUNT]         the next COUNT replies (default: all) are sent N ms late
//   exception CODE [COUNT]     the next COUNT requests (default: all) get exception CODE
//   drop [COUNT]               the next COUNT requests close the TCP connection (RTU: no reply)
//   corrupt [COUNT]            the next COUNT replies have a damaged byte (bad CRC on RTU)
//   # comment
#include <array>
#include <string>
#include <vector>

namespace standcal::emu {

struct Faults {
  std::array<bool, 2> stuck{false, false};
  std::array<double, 2> slow{1.0, 1.0};
  std::array<double, 2> overshoot_deg{0.0, 0.0};
  std::array<bool, 2> drive_fault{false, false};  // one-shot, consumed by the server
  int delay_ms = 0;
  int delay_count = 0;  // < 0: every reply
  int exception_code = 0;
  int exception_count = 0;  // < 0: every request
  int drop_count = 0;
  int corrupt_count = 0;
};

// Parses fault lines into a fresh Faults; an error names the bad line.
bool parse_faults(const std::vector<std::string>& lines, Faults& out, std::string& error);

}  // namespace standcal::emu
