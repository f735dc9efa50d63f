// The EKF (seed 004 sec. 3.1, error-state form) against an independent double-precision reference:
// the prediction's error-state Jacobian against numeric differentiation of an Eigen model of the
// nominal equations, the block-structured covariance propagation against a dense F P F^T + Q in double,
// convergence on a simulated hover with delayed fixes (position and attitude), and consistency (NEES)
// over Monte Carlo runs.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "attitude_sim.h"
#include "eigen_oracle.h"
#include "quad/estimation/delayed_ekf.h"
#include "quad/estimation/ekf.h"
#include "quad/estimation/position_filter.h"

namespace {

using quad::Quat;
using quad::Vec3;
using quad::est::DelayedEkf;
using quad::est::EkfParams;
using quad::est::EkfState;
using quad::est::ErrorStateEkf;
using quad::est::StarFix;
using quad_test::from_eigen;
using quad_test::to_eigen;

constexpr int kN = quad::est::kEkfErrorStates;
constexpr double kG = 9.80665;
using MatN = Eigen::Matrix<double, kN, kN>;
using VecN = Eigen::Matrix<double, kN, 1>;

// ---- Independent model (double): the nominal equations, written from seed 004 eq. 3.6-3.11 with the
// errata, exact exponential, and the error-state difference used for numeric differentiation.
struct State {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero(), v = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg = Eigen::Vector3d::Zero(), ba = Eigen::Vector3d::Zero();
  Eigen::Vector2d sb = Eigen::Vector2d::Zero();  // the station's tilt bias, body x, y
};

Eigen::Quaterniond exp_q(const Eigen::Vector3d& rv) {
  const double a = rv.norm();
  if (a < 1e-15) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(a, rv / a));
}

Eigen::Vector3d log_q(const Eigen::Quaterniond& q) {
  Eigen::AngleAxisd aa(q.w() < 0 ? Eigen::Quaterniond(-q.coeffs()) : q);
  return aa.angle() * aa.axis();
}

State propagate(State x, const Eigen::Vector3d& dtheta, const Eigen::Vector3d& dvel, double dt) {
  const Eigen::Matrix3d r = x.q.toRotationMatrix();
  const Eigen::Vector3d dv = r * (dvel - x.ba * dt) + Eigen::Vector3d(0, 0, kG * dt);
  x.p += x.v * dt + 0.5 * dt * dv;
  x.v += dv;
  x.q = (x.q * exp_q(dtheta - x.bg * dt)).normalized();
  return x;
}

State inject(State x, const VecN& d) {
  x.q = (x.q * exp_q(d.segment<3>(0))).normalized();
  x.p += d.segment<3>(3);
  x.v += d.segment<3>(6);
  x.bg += d.segment<3>(9);
  x.ba += d.segment<3>(12);
  x.sb += d.segment<2>(15);
  return x;
}

VecN difference(const State& a, const State& b) {  // a - b in the error state
  VecN d;
  d.segment<3>(0) = log_q(b.q.conjugate() * a.q);
  d.segment<3>(3) = a.p - b.p;
  d.segment<3>(6) = a.v - b.v;
  d.segment<3>(9) = a.bg - b.bg;
  d.segment<3>(12) = a.ba - b.ba;
  d.segment<2>(15) = a.sb - b.sb;
  return d;
}

MatN numeric_jacobian(const State& x, const Eigen::Vector3d& dth, const Eigen::Vector3d& dv, double dt) {
  MatN f;
  const double eps = 1e-6;
  for (int k = 0; k < kN; ++k) {
    VecN e = VecN::Zero();
    e[k] = eps;
    f.col(k) = (difference(propagate(inject(x, e), dth, dv, dt), propagate(inject(x, -e), dth, dv, dt))) / (2 * eps);
  }
  return f;
}

EkfState to_core(const State& x) {
  EkfState s;
  s.q = from_eigen(x.q);
  s.p = from_eigen(x.p);
  s.v = from_eigen(x.v);
  s.gyro_bias = from_eigen(x.bg);
  s.accel_bias = from_eigen(x.ba);
  s.star_bias = Vec3{static_cast<float>(x.sb.x()), static_cast<float>(x.sb.y()), 0.0f};
  return s;
}

