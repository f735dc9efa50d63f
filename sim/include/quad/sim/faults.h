// What the scenario's faults do at one instant: their combined effect on the radio, the sensors, the
// motors and the message sources. Pure, so the session only applies it.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

#include "quad/sim/scenario.h"
#include "quad/sim/serial_line.h"

namespace quad::sim {

struct FaultEffects {
  RadioConditions radio;                                              // base conditions, worsened
  Eigen::Vector3d mag_offset_ned_gauss = Eigen::Vector3d::Zero();     // added to the local field
  Eigen::Vector3d gyro_bias_step_rad_s = Eigen::Vector3d::Zero();     // added to the gyro bias
  std::array<double, 4> motor_efficiency{1.0, 1.0, 1.0, 1.0};         // per motor, multiplied
  bool vision_dropout = false;                                        // no vision fixes
  bool rc_loss = false;                                               // no MANUAL_CONTROL
};

// Overlapping faults combine: losses and bit error rates take the worst, latencies the last listed,
// field and bias offsets add, efficiencies multiply.
FaultEffects fault_effects(const std::vector<Fault>& faults, const RadioConditions& base_radio, double t);

const char* fault_name(FaultType type);

}  // namespace quad::sim
