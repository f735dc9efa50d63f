// Motor mixing, thesis eq. 5.3-5.8, and the saturation priority (roll/pitch, then thrust, then yaw).
// The oracle is the 4x4 matrix M of eq. 5.5/5.6 built here in double precision from the motor table of
// vehicle.h (angle positions), not from the library.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "eigen_oracle.h"
#include "quad/control/mixer.h"

namespace {

using quad::Vec3;
using quad::ctrl::Frame;
using quad::ctrl::Mixer;
using quad::ctrl::MixerOutput;
using quad::ctrl::VehicleParams;

VehicleParams vehicle(Frame f) {
  VehicleParams v;
  v.frame = f;
  return v;
}

// M of eq. 5.5: (T, tau_1, tau_2, tau_3) = M (w_1^2 .. w_4^2).
Eigen::Matrix4d oracle_m(const VehicleParams& v) {
  const double b = v.thrust_coeff, kappa = v.yaw_coeff, d = v.arm_length;
  Eigen::Matrix4d m;
  for (int i = 0; i < 4; ++i) {
    const double angle = (v.frame == Frame::kX ? -M_PI / 4.0 : 0.0) - i * M_PI / 2.0;
    const double x = d * std::cos(angle), y = d * std::sin(angle), spin = (i % 2 == 0) ? 1.0 : -1.0;
    m.col(i) << b, -y * b, x * b, spin * kappa;
  }
  return m;
}

// Full-scale magnitude of each component: what the motors can produce at most.
Eigen::Vector4d full_scale(const VehicleParams& v) {
  const double f = v.max_motor_thrust;
  return {4.0 * f, v.arm_length * f, v.arm_length * f, 2.0 * f * v.yaw_coeff / v.thrust_coeff};
}

// The squared rotor speeds of eq. 5.7 from the mixer's thrust shares: w_bar_i = n_i f_max / b.
Eigen::Vector4d rotor_speeds_sq(const VehicleParams& v, const MixerOutput& out) {
  Eigen::Vector4d w;
  for (int i = 0; i < 4; ++i) w(i) = static_cast<double>(out.share[i]) * v.max_motor_thrust / v.thrust_coeff;
  return w;
}

Eigen::Vector4d wrench_of(const Eigen::Matrix4d& m, const VehicleParams& v, const MixerOutput& out) {
  return m * rotor_speeds_sq(v, out);
}

TEST(Mixer, PlusMatchesEquation56Exactly) {
  const VehicleParams v = vehicle(Frame::kPlus);
  const double b = v.thrust_coeff, kappa = v.yaw_coeff, d = v.arm_length;
  Eigen::Matrix4d m56;
  m56 << b, b, b, b, 0, d * b, 0, -d * b, d * b, 0, -d * b, 0, kappa, -kappa, kappa, -kappa;  // thesis eq. 5.6
  EXPECT_LT((m56 - oracle_m(v)).norm(), 1e-12);
  // And eq. 5.8 for one demand, entry by entry: w_f^2 = T/(4b) + tau_2/(2db) + tau_3/(4 kappa), ...
  const Mixer mixer(v);
  const double t = 15.0, t1 = 0.3, t2 = -0.2, t3 = 0.05;
  const MixerOutput out = mixer.mix(static_cast<float>(t), Vec3{0.3f, -0.2f, 0.05f});
  const double expected[4] = {t / (4 * b) + t2 / (2 * d * b) + t3 / (4 * kappa), t / (4 * b) + t1 / (2 * d * b) - t3 / (4 * kappa),
                              t / (4 * b) - t2 / (2 * d * b) + t3 / (4 * kappa), t / (4 * b) - t1 / (2 * d * b) - t3 / (4 * kappa)};
  const Eigen::Vector4d w_sq = rotor_speeds_sq(v, out);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(w_sq(i), expected[i], 1e-5 * expected[i]) << i;
  for (int i = 0; i < 4; ++i) EXPECT_FLOAT_EQ(mixer.rotor_speed_sq(out.share[i]), static_cast<float>(w_sq(i))) << i;
}

class MixerFrames : public ::testing::TestWithParam<Frame> {};

// Random feasible demands (made from motor thrusts in 1..99 % of f_max): mixing and the forward model
// reproduce T and tau to 1e-5 relative, without any limit flag; commands are sqrt(f / f_max).
TEST_P(MixerFrames, RoundTrip) {
  const VehicleParams v = vehicle(GetParam());
  const Mixer mixer(v);
  const Eigen::Matrix4d m = oracle_m(v);
  const Eigen::Vector4d fs = full_scale(v);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> share(0.01, 0.99);
  double worst = 0.0, worst_lib_forward = 0.0;
  for (int k = 0; k < 10000; ++k) {
    Eigen::Vector4d w_sq;
    for (int i = 0; i < 4; ++i) w_sq(i) = share(rng) * v.max_motor_thrust / v.thrust_coeff;
    const Eigen::Vector4d demand = m * w_sq;
    const MixerOutput out = mixer.mix(static_cast<float>(demand(0)),
                                      Vec3{float(demand(1)), float(demand(2)), float(demand(3))});
    ASSERT_FALSE(out.yaw_limited || out.thrust_limited || out.roll_pitch_limited) << k << " " << out.yaw_limited << out.thrust_limited << out.roll_pitch_limited << " " << demand.transpose();
    const Eigen::Vector4d got = wrench_of(m, v, out);
    for (int j = 0; j < 4; ++j) {
      // Relative to the component, or to 10 % of its full scale when the component is near zero.
      worst = std::max(worst, std::abs(got(j) - demand(j)) / std::max(std::abs(demand(j)), 0.1 * fs(j)));
    }
    const quad::ctrl::Wrench lib = mixer.forward(out.share);
    const Eigen::Vector4d lib4(lib.thrust, lib.torque.x, lib.torque.y, lib.torque.z);
    worst_lib_forward = std::max(worst_lib_forward, ((lib4 - got).cwiseQuotient(fs)).cwiseAbs().maxCoeff());
    for (int i = 0; i < 4; ++i) {
      ASSERT_GE(out.command[i], 0.0f);
      ASSERT_LE(out.command[i], 1.0f);
      ASSERT_NEAR(out.command[i] * out.command[i] * v.max_motor_thrust, v.thrust_coeff * rotor_speeds_sq(v, out)(i), 1e-4);
    }
  }
  std::printf("[figure] mixer round trip (%s, 10000 demands): max relative error %.2e; library eq. 5.5 vs "
              "oracle %.2e of full scale\n",
              GetParam() == Frame::kX ? "X" : "plus", worst, worst_lib_forward);
  EXPECT_LT(worst, 1e-5);
  EXPECT_LT(worst_lib_forward, 1e-6);
}

// 10 000 random demands, many beyond what the motors can do. Whenever thrust with roll/pitch alone is
// feasible, the mixer keeps them exactly and gives up only yaw: the yaw it keeps has the demanded sign,
// is no larger than demanded, and is the most that fits (some motor sits at 0 or f_max). When even
// roll/pitch cannot be met, their direction is kept.
TEST_P(MixerFrames, SaturationGivesUpYawFirst) {
  const VehicleParams v = vehicle(GetParam());
  const Mixer mixer(v);
  const Eigen::Matrix4d m = oracle_m(v);
  const Eigen::Matrix4d m_inv = m.inverse();
  const Eigen::Vector4d fs = full_scale(v);
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int rp_feasible = 0, yaw_cut = 0, rp_cut = 0;
  double worst_kept = 0.0, worst_reported = 0.0;
  for (int k = 0; k < 10000; ++k) {
    const Eigen::Vector4d demand(fs(0) * 0.5 * (1.0 + u(rng)), 0.8 * fs(1) * u(rng), 0.8 * fs(2) * u(rng),
                                 3.0 * fs(3) * u(rng));
    const MixerOutput out = mixer.mix(static_cast<float>(demand(0)),
                                      Vec3{float(demand(1)), float(demand(2)), float(demand(3))});
    for (int i = 0; i < 4; ++i) ASSERT_TRUE(out.command[i] >= 0.0f && out.command[i] <= 1.0f);
    const Eigen::Vector4d got = wrench_of(m, v, out);
    const Eigen::Vector4d reported(out.achieved.thrust, out.achieved.torque.x, out.achieved.torque.y, out.achieved.torque.z);
    worst_reported = std::max(worst_reported, ((reported - got).cwiseQuotient(fs)).cwiseAbs().maxCoeff());
    // Independent feasibility of thrust + roll/pitch (yaw zero).
    const Eigen::Vector4d f0 = v.thrust_coeff * (m_inv * Eigen::Vector4d(demand(0), demand(1), demand(2), 0.0));
    const bool feasible = f0.minCoeff() >= 0.0 && f0.maxCoeff() <= v.max_motor_thrust;
    if (feasible) {
      ++rp_feasible;
      for (int j = 0; j < 3; ++j) worst_kept = std::max(worst_kept, std::abs(got(j) - demand(j)) / fs(j));
      ASSERT_FALSE(out.thrust_limited || out.roll_pitch_limited) << k;
      ASSERT_GE(got(3) * demand(3), -1e-9) << "yaw changed sign, sample " << k;
      ASSERT_LE(std::abs(got(3)), std::abs(demand(3)) + 1e-6 * fs(3)) << k;
      if (std::abs(got(3)) < std::abs(demand(3)) - 1e-5 * fs(3)) {
        ++yaw_cut;
        ASSERT_TRUE(out.yaw_limited);
        double room = 1.0;
        for (int i = 0; i < 4; ++i) room = std::min({room, double(out.command[i]), 1.0 - double(out.command[i])});
        ASSERT_LT(room, 1e-3) << "yaw was cut although no motor was at a limit, sample " << k;
      }
    } else {
      ++rp_cut;
      const Eigen::Vector2d want(demand(1), demand(2)), have(got(1), got(2));
      ASSERT_NEAR(want.x() * have.y() - want.y() * have.x(), 0.0, 1e-4 * want.squaredNorm()) << k;
      ASSERT_GE(want.dot(have), 0.0) << k;
    }
  }
  std::printf("[figure] mixer saturation (%s, 10000 demands): %d with thrust+roll/pitch feasible (kept to "
              "%.2e of full scale, yaw reduced in %d), %d beyond (roll/pitch direction kept)\n",
              GetParam() == Frame::kX ? "X" : "plus", rp_feasible, worst_kept, yaw_cut, rp_cut);
  EXPECT_LT(worst_kept, 1e-5);
  EXPECT_LT(worst_reported, 1e-5) << "MixerOutput::achieved disagrees with eq. 5.5 of the rotor speeds";
  EXPECT_GT(yaw_cut, 1000);  // the sample really exercised the yaw limit
  EXPECT_GT(rp_cut, 100);
}

INSTANTIATE_TEST_SUITE_P(Frames, MixerFrames, ::testing::Values(Frame::kPlus, Frame::kX),
                         [](const ::testing::TestParamInfo<Frame>& i) { return i.param == Frame::kX ? "X" : "Plus"; });

// The reference allocation: the saturation priority of mixer.h written out in double precision on the
// oracle matrix M (eq. 5.5/5.8), with the textbook form of each step (a division per motor bound, the
// yaw fraction lambda in [0, 1], the roll/pitch scale f_max / spread). The library computes the same
// allocation without divisions, in thrust normalised by f_max and with bit-pattern range checks; this
// catches any desaturation that differs from it.
struct ReferenceAllocation {
  double command[4];
  bool yaw_limited, thrust_limited, roll_pitch_limited;
};

// Largest lambda in [0, 1] with 0 <= base + lambda y <= f_max on every motor; false if none.
bool reference_lambda(const Eigen::Vector4d& base, const Eigen::Vector4d& y, double f_max, double& lambda) {
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 4; ++i) {
    if (y(i) > 0.0) {
      hi = std::min(hi, (f_max - base(i)) / y(i));
      lo = std::max(lo, -base(i) / y(i));
    } else if (y(i) < 0.0) {
      hi = std::min(hi, -base(i) / y(i));
      lo = std::max(lo, (f_max - base(i)) / y(i));
    } else if (base(i) < 0.0 || base(i) > f_max) {
      return false;
    }
  }
  lambda = hi;
  return hi >= lo;
}

