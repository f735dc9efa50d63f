#include "quad/sim/magnetometer.h"

#include <algorithm>
#include <cmath>

namespace quad::sim {

Eigen::Matrix3d soft_iron_matrix(const Eigen::Vector3d& e, const Eigen::Vector3d& d) {
  Eigen::Matrix3d D;  // thesis eq. 7.6
  D << e[0], 0.0, 0.0,
       e[1] * std::sin(d[0]), e[1] * std::cos(d[0]), 0.0,
       e[2] * std::sin(d[1]) * std::cos(d[2]), e[2] * std::sin(d[2]), e[2] * std::cos(d[1]) * std::cos(d[2]);
  return D;
}

Hmc5883l::Hmc5883l(const MagParams& params, Rng rng)
    : p_(params), rng_(std::move(rng)), distortion_(soft_iron_matrix(params.scale, params.misalignment_rad)) {}

bool Hmc5883l::update(double t, const Eigen::Vector3d& true_field_frd) {
  // The 8 measurements of one output are spread evenly over its period.
  const double measurement_period = 1.0 / (p_.output_rate_hz * p_.averaged_samples);
  if (t + 1e-9 < next_measurement_t_) return false;
  next_measurement_t_ += measurement_period;
  const double per_measurement_noise = p_.noise_gauss * std::sqrt(static_cast<double>(p_.averaged_samples));
  Eigen::Vector3d m = distortion_ * true_field_frd + p_.hard_iron_gauss;  // thesis eq. 7.5
  for (int i = 0; i < 3; ++i) m[i] += rng_.normal(per_measurement_noise);
  sum_ += m;
  if (++count_ < p_.averaged_samples) return false;
  const Eigen::Vector3d mean = sum_ / count_;
  for (int i = 0; i < 3; ++i) {
    const double clipped = std::clamp(mean[i], -p_.range_gauss, p_.range_gauss);
    reading_[i] = std::round(clipped / p_.lsb_gauss) * p_.lsb_gauss;
  }
  sum_.setZero();
  count_ = 0;
  return true;
}

}  // namespace quad::sim