State random_state(std::mt19937& rng) {
  State x;
  x.q = quad_test::random_rotation(rng);
  x.p = quad_test::random_vector(rng, 2.0);
  x.v = quad_test::random_vector(rng, 1.0);
  x.bg = quad_test::random_vector(rng, 0.02);
  x.ba = quad_test::random_vector(rng, 0.2);
  x.sb = quad_test::random_vector(rng, 0.003).head<2>();
  return x;
}

TEST(Ekf, PredictionJacobianMatchesNumericDifferentiation) {
  std::mt19937 rng(7);
  double worst = 0.0;
  for (int trial = 0; trial < 50; ++trial) {
    const State x = random_state(rng);
    const double dt = 0.01;
    const Eigen::Vector3d dth = quad_test::random_vector(rng, 2.0) * dt;
    const Eigen::Vector3d dv = (Eigen::Vector3d(0, 0, -kG) + quad_test::random_vector(rng, 3.0)) * dt;
    const MatN numeric = numeric_jacobian(x, dth, dv, dt);
    float f[kN][kN];
    ErrorStateEkf::transition(to_core(x), from_eigen(dth), from_eigen(dv), static_cast<float>(dt), f);
    for (int i = 0; i < kN; ++i)
      for (int j = 0; j < kN; ++j) worst = std::max(worst, std::abs(numeric(i, j) - f[i][j]));
  }
  std::cout << "[figure] EKF transition vs numeric Jacobian (50 random states, 10 ms): worst entry error " << worst
            << "\n";
  // The core's F is first order in the step's rotation (dtheta^2 terms of ~4e-4 neglected) and float.
  EXPECT_LT(worst, 5e-4);
}

TEST(Ekf, CovariancePropagationEqualsDenseDoubleProduct) {
  std::mt19937 rng(11);
  double worst_relative = 0.0;
  for (int trial = 0; trial < 20; ++trial) {
    const State x = random_state(rng);
    Eigen::Matrix<double, kN, kN> a = Eigen::Matrix<double, kN, kN>::Random() * 0.1;
    MatN p0 = a * a.transpose() + MatN::Identity() * 1e-3;
    ErrorStateEkf ekf;
    EkfParams params;
    ekf.set_params(params);
    ekf.reset(from_eigen(x.q), from_eigen(x.p), from_eigen(x.v), from_eigen(x.bg), from_eigen(x.ba));
    ekf.mutable_state() = to_core(x);
    MatN p_float_in;
    for (int i = 0; i < kN; ++i)
      for (int j = i; j < kN; ++j) {
        ekf.set_covariance(i, j, static_cast<float>(p0(i, j)));
        p_float_in(i, j) = p_float_in(j, i) = ekf.covariance(i, j);
      }
    const double dt = 0.01;
    const Eigen::Vector3d dth = quad_test::random_vector(rng, 1.0) * dt;
    const Eigen::Vector3d dv = (Eigen::Vector3d(0, 0, -kG) + quad_test::random_vector(rng, 2.0)) * dt;
    ekf.predict(from_eigen(dth), from_eigen(dv), static_cast<float>(dt));
    const MatN f = numeric_jacobian(x, dth, dv, dt);
    VecN q = VecN::Zero();
    const double qs[4] = {params.gyro_noise, params.accel_noise, params.gyro_bias_walk, params.accel_bias_walk};
    const int off[4] = {0, 6, 9, 12};
    for (int b = 0; b < 4; ++b) q.segment<3>(off[b]).setConstant(qs[b] * qs[b] * dt);
    q.segment<2>(15).setConstant(params.star_bias_walk * params.star_bias_walk * dt);
    const MatN expected = f * p_float_in * f.transpose() + MatN(q.asDiagonal());
    for (int i = 0; i < kN; ++i)
      for (int j = 0; j < kN; ++j) {
        const double scale = std::sqrt(expected(i, i) * expected(j, j));
        worst_relative = std::max(worst_relative, std::abs(ekf.covariance(i, j) - expected(i, j)) / scale);
      }
  }
  std::cout << "[figure] EKF covariance prediction vs dense double F P F^T + Q: worst error / sqrt(P_ii P_jj) "
            << worst_relative << "\n";
  EXPECT_LT(worst_relative, 1e-3);
}

