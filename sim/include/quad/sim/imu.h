// InvenSense MPU-6000 gyroscope and accelerometer, as the APM 2.5 runs it: 1 kHz internal sampling, the
// 20 Hz digital low-pass filter, +-2000 deg/s and +-8 g ranges, 16-bit outputs.
//
// Measurement model (thesis eqs. 7.1 and 7.3, with a drifting bias): reading = truth + b + eta, where
// b = turn-on bias + random walk, eta = white noise, plus optional vibration noise proportional to the
// mean rotor speed; then range clipping (the ADC), the DLPF and quantisation of the output registers.
// The noise defaults are the RotorS / PX4 Gazebo IMU plugin's figures (modelled on the ADIS16448), more
// pessimistic than the MPU-6000 data sheet (0.005 deg/s/sqrt(Hz), 400 ug/sqrt(Hz)).
#pragma once

#include <Eigen/Core>

#include "quad/sim/rng.h"

namespace quad::sim {

struct ImuAxisParams {
  double noise_density = 0.0;     // white noise, units/sqrt(Hz)
  double bias_random_walk = 0.0;  // bias drift, units/s/sqrt(Hz) = units/sqrt(s)
  double turn_on_bias = 0.0;      // standard deviation of the bias drawn at power-up, units
  double range = 0.0;             // full scale, +-units
  double lsb = 0.0;               // quantisation step, units
  double vibration_at_full_speed = 0.0;  // extra white noise std (units) at full rotor speed
};

struct ImuParams {
  double sample_rate_hz = 1000.0;
  double dlpf_cutoff_hz = 20.0;  // first-order: group delay 1/(2 pi fc) = 8.0 ms (data sheet: 8.3 ms)
  ImuAxisParams gyro{3.39e-4, 3.88e-5, 0.5 * 3.14159265358979323846 / 180.0,
                     2000.0 * 3.14159265358979323846 / 180.0,
                     3.14159265358979323846 / 180.0 / 16.4, 0.0};
  ImuAxisParams accel{4.0e-3, 6.0e-3, 0.196, 8.0 * 9.80665, 9.80665 / 4096.0, 0.0};
};

struct ImuReading {
  Eigen::Vector3d specific_force_frd;  // m/s^2, (0, 0, -g) level at rest
  Eigen::Vector3d rate_frd;            // rad/s
};

class Mpu6000 {
 public:
  Mpu6000(const ImuParams& params, Rng rng);

  // One internal sample (call at sample_rate_hz) from the true specific force and body rate in FRD;
  // `vibration` is the mean rotor speed over the maximum, in [0, 1].
  ImuReading sample(const Eigen::Vector3d& true_specific_force_frd, const Eigen::Vector3d& true_rate_frd,
                    double vibration = 0.0);

  // The bias state (turn-on bias plus random walk plus any injected step), for tests and the log.
  Eigen::Vector3d gyro_bias() const { return gyro_bias_ + gyro_bias_step_; }
  Eigen::Vector3d accel_bias() const { return accel_bias_; }
  // Fault injection: an extra gyro bias (a step when set, removed by setting zero).
  void set_gyro_bias_step(const Eigen::Vector3d& step) { gyro_bias_step_ = step; }
  const ImuParams& params() const { return p_; }

 private:
  Eigen::Vector3d corrupt(const Eigen::Vector3d& truth, Eigen::Vector3d& bias, const ImuAxisParams& axis,
                          double vibration);
  Eigen::Vector3d finish(const Eigen::Vector3d& filtered, const ImuAxisParams& axis) const;

  ImuParams p_;
  Rng rng_;
  double dt_;
  double dlpf_alpha_;
  bool primed_ = false;
  Eigen::Vector3d gyro_bias_, accel_bias_, gyro_bias_step_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_filtered_ = Eigen::Vector3d::Zero(), accel_filtered_ = Eigen::Vector3d::Zero();
};

}  // namespace quad::sim
