#pragma once
// A simulated accelerometer unit sitting on a SimStand: its samples follow calib's full
// measurement model (unit errors, stand errors, noise) at the stand's angles of the
// moment, so sim readings obey the same physics as `standcal simulate`.
#include <memory>
#include <mutex>

#include "calib/simulator.hpp"
#include "drivers/accel_unit.hpp"
#include "drivers/sim/sim_clock.hpp"
#include "drivers/sim/sim_stand.hpp"

namespace standcal::drivers {

class SimUnit : public AccelUnit {
 public:
  SimUnit(std::shared_ptr<const SimClock> clock, std::shared_ptr<const SimStand> stand,
          const TruthModel& truth, std::uint64_t seed, double sample_rate_hz);

  std::string name() const override { return "sim"; }
  Status start() override;
  Status stop() override;
  Result<std::vector<AccelSample>> collect(double seconds) override;
  Result<std::vector<AccelSample>> collect_more(double seconds) override;
  AccelUnitHealth health() const override;

  // The simulated operator's hands: the unit is now mounted this way on the table.
  void remount(Mount mount);
  // Fault injection for tests: a silent unit fails every collect like a silent CAN bus.
  void set_silent(bool silent);

 private:
  Result<std::vector<AccelSample>> collect_from(double seconds, bool continuing);
  void restart_grid(double origin_s);
  double grid_time_s(std::uint64_t sample) const;

  std::shared_ptr<const SimClock> clock_;
  std::shared_ptr<const SimStand> stand_;
  double sample_rate_hz_;
  mutable std::mutex mutex_;
  UnitSimulator simulator_;
  Mount mount_ = Mount::x;
  bool started_ = false;
  bool collected_since_start_ = false;  // collect_more continues the grid
  bool silent_ = false;
  double grid_origin_s_ = 0;       // the sample grid: sample k at origin + k / rate
  std::uint64_t next_sample_ = 0;  // the grid's next sample not yet returned
  double series_end_s_ = 0;        // where the last collect's window ended, after grid_origin_s_
  std::uint64_t counter_ = 0;
  AccelUnitHealth health_;
};

}  // namespace standcal::drivers
