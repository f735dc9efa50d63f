// The hardware-in-the-loop side of the flight application: HIL_SENSOR from the simulator becomes one
// control iteration on the simulator's clock, answered with HIL_ACTUATOR_CONTROLS (docs/hil-protocol.md).
// The application knows only a hook (AppIo::hil_sensor); the encoding and decoding live here, in the HIL
// runner, so a board image carries none of it.
#pragma once

#include <stdint.h>

#include "quad/firmware/app.h"

namespace quad {
namespace fw {

class HilBridge {
 public:
  // Sets io's HIL hook to this bridge, which then steps `app` (call before app.init(io)).
  void connect(FlightApp& app, AppIo& io);

  // One HIL_SENSOR as the iteration takes it.
  struct Sample {
    uint64_t time_usec;
    hal::ImuSample imu;
    hal::MagSample mag;
    bool mag_new;
  };

 private:
  static void on_frame(void* bridge, const mavlink::Frame& frame);
  void on_sample(const Sample& s);
  void send_actuators(uint64_t time_usec);

  FlightApp* app_ = nullptr;
};

}  // namespace fw
}  // namespace quad
