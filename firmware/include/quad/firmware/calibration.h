// Boot-time calibration on a still vehicle: the gyro bias (the mean rate, since the true rate is zero),
// the accelerometer bias along gravity (|mean specific force| - g: the only part of the bias a still
// vehicle can observe) and the mean magnetometer reading for the initial attitude. Any sample that
// strays from the running mean by more than the stillness thresholds restarts the collection.
#pragma once

#include <stdint.h>

#include "quad/math/math.h"

namespace quad {
namespace fw {

struct CalibrationConfig {
  float duration_s = 2.0f;       // CAL_TIME
  float gyro_still = 0.05f;      // CAL_GYRO_STILL, rad/s from the mean
  float accel_still = 0.5f;      // CAL_ACC_STILL, m/s^2 from the mean
};

struct CalibrationResult {
  Vec3 gyro_bias;    // rad/s, FRD
  Vec3 accel_bias;   // m/s^2, FRD, along the measured gravity direction
  Vec3 accel_mean;   // bias-corrected mean specific force (points up in FRD: -g e_z level)
  Vec3 mag_mean;     // gauss, FRD; valid only if mag_valid
  bool mag_valid = false;
};

class BootCalibration {
 public:
  void configure(const CalibrationConfig& config) { config_ = config; }
  void restart();

  // Adds one sample at t_us. Returns true once, when the vehicle has been still for the duration.
  bool add(uint32_t t_us, const Vec3& gyro, const Vec3& accel, const Vec3* mag);

  bool done() const { return done_; }
  uint16_t restarts() const { return restarts_; }
  const CalibrationResult& result() const { return result_; }

 private:
  CalibrationConfig config_;
  Vec3 gyro_sum_;
  Vec3 accel_sum_;
  Vec3 mag_sum_;
  uint16_t n_ = 0;
  uint16_t mag_n_ = 0;
  uint32_t start_us_ = 0;
  uint16_t restarts_ = 0;
  bool done_ = false;
  CalibrationResult result_;
};

}  // namespace fw
}  // namespace quad
