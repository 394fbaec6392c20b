#pragma once
// The Stand over Modbus TCP or RTU (docs/stand-modbus.md).
//
// Threading: libmodbus contexts are not thread-safe, so each ModbusStand runs ONE I/O
// thread that owns its link. Calls from any thread are queued to it and wait for the
// answer; between requests that thread writes the heartbeat every
// timing.heartbeat_period_s and, when the link is down, re-opens it with back-off.
// Dropping a ModbusStand without deactivate() sends no command: the controller's
// heartbeat watchdog stops any motion (comm-loss safety).
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <thread>

#include "drivers/modbus/link.hpp"
#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/url.hpp"
#include "drivers/stand.hpp"

namespace standcal::drivers::modbus {

class ModbusStand final : public Stand {
 public:
  // Checks the URL; opens nothing until configure().
  static Result<std::unique_ptr<ModbusStand>> create(const std::string& url,
                                                     ModbusStandConfig config);
  ~ModbusStand() override;

  AxisRange range(StandAxis axis) const override {
    return config_.ranges[static_cast<int>(axis) - 1];
  }
  std::string name() const override { return name_; }

  std::uint64_t heartbeats_written() const { return heartbeats_.load(); }  // for bring-up and tests
  int link_opens() const { return link_opens_.load(); }                    // 1 + reconnects so far

 protected:
  // The controller's steps over the link; drivers/stand/lifecycle.cpp decides when they run.
  Status on_configure() override;
  Result<bool> on_read_estop_latched() override;
  Status on_cleanup() override;
  Status on_recover() override;
  Status on_enable(StandAxis axis) override;
  Status on_disable(StandAxis axis) override;
  Status on_home(StandAxis axis) override;
  Status on_move_to(StandAxis axis, double angle_deg) override;
  Status on_stop(StandAxis axis) override;
  Status on_emergency_stop() override;
  Result<AxisState> on_read_state(StandAxis axis) override;

 private:
  ModbusStand(ModbusUrl url, ModbusStandConfig config);
  // Runs `job` on the I/O thread and returns its Status; reports a link loss (link_lost()).
  Status on_link(std::function<Status(ModbusLink&)> job);
  Status write_axis_command(StandAxis axis, AxisCommand command, const std::string& what);
  Status open_and_arm(ModbusLink& link);
  void io_loop();
  void beat(ModbusLink& link);

  struct Job {
    std::function<Status(ModbusLink&)> run;
    std::promise<Status> done;
  };

  ModbusUrl url_;
  ModbusStandConfig config_;
  std::string name_;
  std::atomic<bool> heartbeat_on_{false};
  std::atomic<std::uint64_t> heartbeats_{0};  // writes that were answered
  // The value of the next heartbeat write. Advanced on every attempt, answered or not: a
  // write whose reply timed out may still have landed, and writing the same value again
  // would look to the controller's watchdog like no heartbeat at all.
  std::atomic<std::uint16_t> heartbeat_value_{0};
  std::atomic<int> link_opens_{0};
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Job*> queue_;
  bool quit_ = false;
  std::thread io_thread_;  // last: starts after every member it uses exists
};

}  // namespace standcal::drivers::modbus
