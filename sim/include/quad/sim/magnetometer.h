// Honeywell HMC5883L magnetometer: 75 Hz output, each output the mean of 8 measurements, 12-bit
// (1090 LSB/gauss at the +-1.3 Ga range), with the hard- and soft-iron distortion of thesis eq. 7.5:
//   m_B = D R^T m_I + b_m + eta_m,
// D lower-triangular from scale errors eps_i and misalignments delta_i (thesis eq. 7.6).
#pragma once

#include <Eigen/Core>

#include "quad/sim/rng.h"

namespace quad::sim {

struct MagParams {
  bool present = true;  // false: the vehicle has no magnetometer (HIL_SENSOR never flags a sample)
  double output_rate_hz = 75.0;
  int averaged_samples = 8;
  double noise_gauss = 2.0e-3;  // standard deviation of one output (data sheet noise floor, 8-sample mean)
  double range_gauss = 1.3;
  double lsb_gauss = 1.0 / 1090.0;
  Eigen::Vector3d scale{1.03, 0.97, 1.01};           // eps_1..3 (thesis eq. 7.6)
  Eigen::Vector3d misalignment_rad{0.02, -0.015, 0.01};  // delta_1..3 (thesis eq. 7.6)
  Eigen::Vector3d hard_iron_gauss{0.04, -0.03, 0.06};    // b_m (thesis eq. 7.5)
};

// D of thesis eq. 7.6.
Eigen::Matrix3d soft_iron_matrix(const Eigen::Vector3d& scale, const Eigen::Vector3d& misalignment);

class Hmc5883l {
 public:
  Hmc5883l(const MagParams& params, Rng rng);

  // Feeds the true body-frame (FRD) field at simulated time t (call at the physics rate). Returns true
  // when a new output is ready; `reading()` then holds it.
  bool update(double t, const Eigen::Vector3d& true_field_frd);
  const Eigen::Vector3d& reading() const { return reading_; }
  const MagParams& params() const { return p_; }

 private:
  MagParams p_;
  Rng rng_;
  Eigen::Matrix3d distortion_;
  double next_measurement_t_ = 0.0;
  int count_ = 0;
  Eigen::Vector3d sum_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d reading_ = Eigen::Vector3d::Zero();
};

}  // namespace quad::sim