ReferenceAllocation reference_mix(const VehicleParams& v, const Eigen::Vector4d& demand) {
  const Eigen::Matrix4d m_inv = oracle_m(v).inverse();
  const double f_max = v.max_motor_thrust, b = v.thrust_coeff;
  const Eigen::Vector4d c = Eigen::Vector4d::Constant(0.25 * demand(0));
  Eigen::Vector4d rp = b * (m_inv * Eigen::Vector4d(0.0, demand(1), demand(2), 0.0));
  const Eigen::Vector4d y = b * (m_inv * Eigen::Vector4d(0.0, 0.0, 0.0, demand(3)));
  ReferenceAllocation r{{0, 0, 0, 0}, false, false, false};
  Eigen::Vector4d f = c + rp + y;
  if (f.minCoeff() < 0.0 || f.maxCoeff() > f_max) {
    double lambda = 1.0;
    if (!reference_lambda(c + rp, y, f_max, lambda)) {
      const double spread = rp.maxCoeff() - rp.minCoeff();
      if (spread > f_max) {
        rp *= f_max / spread;
        r.roll_pitch_limited = true;
      }
      const double collective = std::min(std::max(c(0), -rp.minCoeff()), f_max - rp.maxCoeff());
      r.thrust_limited = collective != c(0);
      if (!reference_lambda(Eigen::Vector4d::Constant(collective) + rp, y, f_max, lambda)) lambda = 0.0;
      f = Eigen::Vector4d::Constant(collective) + rp;
    } else {
      f = c + rp;
    }
    f += lambda * y;
    r.yaw_limited = lambda < 1.0;
  }
  for (int i = 0; i < 4; ++i) r.command[i] = std::sqrt(std::min(std::max(f(i) / f_max, 0.0), 1.0));
  return r;
}