// The star's attitude update (EST_STAR_ATT 2) against the Kalman update written in double from the
// error-state definition with the station's tilt bias b_s: q_meas = q exp(b_s / 2), residual
// log(q_hat* q_meas) - b_s, H = (I, 0, 0, 0, 0, E), K = P H^T S^-1, dx = K nu, P - K S K^T,
// q <- q_hat exp(dtheta / 2).
TEST(Ekf, StarAttitudeUpdateEqualsDoubleKalmanUpdate) {
  std::mt19937 rng(23);
  double worst_state = 0.0, worst_angle = 0.0, worst_cov = 0.0;
  for (int trial = 0; trial < 50; ++trial) {
    const State x = random_state(rng);
    Eigen::Matrix<double, kN, kN> a = Eigen::Matrix<double, kN, kN>::Random() * 0.01;
    const MatN p0 = a * a.transpose() + MatN::Identity() * 1e-5;
    Eigen::Matrix3d b = Eigen::Matrix3d::Random() * 0.003;
    const Eigen::Matrix3d r_att = b * b.transpose() + Eigen::Matrix3d::Identity() * 1e-6;
    const Eigen::Quaterniond q_meas = x.q * exp_q(quad_test::random_vector(rng, 0.01));

    EkfParams params;
    params.star_attitude = quad::est::StarAttitudeUse::kFull;
    params.attitude_sigma_floor = 0.0f;  // the noise is exactly the fix's covariance
    ErrorStateEkf ekf;
    ekf.set_params(params);
    ekf.reset(from_eigen(x.q), from_eigen(x.p), from_eigen(x.v), from_eigen(x.bg), from_eigen(x.ba));
    ekf.mutable_state() = to_core(x);
    MatN p_in;
    for (int i = 0; i < kN; ++i)
      for (int j = i; j < kN; ++j) {
        ekf.set_covariance(i, j, static_cast<float>(p0(i, j)));
        p_in(i, j) = p_in(j, i) = ekf.covariance(i, j);
      }
    StarFix fix;
    fix.star_body = Vec3{NAN, NAN, NAN};  // the attitude group alone
    fix.q_bs = from_eigen(q_meas.conjugate());
    fix.has_attitude = true;
    fix.has_covariance = true;
    const int upper[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
    for (int k = 0; k < 6; ++k) fix.att_cov[k] = static_cast<float>(r_att(upper[k][0], upper[k][1]));
    quad::est::EkfFuse result = quad::est::EkfFuse::kRejectedInvalid;
    ekf.fuse_star(fix, nullptr, &result);
    ASSERT_EQ(result, quad::est::EkfFuse::kFused);

    Eigen::Matrix<double, 3, kN> h = Eigen::Matrix<double, 3, kN>::Zero();
    h.leftCols<3>().setIdentity();
    h(0, 15) = h(1, 16) = 1.0;
    Eigen::Matrix3d r_used;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r_used(i, j) = static_cast<float>(r_att(std::min(i, j), std::max(i, j)));
    const Eigen::Matrix3d s = h * p_in * h.transpose() + r_used;
    const Eigen::Matrix<double, kN, 3> k = p_in * h.transpose() * s.inverse();
    const VecN dx = k * (log_q(x.q.conjugate() * q_meas) - Eigen::Vector3d(x.sb.x(), x.sb.y(), 0.0));
    const State expected = inject(x, dx);
    const MatN p_expected = p_in - k * s * k.transpose();

    const EkfState& got = ekf.state();
    worst_angle = std::max(worst_angle, log_q(expected.q.conjugate() * to_eigen(got.q)).norm() / dx.head<3>().norm());
    const Eigen::Vector3d rest[5][2] = {{to_eigen(got.p), expected.p},
                                        {to_eigen(got.v), expected.v},
                                        {to_eigen(got.gyro_bias), expected.bg},
                                        {to_eigen(got.accel_bias), expected.ba},
                                        {to_eigen(got.star_bias), Eigen::Vector3d(expected.sb.x(), expected.sb.y(), 0.0)}};
    for (int blk = 0; blk < 5; ++blk) {
      const double size = blk < 4 ? dx.segment<3>(3 + 3 * blk).norm() : dx.segment<2>(15).norm();
      worst_state = std::max(worst_state, (rest[blk][0] - rest[blk][1]).norm() / size);
    }
    for (int i = 0; i < kN; ++i)
      for (int j = 0; j < kN; ++j) {
        const double scale = std::sqrt(p_in(i, i) * p_in(j, j));
        worst_cov = std::max(worst_cov, std::abs(ekf.covariance(i, j) - p_expected(i, j)) / scale);
      }
  }
  std::cout << "[figure] EKF star attitude update vs double Kalman update (50 random states): attitude "
            << worst_angle << ", other states " << worst_state << " of the correction; covariance "
            << worst_cov << " of sqrt(P_ii P_jj)\n";
  EXPECT_LT(worst_angle, 1e-3);
  EXPECT_LT(worst_state, 1e-3);
  EXPECT_LT(worst_cov, 1e-4);
}

// ---- Simulated hover (double truth): gentle motion about (0, 0, -1.5) m, IMU at 400 Hz with white noise
// and random-walk biases of the filter's own model, star fixes at 30 Hz captured 30-60 ms before they
// arrive (position 2 mm, attitude 0.2 deg), the filter 100 ms behind.
struct HoverRun {
  double pos_rms_mm = 0.0, tilt_rms_deg = 0.0, yaw_rms_deg = 0.0;
  Eigen::Vector2d roll_pitch_mean_deg = Eigen::Vector2d::Zero();  // estimate minus truth, last 10 s
  double nees_sum = 0.0;
  int nees_count = 0;
  Eigen::Vector3d bg_error, ba_error;
  uint32_t fused = 0, rejected = 0;
};

// still_hover: a multirotor hovering still (level, turning slowly about down, no acceleration: its
// specific force is thrust alone, along body z), the filter told so (predict's hovering flag).
// star_tilt_bias: the fixes' attitude turned by this about body x, y (rad) besides their noise.
HoverRun fly_hover(unsigned seed, double seconds, bool with_attitude, const EkfParams& params, bool still_hover = false,
                   const Eigen::Vector2d& star_tilt_bias = Eigen::Vector2d::Zero()) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  auto nvec = [&](double s) -> Eigen::Vector3d { return Eigen::Vector3d(n01(rng), n01(rng), n01(rng)) * s; };
  const double dt = 1.0 / 400.0;
  State truth;
  truth.p = Eigen::Vector3d(0.1, -0.05, -1.5);
  truth.q = exp_q(Eigen::Vector3d(still_hover ? 0.0 : 0.01, still_hover ? 0.0 : -0.02, 0.3));
  truth.bg = Eigen::Vector3d(0.008, -0.006, 0.004);
  truth.ba = Eigen::Vector3d(0.08, -0.05, 0.1);
  DelayedEkf<quad::est::history_length(100)> ekf;
  // Without the star's attitude the heading comes from the magnetometer (a body-frame fix alone turns
  // the position about the star with the heading error).
  EkfParams with_field = params;
  with_field.mag_ref_ned = from_eigen(quad_test::reference_field());
  ekf.set_params(with_field, 0.1f, !with_attitude, still_hover);
  // Initial errors: 2 deg of tilt, 10 deg of heading; the biases unknown.
  const Eigen::Quaterniond q0 = truth.q * exp_q(Eigen::Vector3d(0.025, -0.022, 0.17));
  uint32_t t_us = 1000000;
  ekf.reset(from_eigen(q0), Vec3{}, Vec3{}, t_us);
  struct Pending {
    uint32_t arrive_us;
    StarFix fix;
  };
  std::vector<Pending> pending;
  std::vector<std::pair<uint32_t, State>> history;
  const Eigen::Vector3d star(0, 0, 0);
  HoverRun run;
  double pos_sq = 0, tilt_sq = 0, yaw_sq = 0;
  int samples = 0;
  const int steps = static_cast<int>(seconds / dt);
  for (int k = 0; k < steps; ++k) {
    const double t = k * dt;
    const double sway = still_hover ? 0.0 : 1.0;
    const Eigen::Vector3d w(sway * 0.2 * std::sin(0.9 * t), sway * 0.15 * std::cos(0.7 * t), 0.1 * std::sin(0.3 * t));
    // v = (0.3 sin 0.8t, 0.25 sin 0.6t, 0.2 sin 1.1t): within half a metre of the start.
    const Eigen::Vector3d a_i =
        sway * Eigen::Vector3d(0.24 * std::cos(0.8 * t), 0.15 * std::cos(0.6 * t), 0.22 * std::cos(1.1 * t));
    const Eigen::Matrix3d r = truth.q.toRotationMatrix();
    const Eigen::Vector3d gyro = w + truth.bg + nvec(params.gyro_noise / std::sqrt(dt));
    const Eigen::Vector3d accel =
        r.transpose() * (a_i - Eigen::Vector3d(0, 0, kG)) + truth.ba + nvec(params.accel_noise / std::sqrt(dt));
    truth.p += truth.v * dt + 0.5 * a_i * dt * dt;
    truth.v += a_i * dt;
    truth.q = (truth.q * exp_q(w * dt)).normalized();
    truth.bg += nvec(params.gyro_bias_walk * std::sqrt(dt));
    truth.ba += nvec(params.accel_bias_walk * std::sqrt(dt));
    t_us += 2500;
    ekf.imu(from_eigen(gyro), from_eigen(accel), static_cast<float>(dt));
    if (k % 5 == 0) {  // 80 Hz magnetometer, 0.4 % noise
      const Eigen::Vector3d m = truth.q.toRotationMatrix().transpose() * quad_test::reference_field() + nvec(0.004);
      ekf.mag(from_eigen(m));
    }
    if (k % 4 == 3) {
      history.emplace_back(t_us, truth);
      ekf.predict(t_us, false, still_hover);
      // NEES of the filter's (delayed) state against the truth at its time, after 5 s.
      if (t > 5.0) {
        for (auto it = history.rbegin(); it != history.rend(); ++it) {
          if (it->first != ekf.filter_time_us()) continue;
          const EkfState& s = ekf.delayed_state();
          State est;
          est.q = to_eigen(s.q);
          est.p = to_eigen(s.p);
          est.v = to_eigen(s.v);
          est.bg = to_eigen(s.gyro_bias);
          est.ba = to_eigen(s.accel_bias);
          est.sb = to_eigen(s.star_bias).head<2>();
          const VecN e = difference(it->second, est);
          MatN p;
          for (int i = 0; i < kN; ++i)
            for (int j = 0; j < kN; ++j) p(i, j) = ekf.filter().covariance(i, j);
          run.nees_sum += e.dot(p.ldlt().solve(e));
          ++run.nees_count;
          break;
        }
      }
    }
    if (k % 13 == 6) {  // ~30 Hz capture
      StarFix f;
      f.capture_us = t_us;
      f.star_body = from_eigen(Eigen::Vector3d(truth.q.toRotationMatrix().transpose() * (star - truth.p) + nvec(0.002)));
      const Eigen::Quaterniond q_meas =
          truth.q * exp_q(Eigen::Vector3d(star_tilt_bias.x(), star_tilt_bias.y(), 0.0)) * exp_q(nvec(0.2 * M_PI / 180));
      f.q_bs = from_eigen(q_meas.conjugate());
      f.has_attitude = with_attitude;
      f.has_covariance = true;
      const double pv = 0.002 * 0.002, av = std::pow(0.2 * M_PI / 180, 2);
      const float pc[6] = {float(pv), 0, 0, float(pv), 0, float(pv)};
      const float ac[6] = {float(av), 0, 0, float(av), 0, float(av)};
      for (int i = 0; i < 6; ++i) {
        f.pos_cov[i] = pc[i];
        f.att_cov[i] = ac[i];
      }
      pending.push_back({t_us + 30000 + static_cast<uint32_t>(rng() % 30000), f});
    }
    for (auto it = pending.begin(); it != pending.end();) {
      if (static_cast<int32_t>(t_us - it->arrive_us) >= 0) {
        ekf.queue_fix(it->fix);
        it = pending.erase(it);
      } else {
        ++it;
      }
    }
    if (t > seconds - 10.0) {
      pos_sq += (to_eigen(ekf.position()) - truth.p).squaredNorm();
      tilt_sq += std::pow(quad_test::tilt_error(truth.q, to_eigen(ekf.attitude())), 2);
      const Eigen::Vector3d eul_t = quad_test::euler_of(truth.q), eul_e = quad_test::euler_of(to_eigen(ekf.attitude()));
      run.roll_pitch_mean_deg += (eul_e - eul_t).head<2>();
      yaw_sq += std::pow(quad_test::wrap(eul_t.z() - eul_e.z()), 2);
      ++samples;
    }
  }
  run.pos_rms_mm = 1e3 * std::sqrt(pos_sq / samples);
  run.tilt_rms_deg = std::sqrt(tilt_sq / samples) * 180 / M_PI;
  run.yaw_rms_deg = std::sqrt(yaw_sq / samples) * 180 / M_PI;
  run.roll_pitch_mean_deg *= 180 / M_PI / samples;
  run.bg_error = to_eigen(ekf.delayed_state().gyro_bias) - truth.bg;
  run.ba_error = to_eigen(ekf.delayed_state().accel_bias) - truth.ba;
  run.fused = ekf.health().positions_fused;
  run.rejected = ekf.health().positions_rejected;
  return run;
}

