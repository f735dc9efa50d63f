// Sensor calibration in the flight core (thesis sec. 7.1-7.3).
//
// Usage, gyro and accelerometer bias at boot (vehicle still and level, thesis eq. 7.2 and 7.4):
//   quad::est::StationaryCalibrator cal;            // default stillness limits
//   for each sample in the window: cal.add(gyro_frd, accel_frd);
//   quad::est::ImuBias bias;
//   if (cal.result(bias) == quad::est::CalibrationStatus::kOk) { gyro -= bias.gyro; accel -= bias.accel; }
//
// Usage, magnetometer (the fit itself runs on the host, see quad/estimation/mag_fit.h):
//   quad::est::MagCalibration mc{offset, soft_iron};
//   quad::Vec3 m = mc.apply(raw_mag);               // W (m_raw - b)
#pragma once

#include <stdint.h>

#include "quad/math/math.h"

namespace quad {
namespace est {

struct ImuBias {
  Vec3 gyro;   // rad/s, subtract from the gyro
  Vec3 accel;  // m/s^2, subtract from the accelerometer
};

// When is a window "still"? Standard deviations are per axis over the window.
struct StillnessLimits {
  uint16_t min_samples = 100;
  float max_gyro_std = 0.01f;       // rad/s   (MPU-6000 noise is ~0.001 rad/s per sample)
  float max_accel_std = 0.1f;       // m/s^2
  float max_gyro_mean = 0.35f;      // rad/s: a larger mean is a turning vehicle, not a bias (20 deg/s)
  float max_accel_bias = 1.0f;      // m/s^2: a larger "bias" means the vehicle was not level (~6 deg)
};

enum class CalibrationStatus : uint8_t {
  kOk,
  kTooFewSamples,
  kNonFinite,    // a sample was not finite
  kMoved,        // gyro or accelerometer spread too large
  kTurning,      // gyro mean beyond max_gyro_mean
  kNotLevel,     // accelerometer mean too far from (0, 0, -g)
};

// Accumulates a window of samples; the statistics are taken about the first sample so that the
// variance of an accelerometer reading ~9.8 m/s^2 does not cancel catastrophically in float.
class StationaryCalibrator {
 public:
  StationaryCalibrator() : StationaryCalibrator(StillnessLimits{}) {}
  explicit StationaryCalibrator(const StillnessLimits& limits) : limits_(limits) {}

  void reset();
  void add(const Vec3& gyro_frd, const Vec3& accel_frd);
  uint16_t samples() const { return n_; }

  // Bias per thesis eq. 7.4 (gyro: the mean) and eq. 7.2 (accelerometer: the mean plus g e_z).
  CalibrationStatus result(ImuBias& out) const;
  // Largest per-axis standard deviations of the window (for diagnostics).
  float gyro_std() const;
  float accel_std() const;

 private:
  StillnessLimits limits_;
  Vec3 g0_, a0_;            // first samples (shift)
  Vec3 gs_, gss_, as_, ass_;  // sums and sums of squares of the shifted samples
  uint16_t n_ = 0;
  bool non_finite_ = false;
};

// Hard- and soft-iron correction m = W (m_raw - b)  (inverse of thesis eq. 7.5 with D^-1 = W).
struct MagCalibration {
  Vec3 offset;                     // b, raw units
  Mat3 soft_iron = Mat3::identity();  // W, symmetric from the host fit
  Vec3 apply(const Vec3& raw) const { return soft_iron * (raw - offset); }
};

}  // namespace est
}  // namespace quad
