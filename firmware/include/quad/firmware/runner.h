// The loop that runs the flight application on a target, written against the HAL only, so every
// target's image is `hal::init(); app.init(...); run_hil(app)` or `run_board(app)`.
//
//   HIL:   the iteration is driven by HIL_SENSOR on UART0 (lockstep with the simulator; the clock is the
//          simulator's), the motor commands go back as HIL_ACTUATOR_CONTROLS.
//   board: the iteration runs at SYS_LOOP_HZ on hal::micros(), with the IMU, magnetometer and RC from
//          the HAL drivers and the motor commands to hal::motors_write().
#pragma once

#include "quad/firmware/app.h"

namespace quad {
namespace fw {

// RC channel order of the receiver (APM convention, 0-based): roll, pitch, throttle, yaw, then the
// motor-enable and manual/auto switches of thesis sec. 6.1.4 (on above 1500 us).
constexpr uint8_t kRcRoll = 0, kRcPitch = 1, kRcThrottle = 2, kRcYaw = 3, kRcMotorEnable = 4, kRcAutoMode = 5;

// The AppIo of a HAL target: storage, serial output and clock from the HAL.
AppIo hal_app_io();

// Connects the HIL bridge (hil_bridge.h: HIL_SENSOR in, HIL_ACTUATOR_CONTROLS out) and initialises the
// application with io for hardware-in-the-loop. One application per image.
void init_hil(FlightApp& app, AppIo io);

// Hands every byte waiting on the serial ports to the application.
void poll_ports(FlightApp& app);

// One pass of the board loop: ports, RC, and a control iteration when one is due. Returns true when an
// iteration ran.
bool board_pass(FlightApp& app);

// Forever.
void run_hil(FlightApp& app);
void run_board(FlightApp& app);

}  // namespace fw
}  // namespace quad