// 40 000 demands per frame, most of them saturating (thrust up to 4 f_max, roll/pitch up to 1.5 times
// full scale, yaw up to 3 times): motor thrusts agree with the reference to float round-off, and the limit
// flags agree except where the demand sits on a decision boundary within round-off (counted; then the
// motor thrusts still agree, the allocation being continuous there).
TEST_P(MixerFrames, DesaturationMatchesTheReferenceAllocation) {
  const VehicleParams v = vehicle(GetParam());
  const Mixer mixer(v);
  const Eigen::Vector4d fs = full_scale(v);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0.0;
  int flag_mismatch = 0, yaw_cut = 0, thrust_cut = 0, rp_cut = 0;
  for (int k = 0; k < 40000; ++k) {
    Eigen::Vector4d demand(fs(0) * 0.5 * (1.0 + u(rng)), 1.5 * fs(1) * u(rng), 1.5 * fs(2) * u(rng), 3.0 * fs(3) * u(rng));
    if (k % 4 == 0) demand(1) = demand(2) = 0.0;  // pure thrust and yaw
    if (k % 4 == 1) demand.tail<3>() *= 0.3;      // mostly feasible
    for (int j = 0; j < 4; ++j) demand(j) = static_cast<float>(demand(j));  // what the library sees
    const MixerOutput out = mixer.mix(static_cast<float>(demand(0)),
                                      Vec3{float(demand(1)), float(demand(2)), float(demand(3))});
    const ReferenceAllocation ref = reference_mix(v, demand);
    // In motor thrust (u^2 f_max, relative to f_max): the square root of the command would magnify the
    // round-off of a motor at idle (sqrt(6e-8) = 2.4e-4).
    for (int i = 0; i < 4; ++i) {
      worst = std::max(worst, std::abs(double(out.command[i]) * out.command[i] - ref.command[i] * ref.command[i]));
    }
    if (out.yaw_limited != ref.yaw_limited || out.thrust_limited != ref.thrust_limited ||
        out.roll_pitch_limited != ref.roll_pitch_limited) {
      ++flag_mismatch;
    }
    yaw_cut += ref.yaw_limited;
    thrust_cut += ref.thrust_limited;
    rp_cut += ref.roll_pitch_limited;
  }
  std::printf("[figure] mixer vs reference allocation (%s, 40000 demands: %d yaw, %d thrust, %d roll/pitch "
              "limited): max motor thrust difference %.2e of f_max, %d flag mismatches\n",
              GetParam() == Frame::kX ? "X" : "plus", yaw_cut, thrust_cut, rp_cut, worst, flag_mismatch);
  EXPECT_LT(worst, 1e-6);
  EXPECT_LE(flag_mismatch, 4);
  EXPECT_GT(yaw_cut, 10000);
  EXPECT_GT(thrust_cut, 2000);
  EXPECT_GT(rp_cut, 2000);
}

