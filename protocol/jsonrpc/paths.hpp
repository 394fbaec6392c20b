#pragma once
// Where an installed standcal keeps things: one definition for the daemon, the CLI, the
// systemd units (systemd/*.in, filled in by CMake) and the docs (docs/install.md).
// StateDirectory=standcal and RuntimeDirectory=standcal in the unit create the two
// directories; systemd fixes them under /var/lib and /run whatever the install prefix.
namespace standcal::paths {

inline constexpr const char* kConfigFile = "/etc/standcal/standcald.json";
inline constexpr const char* kStateDir = "/var/lib/standcal";
inline constexpr const char* kSocket = "/run/standcal/standcald.sock";

}  // namespace standcal::paths
