// Calibration: stationary gyro/accelerometer bias with the stillness check (thesis eq. 7.2, 7.4), and
// the magnetometer ellipsoid fit (eq. 7.15-7.18) on synthetic hard- and soft-iron distortion.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>
#include <vector>

#include "attitude_sim.h"
#include "quad/estimation/calibration.h"
#include "quad/estimation/mag_fit.h"

namespace {

using quad::Vec3;
using quad::est::CalibrationStatus;
using quad::est::ImuBias;
using quad::est::StationaryCalibrator;
using namespace quad_test;

const Eigen::Vector3d kGyroBias(0.012, -0.02, 0.007);
const Eigen::Vector3d kAccelBias(0.15, -0.08, 0.25);

// A window of `n` samples at attitude q with body rate `rate(k)`, MPU-6000 noise and the biases above.
template <class Rate>
StationaryCalibrator window(const Eigen::Quaterniond& q, int n, Rate rate, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> z(0.0, 1.0);
  const SensorNoise noise = mpu6000_noise();
  StationaryCalibrator cal;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d g = rate(k) + kGyroBias + noise.gyro * Eigen::Vector3d(z(rng), z(rng), z(rng));
    const Eigen::Vector3d a = -9.80665 * (q.toRotationMatrix().transpose() * Eigen::Vector3d::UnitZ()) + kAccelBias +
                              noise.accel * Eigen::Vector3d(z(rng), z(rng), z(rng));
    cal.add(from_eigen(g), from_eigen(a));
  }
  return cal;
}

const auto still = [](int) -> Eigen::Vector3d { return Eigen::Vector3d::Zero(); };

TEST(StationaryCalibration, RecoversBiasesFromAStillLevelWindow) {
  const StationaryCalibrator cal = window(Eigen::Quaterniond::Identity(), 500, still);
  ImuBias b;
  ASSERT_EQ(cal.result(b), CalibrationStatus::kOk);
  const SensorNoise noise = mpu6000_noise();
  const double gyro_tol = 5 * noise.gyro / std::sqrt(500.0), accel_tol = 5 * noise.accel / std::sqrt(500.0);
  std::cout << "[figure] stationary calibration, 500 samples: gyro bias error "
            << (to_eigen(b.gyro) - kGyroBias).norm() << " rad/s, accelerometer bias error "
            << (to_eigen(b.accel) - kAccelBias).norm() << " m/s^2; window std gyro " << cal.gyro_std() << ", accel "
            << cal.accel_std() << "\n";
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(b.gyro[i], kGyroBias(i), gyro_tol);
    EXPECT_NEAR(b.accel[i], kAccelBias(i), accel_tol);
  }
  // The spread statistic is the noise, not the ~9.8 m/s^2 offset it was accumulated around.
  EXPECT_NEAR(cal.accel_std(), noise.accel, 0.3 * noise.accel);
  EXPECT_NEAR(cal.gyro_std(), noise.gyro, 0.3 * noise.gyro);
}

TEST(StationaryCalibration, RefusesWindowsThatAreNotStillOrLevel) {
  ImuBias b;
  // Picked up and put down: a 0.5 s wobble in the middle of the window.
  const auto wobble = [](int k) -> Eigen::Vector3d {
    return (k > 200 && k < 250 ? 0.3 * std::sin(0.2 * k) : 0.0) * Eigen::Vector3d(1, 0.5, 0).eval();
  };
  EXPECT_EQ(window(Eigen::Quaterniond::Identity(), 500, wobble).result(b), CalibrationStatus::kMoved);
  // Turning steadily on a turntable: small spread, but the mean is a rate, not a bias.
  const auto turning = [](int) -> Eigen::Vector3d { return {0, 0, 0.5}; };
  EXPECT_EQ(window(Eigen::Quaterniond::Identity(), 500, turning).result(b), CalibrationStatus::kTurning);
  // Standing tilted by 15 deg: eq. 7.2 assumes the identity attitude.
  const Eigen::Quaterniond tilted(Eigen::AngleAxisd(15 * M_PI / 180, Eigen::Vector3d::UnitX()));
  EXPECT_EQ(window(tilted, 500, still).result(b), CalibrationStatus::kNotLevel);
  EXPECT_EQ(window(Eigen::Quaterniond::Identity(), 50, still).result(b), CalibrationStatus::kTooFewSamples);
  StationaryCalibrator cal = window(Eigen::Quaterniond::Identity(), 500, still);
  cal.add(Vec3{std::nanf(""), 0, 0}, Vec3{0, 0, -9.8f});
  EXPECT_EQ(cal.result(b), CalibrationStatus::kNonFinite);
  cal.reset();
  EXPECT_EQ(cal.samples(), 0u);
}

// Raw magnetometer samples m = D R^T m_I + b + noise over `n` attitudes drawn by `attitude`.
template <class Attitude>
std::vector<Eigen::Vector3d> mag_samples(const Eigen::Matrix3d& d, const Eigen::Vector3d& b, double field_norm, int n,
                                         Attitude attitude, unsigned seed = 2) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> z(0.0, 1.0);
  const Eigen::Vector3d m_i = field_norm * reference_field();
  std::vector<Eigen::Vector3d> out;
  for (int k = 0; k < n; ++k) {
    const Eigen::Matrix3d r = attitude(rng, k).toRotationMatrix();
    out.push_back(d * r.transpose() * m_i + b + 0.002 * Eigen::Vector3d(z(rng), z(rng), z(rng)));
  }
  return out;
}