// Roll/pitch beyond the motors near idle: thrust is raised (priority 2) rather than the torque cut.
TEST(Mixer, ThrustShiftsBeforeRollPitchIsCut) {
  const VehicleParams v;
  const Mixer mixer(v);
  const float tau = 0.5f * v.arm_length * v.max_motor_thrust;  // needs 0.5 f_max of spread
  const MixerOutput out = mixer.mix(0.0f, Vec3{tau, 0.0f, 0.0f});
  EXPECT_TRUE(out.thrust_limited);
  EXPECT_FALSE(out.roll_pitch_limited);
  EXPECT_NEAR(out.achieved.torque.x, tau, 1e-5f);
  EXPECT_GT(out.achieved.thrust, 0.0f);
}

// The in-place form (what Cascade uses) writes every field: a result struct full of stale values (NaN,
// every flag set) comes out identical to the by-value result, saturated or not.
TEST(Mixer, InPlaceMixWritesEveryField) {
  const Mixer mixer;
  const float thrusts[] = {14.0f, 30.0f, 0.5f, 14.0f, NAN};
  const Vec3 torques[] = {{0.1f, -0.05f, 0.02f}, {0.3f, -0.2f, 0.6f}, {4.0f, -3.0f, 0.6f}, {0.0f, 0.0f, -0.9f}, {}};
  for (int k = 0; k < 5; ++k) {
    MixerOutput dirty;
    for (int i = 0; i < 4; ++i) dirty.share[i] = dirty.command[i] = NAN;
    dirty.achieved.thrust = NAN;
    dirty.achieved.torque = Vec3{NAN, NAN, NAN};
    dirty.yaw_limited = dirty.thrust_limited = dirty.roll_pitch_limited = (k != 4);
    if (k == 4) dirty.yaw_limited = dirty.thrust_limited = dirty.roll_pitch_limited = false;
    mixer.mix(thrusts[k], torques[k], dirty);
    const MixerOutput want = mixer.mix(thrusts[k], torques[k]);
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(dirty.share[i], want.share[i]) << k;
      EXPECT_EQ(dirty.command[i], want.command[i]) << k;
    }
    EXPECT_EQ(dirty.achieved.thrust, want.achieved.thrust) << k;
    EXPECT_EQ(dirty.achieved.torque.x, want.achieved.torque.x) << k;
    EXPECT_EQ(dirty.achieved.torque.y, want.achieved.torque.y) << k;
    EXPECT_EQ(dirty.achieved.torque.z, want.achieved.torque.z) << k;
    EXPECT_EQ(dirty.yaw_limited, want.yaw_limited) << k;
    EXPECT_EQ(dirty.thrust_limited, want.thrust_limited) << k;
    EXPECT_EQ(dirty.roll_pitch_limited, want.roll_pitch_limited) << k;
  }
}

