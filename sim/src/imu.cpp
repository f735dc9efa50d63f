#include "quad/sim/imu.h"

#include <algorithm>
#include <cmath>

namespace quad::sim {

Mpu6000::Mpu6000(const ImuParams& params, Rng rng)
    : p_(params),
      rng_(std::move(rng)),
      dt_(1.0 / params.sample_rate_hz),
      dlpf_alpha_(params.dlpf_cutoff_hz > 0.0
                      ? 1.0 - std::exp(-2.0 * 3.14159265358979323846 * params.dlpf_cutoff_hz * dt_)
                      : 1.0) {
  for (int i = 0; i < 3; ++i) gyro_bias_[i] = rng_.normal(p_.gyro.turn_on_bias);
  for (int i = 0; i < 3; ++i) accel_bias_[i] = rng_.normal(p_.accel.turn_on_bias);
}

Eigen::Vector3d Mpu6000::corrupt(const Eigen::Vector3d& truth, Eigen::Vector3d& bias, const ImuAxisParams& axis,
                                 double vibration) {
  // Discrete equivalents of the continuous densities at the sample rate.
  const double white = axis.noise_density / std::sqrt(dt_);
  const double walk = axis.bias_random_walk * std::sqrt(dt_);
  const double vib = axis.vibration_at_full_speed * std::clamp(vibration, 0.0, 1.0);
  Eigen::Vector3d out;
  for (int i = 0; i < 3; ++i) {
    bias[i] += rng_.normal(walk);
    const double raw = truth[i] + bias[i] + rng_.normal(white) + (vib > 0.0 ? rng_.normal(vib) : 0.0);
    out[i] = std::clamp(raw, -axis.range, axis.range);  // the ADC saturates before the digital filter
  }
  return out;
}

Eigen::Vector3d Mpu6000::finish(const Eigen::Vector3d& filtered, const ImuAxisParams& axis) const {
  Eigen::Vector3d out;
  for (int i = 0; i < 3; ++i) out[i] = axis.lsb > 0.0 ? std::round(filtered[i] / axis.lsb) * axis.lsb : filtered[i];
  return out;
}

ImuReading Mpu6000::sample(const Eigen::Vector3d& true_specific_force_frd, const Eigen::Vector3d& true_rate_frd,
                           double vibration) {
  const Eigen::Vector3d gyro_raw =
      corrupt(true_rate_frd + gyro_bias_step_, gyro_bias_, p_.gyro, vibration);
  const Eigen::Vector3d accel_raw = corrupt(true_specific_force_frd, accel_bias_, p_.accel, vibration);
  if (!primed_) {  // the filter starts settled on the first sample, as after the sensor's start-up
    gyro_filtered_ = gyro_raw;
    accel_filtered_ = accel_raw;
    primed_ = true;
  }
  gyro_filtered_ += dlpf_alpha_ * (gyro_raw - gyro_filtered_);
  accel_filtered_ += dlpf_alpha_ * (accel_raw - accel_filtered_);
  return {finish(accel_filtered_, p_.accel), finish(gyro_filtered_, p_.gyro)};
}

}  // namespace quad::sim
