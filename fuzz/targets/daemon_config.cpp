// standcald's config reader (daemon/standcald/config.hpp parse_config, docs/daemon.md):
// arbitrary JSON as /etc/standcal/standcald.json. ConfigError (a std::runtime_error) is
// the documented rejection.
#include <nlohmann/json.hpp>

#include "daemon/standcald/config.hpp"
#include "fuzz/targets/fuzz_support.hpp"
#include "fuzz/targets/targets.hpp"

int standcal_fuzz_daemon_config(const std::uint8_t* data, std::size_t size) {
  const auto doc = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return 0;  // not JSON: load_config rejects it before parse_config
  return standcal::fuzz::expect_only_runtime_errors("daemon_config", [&] {
    const standcal::daemon::DaemonConfig config = standcal::daemon::parse_config(doc, "fuzz-input");
    standcal::fuzz::require(!standcal::daemon::config_hash(config).empty(),
                            "daemon_config: empty config hash");
  });
}