TEST(Mixer, NonFiniteDemandStopsTheMotors) {
  const Mixer mixer;
  const MixerOutput out = mixer.mix(NAN, Vec3{});
  for (int i = 0; i < 4; ++i) EXPECT_EQ(out.command[i], 0.0f);
  EXPECT_TRUE(out.yaw_limited && out.thrust_limited && out.roll_pitch_limited);
}

TEST(Vehicle, LayoutTableAndValidation) {
  // The motor table of vehicle.h, spot-checked: plus front/left/back/right, X front-left first.
  const quad::ctrl::MotorLayout left = quad::ctrl::motor_layout(Frame::kPlus, 0.26f, 1);
  EXPECT_NEAR(left.x, 0.0f, 1e-7f);
  EXPECT_NEAR(left.y, -0.26f, 1e-7f);
  EXPECT_EQ(left.spin, -1.0f);
  const quad::ctrl::MotorLayout front_left = quad::ctrl::motor_layout(Frame::kX, 1.0f, 0);
  EXPECT_NEAR(front_left.x, 0.70710678f, 1e-6f);
  EXPECT_NEAR(front_left.y, -0.70710678f, 1e-6f);
  EXPECT_EQ(front_left.spin, 1.0f);
  VehicleParams v;
  EXPECT_EQ(quad::ctrl::validate(v), nullptr);
  EXPECT_NEAR(v.max_rotor_speed(), 6500.0 * 2.0 * M_PI / 60.0, 1.0);  // the props' 6500 RPM
  v.inertia.y = 0.0f;
  EXPECT_STREQ(quad::ctrl::validate(v), "inertia");
  v = VehicleParams{};
  v.yaw_coeff = NAN;
  EXPECT_STREQ(quad::ctrl::validate(v), "yaw_coeff");
}

}  // namespace
