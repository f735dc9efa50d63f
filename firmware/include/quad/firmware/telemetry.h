// The vehicle's telemetry streams, each at its own TEL_*_HZ out of the loop rate: HEARTBEAT (and
// EXTENDED_SYS_STATE at the heartbeat's rate), ATTITUDE_QUATERNION, LOCAL_POSITION_NED, SYS_STATUS and
// ESTIMATOR_STATUS, broadcast on both ports.
#pragma once

#include <stdint.h>

#include "quad/firmware/ground_link.h"
#include "quad/firmware/modes.h"
#include "quad/firmware/params.h"
#include "quad/firmware/scheduler.h"

namespace quad {
namespace fw {

class FlightApp;

class Telemetry {
 public:
  void configure(const Params& p, float loop_hz);
  // Latches an IMU clip until the next SYS_STATUS, which reports the sensor unhealthy for its period.
  void note_clipping(bool gyro, bool accel) {
    gyro_clipped_ = gyro_clipped_ || gyro;
    accel_clipped_ = accel_clipped_ || accel;
  }
  // Once per iteration: counts the streams' rates.
  void count();
  // Whether a stream is due and not sent yet.
  bool due() const { return due_ != 0; }
  // Sends one stream that is due (the first in the order heartbeat, attitude, position, status, extended
  // state, estimator status; the others wait for the next iterations). An iteration without room for it
  // (a vision fix's step, or no time left: FlightApp::step) sends none.
  void send_next(const FlightApp& app, GroundLink& link);

 private:
  enum Stream : uint8_t {
    kHeartbeat = 1, kAttitude = 2, kPosition = 4, kStatus = 8, kExtendedState = 16, kEstimatorStatus = 32
  };
  void send(Stream stream, const FlightApp& app, GroundLink& link);
  void send_status(const FlightApp& app, GroundLink& link);
  void send_estimator_status(const FlightApp& app, GroundLink& link);

  RateDivider heartbeat_rate_;
  RateDivider attitude_rate_;
  RateDivider position_rate_;
  RateDivider status_rate_;
  RateDivider extended_state_rate_;
  RateDivider estimator_rate_;
  uint8_t due_ = 0;             // streams due and not sent yet (Stream bits)
  bool gyro_clipped_ = false;   // since the last SYS_STATUS
  bool accel_clipped_ = false;
  uint32_t radio_rejected_reported_ = 0;
};

// MAVLink HEARTBEAT.base_mode of the vehicle.
uint8_t base_mode(bool armed, bool hil);
// MAV_LANDED_STATE: on the ground while disarmed or landed (the land detector), landing in LANDING,
// else in the air.
uint8_t landed_state(bool armed, bool landed, FlightMode mode);

}  // namespace fw
}  // namespace quad
