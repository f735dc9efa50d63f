#include "quad/estimation/calibration.h"

namespace quad {
namespace est {

void StationaryCalibrator::reset() { *this = StationaryCalibrator(limits_); }

void StationaryCalibrator::add(const Vec3& gyro, const Vec3& accel) {
  if (!is_finite(gyro) || !is_finite(accel)) {
    non_finite_ = true;
    return;
  }
  if (n_ == 0) {
    g0_ = gyro;
    a0_ = accel;
  }
  if (n_ == 0xFFFFu) return;  // a full window: later samples add nothing the mean needs
  const Vec3 dg = gyro - g0_, da = accel - a0_;
  gs_ += dg;
  gss_ += hadamard(dg, dg);
  as_ += da;
  ass_ += hadamard(da, da);
  ++n_;
}

namespace {
// Largest per-axis standard deviation from shifted sums (sum d, sum d^2) of n samples.
float max_std(const Vec3& s, const Vec3& ss, uint16_t n) {
  if (n < 2) return 0.0f;
  const float inv_n = 1.0f / static_cast<float>(n);
  float worst = 0.0f;
  for (int i = 0; i < 3; ++i) {
    const float mean = s[i] * inv_n;
    worst = maxf(worst, ss[i] * inv_n - mean * mean);
  }
  return safe_sqrtf(worst * static_cast<float>(n) / static_cast<float>(n - 1));
}
}  // namespace

float StationaryCalibrator::gyro_std() const { return max_std(gs_, gss_, n_); }
float StationaryCalibrator::accel_std() const { return max_std(as_, ass_, n_); }

CalibrationStatus StationaryCalibrator::result(ImuBias& out) const {
  if (non_finite_) return CalibrationStatus::kNonFinite;
  if (n_ < limits_.min_samples || n_ < 2) return CalibrationStatus::kTooFewSamples;
  if (gyro_std() > limits_.max_gyro_std || accel_std() > limits_.max_accel_std) return CalibrationStatus::kMoved;
  const float inv_n = 1.0f / static_cast<float>(n_);
  const Vec3 gyro_mean = g0_ + gs_ * inv_n;
  const Vec3 accel_mean = a0_ + as_ * inv_n;
  if (norm(gyro_mean) > limits_.max_gyro_mean) return CalibrationStatus::kTurning;
  // thesis eq. 7.2: b_a = mean(a_B) + g e_z (the vehicle level, at the identity attitude)
  const Vec3 accel_bias = accel_mean + Vec3{0.0f, 0.0f, kGravity};
  if (norm(accel_bias) > limits_.max_accel_bias) return CalibrationStatus::kNotLevel;
  out.gyro = gyro_mean;  // thesis eq. 7.4
  out.accel = accel_bias;
  return CalibrationStatus::kOk;
}

}  // namespace est
}  // namespace quad
