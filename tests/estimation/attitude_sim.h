// Synthetic attitude truth and sensors for the estimation tests (double precision, Eigen).
//
// The body turns with a rate held constant over each sample period, so a noise-free gyro sample is the
// exact rate of its interval and the only errors left are the filter's own. Sensors follow the
// project's conventions: accelerometer specific force -g R^T e_z (vehicle turning in place), magnetometer
// R^T m_I, both in FRD.
#pragma once

#include <cmath>
#include <random>

#include "eigen_oracle.h"
#include "quad/math/math.h"

namespace quad_test {

struct SensorNoise {
  double gyro = 0.0;   // rad/s, per-sample standard deviation
  double accel = 0.0;  // m/s^2
  double mag = 0.0;    // fraction of the field norm
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
};

// MPU-6000 (PS-MPU-6000A-00 rev. 3.4): gyro total RMS noise 0.05 deg/s, accelerometer 400 ug/sqrt(Hz)
// over the 50 Hz Nyquist band of a 100 Hz loop; HMC5883L: 2 mG noise floor on a ~0.5 G field.
inline SensorNoise mpu6000_noise() {
  SensorNoise n;
  n.gyro = 0.05 * M_PI / 180.0;
  n.accel = 400e-6 * 9.80665 * std::sqrt(50.0);
  n.mag = 0.002 / 0.5;
  return n;
}

// In-flight levels with vibration (ArduPilot SITL defaults: gyro 0.1 deg/s, accelerometer 0.3 m/s^2).
inline SensorNoise vibration_noise() {
  SensorNoise n = mpu6000_noise();
  n.gyro = 0.1 * M_PI / 180.0;
  n.accel = 0.3;
  return n;
}

// A reference field with 65 deg inclination and 5 deg declination (unit norm).
inline Eigen::Vector3d reference_field() {
  const double inc = 65.0 * M_PI / 180.0, dec = 5.0 * M_PI / 180.0;
  return {std::cos(inc) * std::cos(dec), std::cos(inc) * std::sin(dec), std::sin(inc)};
}

struct Sample {
  quad::Vec3 gyro, accel, mag;
};

class AttitudeSim {
 public:
  AttitudeSim(const Eigen::Quaterniond& q0, bool rotating, unsigned seed, const SensorNoise& noise = {},
              const Eigen::Vector3d& field = reference_field())
      : q_(q0.normalized()), rotating_(rotating), rng_(seed), noise_(noise), field_(field) {}

  // Body rate (FRD, rad/s) of the interval starting at t: a slow tumble about all three axes.
  Eigen::Vector3d rate(double t) const {
    if (!rotating_) return Eigen::Vector3d::Zero();
    return {0.6 * std::sin(0.7 * t), 0.5 * std::cos(0.45 * t + 0.3), 0.4 + 0.2 * std::sin(0.25 * t)};
  }

  // Sensor readings at the current time, with `mag_rotation` applied to the measured field (disturbance).
  Sample sample(const Eigen::Matrix3d& mag_rotation = Eigen::Matrix3d::Identity()) {
    std::normal_distribution<double> n(0.0, 1.0);
    const Eigen::Matrix3d r = q_.toRotationMatrix();
    const Eigen::Vector3d w = rate(t_) + noise_.gyro_bias + noise_.gyro * Eigen::Vector3d(n(rng_), n(rng_), n(rng_));
    const Eigen::Vector3d a =
        -9.80665 * r.transpose() * Eigen::Vector3d::UnitZ() + noise_.accel * Eigen::Vector3d(n(rng_), n(rng_), n(rng_));
    const Eigen::Vector3d m = r.transpose() * (mag_rotation * field_) +
                              noise_.mag * field_.norm() * Eigen::Vector3d(n(rng_), n(rng_), n(rng_));
    return {from_eigen(w), from_eigen(a), from_eigen(m)};
  }

  void step(double dt) {
    const Eigen::Vector3d w = rate(t_);
    const double angle = w.norm() * dt;
    if (angle > 0.0) q_ = (q_ * Eigen::Quaterniond(Eigen::AngleAxisd(angle, w.normalized()))).normalized();
    t_ += dt;
  }

  const Eigen::Quaterniond& q() const { return q_; }
  double t() const { return t_; }
  const Eigen::Vector3d& field() const { return field_; }

 private:
  Eigen::Quaterniond q_;
  bool rotating_;
  std::mt19937 rng_;
  SensorNoise noise_;
  Eigen::Vector3d field_;
  double t_ = 0.0;
};

// Roll, pitch, yaw (ZYX) of an Eigen quaternion, computed independently of the core.
inline Eigen::Vector3d euler_of(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d r = q.toRotationMatrix();
  return {std::atan2(r(2, 1), r(2, 2)), std::asin(std::clamp(-r(2, 0), -1.0, 1.0)), std::atan2(r(1, 0), r(0, 0))};
}

inline double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// Angle between the true and estimated "down" directions (the roll/pitch part of the error), rad.
inline double tilt_error(const Eigen::Quaterniond& truth, const Eigen::Quaterniond& est) {
  const Eigen::Vector3d d_true = truth.toRotationMatrix().transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d d_est = est.toRotationMatrix().transpose() * Eigen::Vector3d::UnitZ();
  return std::atan2(d_true.cross(d_est).norm(), d_true.dot(d_est));
}

}  // namespace quad_test
