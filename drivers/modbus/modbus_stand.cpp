// ModbusStand: the Stand's hardware steps over one I/O thread (see the header).
#include "drivers/modbus/modbus_stand.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace standcal::drivers::modbus {

namespace {

using Clock = std::chrono::steady_clock;

std::string axis_text(StandAxis axis) { return std::string(to_string(axis)) + " axis"; }

bool is_link_loss(const Status& s) {
  return s.kind == ErrorKind::timeout || s.kind == ErrorKind::link;
}

// An axis status block as read from the input registers.
struct RawAxisStatus {
  std::uint16_t state = 0;
  std::uint16_t flags = 0;
  std::int32_t angle_counts = 0;
  std::uint16_t fault = 0;
};

Status read_axis_status(ModbusLink& link, const RegisterMap& map, StandAxis axis,
                        RawAxisStatus& out) {
  const AxisRegisters& r = map.axis(axis);
  const int first = std::min({r.state, r.flags, r.angle, r.fault});
  const int last = std::max({static_cast<int>(r.state), static_cast<int>(r.flags), r.angle + 1,
                             static_cast<int>(r.fault)});
  std::vector<std::uint16_t> regs(static_cast<std::size_t>(last - first + 1));
  if (regs.size() > 125)
    return Status::error(
        ErrorKind::invalid_argument,
        "stand config: the " + axis_text(axis) + " status registers span more than 125 registers");
  auto read = link.read_input(static_cast<std::uint16_t>(first), static_cast<int>(regs.size()),
                              regs.data(), "reading " + axis_text(axis) + " status");
  if (!read) return read;
  out.state = regs[r.state - first];
  out.flags = regs[r.flags - first];
  out.angle_counts = get_i32(&regs[r.angle - first], map.word_order);
  out.fault = regs[r.fault - first];
  return Status::ok();
}

}  // namespace

Result<std::unique_ptr<ModbusStand>> ModbusStand::create(const std::string& url,
                                                         ModbusStandConfig config) {
  auto parsed = parse_url(url);
  if (!parsed) return parsed.status();
  return std::unique_ptr<ModbusStand>(
      new ModbusStand(std::move(parsed.value()), std::move(config)));
}

ModbusStand::ModbusStand(ModbusUrl url, ModbusStandConfig config)
    : url_(std::move(url)),
      config_(std::move(config)),
      name_(describe(url_)),
      io_thread_([this] { io_loop(); }) {}

ModbusStand::~ModbusStand() {
  {
    std::lock_guard lock(mutex_);
    quit_ = true;
  }
  wake_.notify_all();
  io_thread_.join();
}

void ModbusStand::io_loop() {
  ModbusLink link(url_, config_.timing);
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(config_.timing.heartbeat_period_s));
  auto next_beat = Clock::now();
  for (;;) {
    Job* job = nullptr;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_until(lock, next_beat, [&] { return quit_ || !queue_.empty(); });
      if (quit_ && queue_.empty()) break;
      if (!queue_.empty()) {
        job = queue_.front();
        queue_.pop_front();
      }
    }
    if (Clock::now() >= next_beat) {
      beat(link);
      next_beat = Clock::now() + period;
    }
    if (job != nullptr) job->done.set_value(job->run(link));
    link_opens_ = link.opens();
  }
}

// The controller's watchdog needs a changing value; after a re-open the controller may
// have restarted, so its watchdog timeout is written again first.
void ModbusStand::beat(ModbusLink& link) {
  if (!heartbeat_on_) return;
  const int opens_before = link.opens();
  // A lost link is re-opened here in the background, one attempt per back-off, so the
  // heartbeat never holds the I/O thread for long while the controller is away.
  if (!link.reopen_if_due()) return;
  const std::uint16_t counter = ++heartbeat_value_;
  if (auto written = link.write(config_.map.heartbeat, 1, &counter, "writing the heartbeat");
      !written) {
    if (is_link_loss(written)) link_lost();
    return;
  }
  ++heartbeats_;
  if (link.opens() != opens_before) {
    const auto timeout_ms =
        static_cast<std::uint16_t>(std::lround(config_.timing.heartbeat_timeout_s * 1000));
    (void)link.write(config_.map.heartbeat_timeout_ms, 1, &timeout_ms,
                     "writing the heartbeat timeout");
  }
}

Status ModbusStand::on_link(std::function<Status(ModbusLink&)> job) {
  Job request{std::move(job), {}};
  auto done = request.done.get_future();
  {
    std::lock_guard lock(mutex_);
    queue_.push_back(&request);
  }
  wake_.notify_all();
  Status result = done.get();
  if (is_link_loss(result)) link_lost();
  return result;
}

Status ModbusStand::open_and_arm(ModbusLink& link) {
  if (auto opened = link.open_with_retries(); !opened) return opened;
  const auto timeout_ms =
      static_cast<std::uint16_t>(std::lround(config_.timing.heartbeat_timeout_s * 1000));
  const std::uint16_t counter = ++heartbeat_value_;
  if (auto w = link.write(config_.map.heartbeat_timeout_ms, 1, &timeout_ms,
                          "writing the heartbeat timeout");
      !w)
    return w;
  if (auto w = link.write(config_.map.heartbeat, 1, &counter, "writing the heartbeat"); !w)
    return w;
  ++heartbeats_;
  // Read, never assume: both axes must answer before the stand counts as configured.
  for (StandAxis axis : {StandAxis::outer, StandAxis::inner}) {
    RawAxisStatus status;
    if (auto r = read_axis_status(link, config_.map, axis, status); !r) return r;
  }
  return Status::ok();
}

Status ModbusStand::on_configure() {
  auto opened = on_link([&](ModbusLink& link) { return open_and_arm(link); });
  if (!opened) return opened;
  heartbeat_on_ = true;
  return Status::ok();
}