TEST(Ekf, ConvergesOnASimulatedHoverWithDelayedFixes) {
  EkfParams params;
  params.star_attitude = quad::est::StarAttitudeUse::kFull;  // the fixes' attitude is unbiased here
  for (bool with_attitude : {true, false}) {
    const HoverRun run = fly_hover(3, 40.0, with_attitude, params);
    std::cout << "[figure] EKF hover, 40 s, fixes 30-60 ms late" << (with_attitude ? " with" : " without")
              << " attitude (" << (with_attitude ? "no magnetometer" : "magnetometer heading") << "), last 10 s: position RMS " << run.pos_rms_mm << " mm, tilt RMS " << run.tilt_rms_deg
              << " deg, yaw RMS " << run.yaw_rms_deg << " deg; bias errors gyro " << run.bg_error.norm()
              << " rad/s, accel " << run.ba_error.norm() << " m/s^2; " << run.fused << " fused, " << run.rejected
              << " rejected\n";
    // The accelerometer's noise here is the filter's default density, 0.03 m/s^2/sqrt(Hz) (0.6 m/s^2 per
    // 400 Hz sample: flight vibration), so a few millimetres is what a consistent filter holds (NEES below).
    EXPECT_LT(run.pos_rms_mm, with_attitude ? 8.0 : 15.0);
    EXPECT_EQ(run.rejected, 0u);
    EXPECT_LT(run.yaw_rms_deg, 0.5);
    // With the attitude the star's tilt is not an absolute reference (its bias states, prior 0.5 deg):
    // the tilt comes from the accelerometer and the motion, the star's tilt steadies it. The accelerometer
    // bias rests on the same motion: 0.032 m/s^2 after 40 s (0.026 with a 0.2 deg prior).
    EXPECT_LT(run.tilt_rms_deg, with_attitude ? 0.2 : 0.4);
    if (with_attitude) {
      EXPECT_LT(run.yaw_rms_deg, 0.15);
      EXPECT_LT(run.bg_error.norm(), 1e-3);
      EXPECT_LT(run.ba_error.norm(), 0.04);
    }
  }
}