Eigen::Matrix3d soft_iron() {
  Eigen::Matrix3d d;  // scale errors, misalignment and cross-coupling (not symmetric)
  d << 1.12, 0.05, -0.03, -0.02, 0.91, 0.06, 0.04, 0.08, 1.05;
  return d;
}

TEST(MagnetometerFit, RecoversHardAndSoftIron) {
  const double field = 0.5;  // gauss
  const Eigen::Vector3d offset(0.21, -0.13, 0.34);
  const auto any = [](std::mt19937& rng, int) { return random_rotation(rng); };
  const auto raw = mag_samples(soft_iron(), offset, field, 600, any);
  quad::est::MagFitOptions opt;
  opt.field_norm = field;
  const quad::est::MagFitResult r = quad::est::fit_magnetometer(raw, opt);
  ASSERT_TRUE(r.ok) << r.message;
  const double offset_error = (r.offset - offset).norm();
  // W D must be a rotation: |W (m - b)| = |m_I| for every attitude. (The symmetric W leaves the
  // rotation part of D unresolved, which a heading reference cannot see anyway.)
  const Eigen::Matrix3d wd = r.soft_iron * soft_iron();
  const double orthogonality = (wd.transpose() * wd - Eigen::Matrix3d::Identity()).norm();
  std::cout << "[figure] magnetometer fit, 600 samples, 2 mG noise on a 0.5 G field: offset error " << offset_error
            << " G (" << 100 * offset_error / field << " % of the field), |(WD)^T WD - I| " << orthogonality
            << ", residual RMS " << r.residual_rms << ", coverage " << r.coverage << ", condition " << r.condition
            << "\n";
  EXPECT_LT(offset_error, 0.01 * field);
  EXPECT_LT(orthogonality, 0.02);
  EXPECT_LT(r.residual_rms, 0.01);
  EXPECT_GT(r.coverage, 0.2);
  // Applied in the core (float): corrected samples have the field's norm.
  double worst = 0.0;
  for (const auto& m : raw) worst = std::max(worst, std::abs(quad::norm(r.calibration.apply(from_eigen(m))) - field));
  EXPECT_LT(worst, 0.02 * field);
}

TEST(MagnetometerFit, RefusesPoorCoverage) {
  const double field = 0.5;
  const Eigen::Vector3d offset(0.21, -0.13, 0.34);
  quad::est::MagFitOptions opt;
  opt.field_norm = field;
  // Turning only about the vertical while level: every sample lies on one circle of the ellipsoid.
  const auto yaw_only = [](std::mt19937& rng, int) {
    std::uniform_real_distribution<double> u(-M_PI, M_PI);
    return Eigen::Quaterniond(Eigen::AngleAxisd(u(rng), Eigen::Vector3d::UnitZ()));
  };
  const auto r = quad::est::fit_magnetometer(mag_samples(soft_iron(), offset, field, 600, yaw_only), opt);
  std::cout << "[figure] yaw-only samples: refused = " << !r.ok << " (" << r.message << ")\n";
  EXPECT_FALSE(r.ok);
  // Tilts up to 10 deg only: a band around one circle, still not enough.
  const auto small_tilts = [](std::mt19937& rng, int) {
    std::uniform_real_distribution<double> u(-M_PI, M_PI), t(-0.17, 0.17);
    return Eigen::Quaterniond(Eigen::AngleAxisd(u(rng), Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(t(rng), Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(t(rng), Eigen::Vector3d::UnitX()));
  };
  const auto r2 = quad::est::fit_magnetometer(mag_samples(soft_iron(), offset, field, 600, small_tilts), opt);
  std::cout << "[figure] tilts within 10 deg: refused = " << !r2.ok << ", coverage " << r2.coverage
            << ", offset error " << (r2.offset - offset).norm() / field * 100 << " % of the field (" << r2.message
            << ")\n";
  EXPECT_FALSE(r2.ok);
  // A hand-held calibration that tilts up to 45 deg in every heading is enough.
  const auto moderate = [](std::mt19937& rng, int) {
    std::uniform_real_distribution<double> u(-M_PI, M_PI), t(-0.79, 0.79);
    return Eigen::Quaterniond(Eigen::AngleAxisd(u(rng), Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(t(rng), Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(t(rng), Eigen::Vector3d::UnitX()));
  };
  const auto r3 = quad::est::fit_magnetometer(mag_samples(soft_iron(), offset, field, 600, moderate), opt);
  std::cout << "[figure] tilts within 45 deg: accepted = " << r3.ok << ", coverage " << r3.coverage
            << ", offset error " << (r3.offset - offset).norm() / field * 100 << " % of the field (" << r3.message
            << ")\n";
  EXPECT_TRUE(r3.ok);
  EXPECT_LT((r3.offset - offset).norm(), 0.01 * field);
  EXPECT_FALSE(quad::est::fit_magnetometer(std::vector<Eigen::Vector3d>(20, Eigen::Vector3d(1, 2, 3)), opt).ok);
}

}  // namespace
