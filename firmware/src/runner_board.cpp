// The board loop: the HAL's sensor drivers and motor outputs at SYS_LOOP_HZ.
#include "quad/firmware/runner.h"

#include "quad/hal/hal.h"

namespace quad {
namespace fw {

bool board_pass(FlightApp& app) {
  poll_ports(app);
  hal::RcFrame rc;
  if (hal::rc_read(rc) && rc.count > kRcYaw) {
    ctrl::RcSticks sticks;
    sticks.roll = rc.pulse_us[kRcRoll];
    sticks.pitch = rc.pulse_us[kRcPitch];
    sticks.throttle = rc.pulse_us[kRcThrottle];
    sticks.yaw = rc.pulse_us[kRcYaw];
    if (rc.count > kRcAutoMode) {
      RcSwitches switches;
      switches.motors_enabled = rc.pulse_us[kRcMotorEnable] > 1500;
      switches.auto_mode = rc.pulse_us[kRcAutoMode] > 1500;
      app.rc_input(sticks, hal::micros(), &switches);
    } else {
      app.rc_input(sticks, hal::micros());
    }
  }
  const uint32_t now = hal::micros();
  if (!app.loop_timer().due(now)) return false;
  hal::ImuSample imu;
  if (!hal::imu_read(imu)) return false;  // no new sample: the sensors' health check will notice
  hal::MagSample mag;
  const bool mag_new = hal::mag_read(mag);
  app.step(now, imu, mag_new ? &mag : nullptr);
  hal::motors_write(app.motors());
  hal::led_write(app.led(now));
  return true;
}

void run_board(FlightApp& app) {
  for (;;) {
    if (!board_pass(app)) hal::idle(200);
  }
}

}  // namespace fw
}  // namespace quad