// With the star's heading only (EST_STAR_ATT 1), tilt and the accelerometer's horizontal bias are one
// unknown in a still hover; the hovering specific force (EST_ABIAS_TAU > 0) tells them apart.
TEST(Ekf, HoverForceSeparatesTiltFromAccelerometerBias) {
  EkfParams params;
  params.star_attitude = quad::est::StarAttitudeUse::kHeading;
  const HoverRun with_force = fly_hover(5, 40.0, true, params, true);
  EkfParams no_force = params;
  no_force.hover_force_sigma = 1e3f;  // the same run with the measurement carrying no information
  const HoverRun without = fly_hover(5, 40.0, true, no_force, true);
  for (const HoverRun* run : {&with_force, &without}) {
    std::cout << "[figure] EKF still hover, 40 s, star heading only, hovering force "
              << (run == &with_force ? "fused" : "not fused") << ", last 10 s: position RMS " << run->pos_rms_mm
              << " mm, tilt RMS " << run->tilt_rms_deg << " deg, accel bias error (x, y) "
              << run->ba_error.head<2>().norm() << " m/s^2\n";
  }
  // The truth's horizontal bias, (0.08, -0.05) m/s^2, is 0.55 deg of tilt when taken for one. The tilt
  // that remains is the test accelerometer's noise (0.03 m/s^2/sqrt(Hz), flight vibration).
  EXPECT_LT(with_force.ba_error.head<2>().norm(), 0.015);
  EXPECT_GT(without.ba_error.head<2>().norm(), 0.05);
  EXPECT_LT(with_force.tilt_rms_deg, 0.35);
  EXPECT_GT(without.tilt_rms_deg, 1.4 * with_force.tilt_rms_deg);
}