Result<bool> ModbusStand::on_read_estop_latched() {
  std::uint16_t flags = 0;
  auto read = on_link([&](ModbusLink& link) {
    return link.read_input(config_.map.global_flags, 1, &flags, "reading the global flags");
  });
  if (!read) return read;
  return (flags & kGlobalEstop) != 0;
}

Status ModbusStand::on_cleanup() {
  heartbeat_on_ = false;
  return on_link([](ModbusLink& link) {
    link.close();
    return Status::ok();
  });
}

Status ModbusStand::on_recover() {
  auto recovered = on_link([this](ModbusLink& link) {
    if (auto armed = open_and_arm(link); !armed) return armed;
    const auto reset = static_cast<std::uint16_t>(GlobalCommand::reset);
    return link.write(config_.map.global_command, 1, &reset, "resetting the emergency stop");
  });
  if (!recovered) return recovered;
  heartbeat_on_ = true;
  return Status::ok();
}

Status ModbusStand::write_axis_command(StandAxis axis, AxisCommand command,
                                       const std::string& what) {
  const auto value = static_cast<std::uint16_t>(command);
  return on_link([&](ModbusLink& link) {
    return link.write(config_.map.axis(axis).command, 1, &value, what);
  });
}

Status ModbusStand::on_enable(StandAxis axis) {
  if (auto w = write_axis_command(axis, AxisCommand::enable, "enabling the " + axis_text(axis)); !w)
    return w;
  const auto deadline = Clock::now() + std::chrono::duration<double>(config_.enable_timeout_s);
  for (;;) {
    auto state = on_read_state(axis);
    if (!state) return state.status();
    if (state.value().enabled) return Status::ok();
    if (Clock::now() > deadline) {
      const AxisState& s = state.value();
      const std::string why =
          s.estop ? "emergency stop latched"
          : s.mode == AxisMode::fault
              ? "fault " + std::to_string(s.fault_code) + " (" + s.fault_text + ")"
              : to_string(s.mode);
      return Status::error(ErrorKind::fault,
                           "stand " + name_ + " " + axis_text(axis) + " did not enable: " + why);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

Status ModbusStand::on_disable(StandAxis axis) {
  return write_axis_command(axis, AxisCommand::disable, "disabling the " + axis_text(axis));
}

Status ModbusStand::on_home(StandAxis axis) {
  return write_axis_command(axis, AxisCommand::home, "starting the " + axis_text(axis) + " homing");
}

Status ModbusStand::on_move_to(StandAxis axis, double angle_deg) {
  const RegisterMap& map = config_.map;
  const AxisRegisters& r = map.axis(axis);
  const std::string what =
      "commanding the " + axis_text(axis) + " move to " + format_deg(angle_deg);
  return on_link([&](ModbusLink& link) {
    RawAxisStatus now;
    if (auto read = read_axis_status(link, map, axis, now); !read) return read;
    // The path is planned from the controller's raw angle so a continuous axis takes the
    // shorter way without unwinding the turns it has counted.
    auto target =
        path_target_deg(range(axis), angle_deg, counts_to_angle_deg(map, now.angle_counts));
    if (!target)
      return Status::error(target.status().kind, "stand " + name_ + " " + axis_text(axis) + ": " +
                                                     target.status().message);
    auto counts = angle_to_counts(map, target.value());
    if (!counts) return counts.status();
    std::uint16_t block[4] = {0, 0, 0, static_cast<std::uint16_t>(AxisCommand::move)};
    put_i32(block, counts.value(), map.word_order);
    block[2] = static_cast<std::uint16_t>(
        std::clamp(std::lround(config_.speed_dps / map.speed_lsb_dps), 0L, 65535L));
    if (r.speed == r.target + 2 && r.command == r.target + 3)
      return link.write(r.target, 4, block, what);
    // Scattered registers: target and speed first, the command that acts on them last.
    if (auto w = link.write(r.target, 2, block, what); !w) return w;
    if (auto w = link.write(r.speed, 1, &block[2], what); !w) return w;
    return link.write(r.command, 1, &block[3], what);
  });
}

Status ModbusStand::on_stop(StandAxis axis) {
  return write_axis_command(axis, AxisCommand::stop, "stopping the " + axis_text(axis));
}

Status ModbusStand::on_emergency_stop() {
  const auto value = static_cast<std::uint16_t>(GlobalCommand::emergency_stop);
  return on_link([&](ModbusLink& link) {
    return link.write(config_.map.global_command, 1, &value, "commanding the emergency stop");
  });
}

Result<AxisState> ModbusStand::on_read_state(StandAxis axis) {
  RawAxisStatus raw;
  auto read =
      on_link([&](ModbusLink& link) { return read_axis_status(link, config_.map, axis, raw); });
  if (!read) return read;
  if (raw.state > static_cast<std::uint16_t>(StateCode::fault))
    return Status::error(ErrorKind::protocol, "stand " + name_ + " " + axis_text(axis) +
                                                  " reports an unknown state code " +
                                                  std::to_string(raw.state));
  AxisState s;
  s.mode = static_cast<AxisMode>(raw.state);
  s.angle_deg =
      normalise_reading_deg(range(axis), counts_to_angle_deg(config_.map, raw.angle_counts));
  s.enabled = raw.flags & kFlagEnabled;
  s.homed = raw.flags & kFlagHomed;
  s.stopped_by_heartbeat = raw.flags & kFlagStoppedByHeartbeat;
  s.estop = raw.flags & kFlagEstop;
  s.fault_code = raw.fault;
  if (raw.fault != 0 || s.mode == AxisMode::fault) s.fault_text = fault_text(raw.fault);
  return s;
}

}  // namespace standcal::drivers::modbus
