#include "quad/firmware/calibration.h"

namespace quad {
namespace fw {

void BootCalibration::restart() {
  gyro_sum_ = accel_sum_ = mag_sum_ = Vec3{};
  n_ = mag_n_ = 0;
  done_ = false;
}

bool BootCalibration::add(uint32_t t_us, const Vec3& gyro, const Vec3& accel, const Vec3* mag) {
  if (done_) return false;
  if (!is_finite(gyro) || !is_finite(accel) || (mag != nullptr && !is_finite(*mag))) {
    restart();
    ++restarts_;
    return false;
  }
  if (n_ > 0) {
    const float inv = 1.0f / static_cast<float>(n_);
    const bool moved = norm_sq(gyro - gyro_sum_ * inv) > sqf(config_.gyro_still) ||
                       norm_sq(accel - accel_sum_ * inv) > sqf(config_.accel_still);
    if (moved) {
      restart();
      ++restarts_;
    }
  }
  if (n_ == 0) start_us_ = t_us;
  gyro_sum_ += gyro;
  accel_sum_ += accel;
  ++n_;
  if (mag != nullptr) {
    mag_sum_ += *mag;
    ++mag_n_;
  }
  const float elapsed_s = static_cast<float>(t_us - start_us_) * 1e-6f;
  if (elapsed_s < config_.duration_s || n_ < 10) return false;

  const float inv = 1.0f / static_cast<float>(n_);
  result_.gyro_bias = gyro_sum_ * inv;
  const Vec3 a = accel_sum_ * inv;
  const float a_norm = norm(a);
  const Vec3 up = a_norm > 0.0f ? a * (1.0f / a_norm) : Vec3{0.0f, 0.0f, -1.0f};
  result_.accel_bias = up * (a_norm - kGravity);
  result_.accel_mean = a - result_.accel_bias;
  result_.mag_valid = mag_n_ > 0;
  result_.mag_mean = mag_n_ > 0 ? mag_sum_ * (1.0f / static_cast<float>(mag_n_)) : Vec3{};
  done_ = true;
  return true;
}

}  // namespace fw
}  // namespace quad