// The station's tilt biased by (0.08, -0.07) deg (its stereo calibration in flight_plain.yaml): with the
// bias states the hovering specific force holds the tilt and the star's tilt adds its short-term
// information; without them (prior and walk 0) the tilt follows the star's bias.
TEST(Ekf, StarTiltBiasStatesKeepTheStationsBiasOutOfTheTilt) {
  const Eigen::Vector2d bias = Eigen::Vector2d(0.08, -0.07) * M_PI / 180;
  EkfParams params;
  params.star_attitude = quad::est::StarAttitudeUse::kFull;
  EkfParams no_states = params;
  no_states.star_bias_sigma0 = 0.0f;
  no_states.star_bias_walk = 0.0f;
  const HoverRun with_states = fly_hover(9, 60.0, true, params, true, bias);
  const HoverRun without = fly_hover(9, 60.0, true, no_states, true, bias);
  for (const HoverRun* run : {&with_states, &without}) {
    std::cout << "[figure] EKF still hover, 60 s, star tilt biased (0.08, -0.07) deg, bias states "
              << (run == &with_states ? "on" : "off") << ", last 10 s: roll, pitch error mean ("
              << run->roll_pitch_mean_deg.x() << ", " << run->roll_pitch_mean_deg.y() << ") deg, tilt RMS "
              << run->tilt_rms_deg << " deg, position RMS " << run->pos_rms_mm << " mm\n";
  }
  EXPECT_GT(without.roll_pitch_mean_deg.norm(), 0.07);
  EXPECT_LT(with_states.roll_pitch_mean_deg.norm(), 0.6 * without.roll_pitch_mean_deg.norm());
}

TEST(Ekf, ConsistentOverMonteCarloRuns) {
  EkfParams params;
  params.fix_sigma_floor = 0.0f;  // the truth's noise is exactly what the filter is told
  params.attitude_sigma_floor = 0.0f;
  params.star_attitude = quad::est::StarAttitudeUse::kFull;
  double sum = 0.0;
  int count = 0;
  for (unsigned seed = 100; seed < 120; ++seed) {
    const HoverRun run = fly_hover(seed, 15.0, true, params);
    sum += run.nees_sum;
    count += run.nees_count;
  }
  const double mean = sum / count;
  std::cout << "[figure] EKF NEES, 20 runs x 10 s at 100 Hz (" << kN << " degrees of freedom): mean " << mean << " over "
            << count << " steps\n";
  EXPECT_GT(mean, kN * 0.7);
  EXPECT_LT(mean, kN * 1.3);
}

}  // namespace
