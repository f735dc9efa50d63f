// Boot-time calibration on a still vehicle, in windows of CAL_TIME seconds: the gyro and accelerometer
// biases by thesis eq. 7.4 and 7.2 (quad::est::StationaryCalibrator: the gyro mean; the accelerometer
// mean plus g e_z, the vehicle standing level), and the mean magnetometer reading for the initial
// heading. A window in which the vehicle moved, turned, was not level or gave a non-finite sample is
// thrown away and the next one starts.
#pragma once

#include <stdint.h>

#include "quad/estimation/calibration.h"
#include "quad/math/math.h"

namespace quad {
namespace fw {

struct CalibrationConfig {
  float duration_s = 2.0f;  // CAL_TIME: length of a window
  est::StillnessLimits limits;
};

struct CalibrationResult {
  est::ImuBias bias;
  Vec3 mag_mean;  // FRD, the magnetometer's units; valid only if mag_valid
  bool mag_valid = false;
};

class BootCalibration {
 public:
  enum class Event : uint8_t { kCollecting, kDone, kWindowRejected };

  void configure(const CalibrationConfig& config);
  void restart();

  // Adds one sample taken at t_us. kDone once, when a window passed; kWindowRejected when one failed
  // (rejection() says why) and a new one begins with the next sample.
  Event add(uint32_t t_us, const Vec3& gyro, const Vec3& accel, const Vec3* mag);

  bool done() const { return done_; }
  uint16_t windows_rejected() const { return rejected_; }
  est::CalibrationStatus rejection() const { return rejection_; }
  const CalibrationResult& result() const { return result_; }

 private:
  CalibrationConfig config_;
  est::StationaryCalibrator stats_;
  Vec3 mag_sum_;
  uint16_t mag_n_ = 0;
  uint32_t start_us_ = 0;
  bool started_ = false;
  bool done_ = false;
  uint16_t rejected_ = 0;
  est::CalibrationStatus rejection_ = est::CalibrationStatus::kOk;
  CalibrationResult result_;
};

}  // namespace fw
}  // namespace quad
