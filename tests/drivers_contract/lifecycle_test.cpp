// The lifecycle's own rules (drivers/stand/lifecycle.cpp), with a scripted backend whose
// hardware steps succeed or fail on demand: what the shared code does when a step fails,
// which neither real backend can be made to do on cue.
#include <gtest/gtest.h>

#include "drivers/stand.hpp"

namespace standcal::drivers {
namespace {

class ScriptedStand : public Stand {
 public:
  bool estop_read_fails = false;
  int opened = 0;  // on_configure calls
  int closed = 0;  // on_cleanup calls

  AxisRange range(StandAxis) const override { return {}; }
  std::string name() const override { return "scripted"; }

 protected:
  Status on_configure() override {
    ++opened;
    return Status::ok();
  }
  Result<bool> on_read_estop_latched() override {
    if (estop_read_fails)
      return Status::error(ErrorKind::timeout, "no reply reading the e-stop latch");
    return false;
  }
  Status on_cleanup() override {
    ++closed;
    return Status::ok();
  }
  Status on_recover() override { return Status::ok(); }
  Status on_enable(StandAxis) override { return Status::ok(); }
  Status on_disable(StandAxis) override { return Status::ok(); }
  Status on_home(StandAxis) override { return Status::ok(); }
  Status on_move_to(StandAxis, double) override { return Status::ok(); }
  Status on_stop(StandAxis) override { return Status::ok(); }
  Status on_emergency_stop() override { return Status::ok(); }
  Result<AxisState> on_read_state(StandAxis) override { return AxisState{}; }
};

TEST(StandLifecycle, AConfigureThatCannotReadTheEstopLatchClosesTheLinkItOpened) {
  ScriptedStand stand;
  stand.estop_read_fails = true;
  const Status s = stand.configure();
  EXPECT_FALSE(s);
  EXPECT_NE(s.message.find("e-stop latch"), std::string::npos) << s.message;
  EXPECT_EQ(stand.lifecycle(), Lifecycle::unconfigured);
  EXPECT_EQ(stand.opened, 1);
  EXPECT_EQ(stand.closed, 1);  // not left open behind an unconfigured stand

  stand.estop_read_fails = false;  // the next attempt opens it again, and keeps it
  EXPECT_TRUE(stand.configure());
  EXPECT_EQ(stand.lifecycle(), Lifecycle::inactive);
  EXPECT_EQ(stand.opened, 2);
  EXPECT_EQ(stand.closed, 1);
}

}  // namespace
}  // namespace standcal::drivers
