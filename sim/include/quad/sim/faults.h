// What the scenario's faults do at one instant: their combined effect on the radio, the sensors, the
// motors and the message sources. Pure, so the session only applies it.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Core>

#include "quad/sim/imu.h"
#include "quad/sim/scenario.h"
#include "quad/sim/serial_line.h"
#include "quad/sim/vision_fix.h"

namespace quad::sim {

// What a faulty IMU puts into HIL_SENSOR in place of its reading.
enum class ImuSampleFault {
  kNone,
  kSaturated,  // every axis pinned at full scale, with the sign of the reading (a shock)
  kNonFinite,  // NaN and +-infinity (a broken driver or bus)
};

struct FaultEffects {
  RadioConditions radio;                                              // base conditions, worsened
  Eigen::Vector3d mag_offset_ned_gauss = Eigen::Vector3d::Zero();     // added to the local field
  Eigen::Vector3d gyro_bias_step_rad_s = Eigen::Vector3d::Zero();     // added to the gyro bias
  std::array<double, 4> motor_efficiency{1.0, 1.0, 1.0, 1.0};         // per motor, multiplied
  bool vision_dropout = false;                                        // no vision fixes
  FixErrors vision_errors;                                            // late, scaled or decoy fixes
  ImuSampleFault imu = ImuSampleFault::kNone;
  bool rc_loss = false;                                               // no MANUAL_CONTROL
};

// Overlapping faults combine: losses and bit error rates take the worst, latencies the last listed
// (vision latencies add), field and bias offsets add, efficiencies and fix scales multiply, the last
// listed decoy is the one seen, a non-finite IMU sample wins over a saturated one.
FaultEffects fault_effects(const std::vector<Fault>& faults, const RadioConditions& base_radio, double t);

// The IMU reading as a faulty sensor reports it: `reading` itself without a fault; pinned at the ranges
// of `params` when saturated; (NaN, +inf, -inf) on the accelerometer and (-inf, NaN, +inf) on the gyro
// when non-finite, so every axis meets both kinds of non-finite value within the pair.
ImuReading apply_imu_fault(const ImuReading& reading, ImuSampleFault fault, const ImuParams& params);

const char* fault_name(FaultType type);

}  // namespace quad::sim
