#pragma once
// What the OS said about the last failed call, for log lines and error replies.
#include <cerrno>
#include <cstring>
#include <string>

namespace standcal::daemon {

inline std::string errno_text() { return std::strerror(errno); }

}  // namespace standcal::daemon
