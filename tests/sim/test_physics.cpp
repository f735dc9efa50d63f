// Physics signs, checked through the one NED/FRD conversion: what the firmware will see.
#include <gtest/gtest.h>

#include <cstdio>

#include <Eigen/Geometry>

#include "quad/control/vehicle.h"
#include "quad/sim/frames.h"
#include "quad/sim/imu.h"
#include "quad/sim/vehicle.h"

namespace quad::sim {
namespace {

constexpr double kG = 9.80665;

VehicleParams quad_c() {
  VehicleParams p;
  p.model_path = QUAD_SIM_SOURCE_DIR "/models/quad_c.xml";
  return p;
}

int index_of(const VehicleParams& p, const std::string& name) {
  for (int i = 0; i < 4; ++i)
    if (p.rotor_order[static_cast<size_t>(i)] == name) return i;
  return -1;
}

// Commands giving each rotor `scale[i]` times the hover thrust m g / 4 (command = speed / max speed).
std::array<double, 4> hover_commands(const Vehicle& v, const std::array<double, 4>& scale) {
  std::array<double, 4> c{};
  for (size_t i = 0; i < 4; ++i)
    c[i] = std::sqrt(scale[i] * v.mass_kg() * kG / 4.0 / v.motor(0).params().max_thrust_n);
  return c;
}

void run(Vehicle& v, double seconds) {
  const int n = static_cast<int>(seconds / v.timestep() + 0.5);
  for (int i = 0; i < n; ++i) v.step();
}

TEST(Frames, ConversionIsTheRotationByPiAboutNorth) {
  const Eigen::Matrix3d T = Eigen::Vector3d(1, -1, -1).asDiagonal();
  for (int k = 0; k < 20; ++k) {
    const Eigen::Quaterniond q_wb = Eigen::Quaterniond::UnitRandom();
    const Eigen::Matrix3d expected = T * q_wb.toRotationMatrix() * T;
    EXPECT_TRUE(world_body_to_q_ib(q_wb).toRotationMatrix().isApprox(expected, 1e-12));
    EXPECT_TRUE(q_ib_to_world_body(world_body_to_q_ib(q_wb)).coeffs().isApprox(q_wb.coeffs(), 1e-15));
  }
  // Up in MuJoCo's world is -z in NED; West is -East.
  EXPECT_TRUE(world_to_ned({0, 0, 1}).isApprox(Eigen::Vector3d(0, 0, -1)));
  EXPECT_TRUE(world_to_ned({0, 1, 0}).isApprox(Eigen::Vector3d(0, -1, 0)));
  // A positive NED yaw turns the nose from North toward East.
  const Eigen::Vector3d nose = q_ib_from_yaw(0.5) * Eigen::Vector3d::UnitX();
  EXPECT_GT(nose.y(), 0.0);
  EXPECT_NEAR(euler_from_q_ib(q_ib_from_yaw(0.5)).z(), 0.5, 1e-12);
}

TEST(Physics, VehicleHasThePlannedMassAndRestsOnItsGear) {
  Vehicle v(quad_c());
  EXPECT_NEAR(v.mass_kg(), 1.40, 1e-9);
  run(v, 1.0);
  const VehicleTruth t = v.truth();
  EXPECT_NEAR(t.position_ned.z(), v.rest_down_m(), 0.005);  // settles on its feet, not through the floor
  EXPECT_LT(t.velocity_ned.norm(), 1e-3);
  // An ideal accelerometer at rest and level reads (0, 0, -g) in FRD.
  std::printf("at rest on the gear: specific force FRD (%.4g, %.4g, %.5f) m/s^2, height error %.2g m\n",
              t.specific_force_frd.x(), t.specific_force_frd.y(), t.specific_force_frd.z(),
              t.position_ned.z() - v.rest_down_m());
  EXPECT_TRUE(t.specific_force_frd.isApprox(Eigen::Vector3d(0, 0, -kG), 1e-3)) << t.specific_force_frd.transpose();
}

TEST(Physics, HoverThrustIsAnEquilibriumAndMoreThrustClimbs) {
  for (double scale : {1.0, 1.05, 0.95}) {
    VehicleParams p = quad_c();
    p.drag_linear_n_per_m_s = 0.0;  // drag would take part of the climb (checked separately below)
    p.drag_quadratic_n_per_m2_s2 = 0.0;
    Vehicle v(p);
    v.reset({0.0, 0.0}, 2.0, 0.3);
    v.set_commands(hover_commands(v, {scale, scale, scale, scale}));
    v.settle_motors();
    run(v, 1.0);
    const VehicleTruth t = v.truth();
    const double expected_down_acc = (1.0 - scale) * kG;  // climbing is negative down
    // z(t) = z0 + a t^2 / 2
    const double expected_dz = 0.5 * expected_down_acc;
    std::printf("thrust %.2f x m g: down displacement in 1 s %.4g m (expected %.4g), |rate| %.2g rad/s, "
                "accel z %.4f m/s^2\n", scale, t.position_ned.z() - (v.rest_down_m() - 2.0), expected_dz,
                t.rate_frd.norm(), t.specific_force_frd.z());
    EXPECT_NEAR(t.position_ned.z() - (v.rest_down_m() - 2.0), expected_dz, 0.05 * std::abs(expected_dz) + 1e-4)
        << "scale " << scale;
    EXPECT_LT(t.rate_frd.norm(), 1e-6) << "equal rotors must not turn the vehicle";
    EXPECT_LT(t.position_ned.head<2>().norm(), 1e-6);
    // In the air the accelerometer reads thrust only: -scale g along body z.
    EXPECT_NEAR(t.specific_force_frd.z(), -scale * kG, 0.02);
  }
}

TEST(Physics, WindPushesTheVehicleDownwind) {
  Vehicle v(quad_c());
  v.reset({0.0, 0.0}, 2.0, 0.0);
  v.set_commands(hover_commands(v, {1, 1, 1, 1}));
  v.settle_motors();
  v.set_wind_ned({0.0, 3.0, 0.0});  // wind blowing toward East
  run(v, 0.5);
  EXPECT_GT(v.truth().velocity_ned.y(), 0.1);
  EXPECT_NEAR(v.truth().velocity_ned.x(), 0.0, 1e-6);
}

struct TorqueCase {
  const char* name;
  std::array<const char*, 2> faster;  // these rotors get +10 % thrust
  std::array<const char*, 2> slower;  // these -10 %
  int axis;                           // FRD axis that must turn positive
};

TEST(Physics, RotorDifferencesTurnTheVehicleTheFirmwaresWay) {
  // FRD: positive roll = right side down; positive pitch = nose up; positive yaw = clockwise from above.
  // Front/back props turn counter-clockwise, left/right clockwise (control/vehicle.h): thesis eq. 5.4,
  // tau_3 = kappa (w_f^2 + w_b^2 - w_l^2 - w_r^2), so faster front and back rotors yaw the nose right.
  const TorqueCase cases[] = {
      {"roll", {"rotor_left", "rotor_left"}, {"rotor_right", "rotor_right"}, 0},
      {"pitch", {"rotor_front", "rotor_front"}, {"rotor_back", "rotor_back"}, 1},
      {"yaw", {"rotor_front", "rotor_back"}, {"rotor_left", "rotor_right"}, 2},
  };
  for (const auto& c : cases) {
    const VehicleParams p = quad_c();
    Vehicle v(p);
    v.reset({0.0, 0.0}, 2.0, 0.0);
    std::array<double, 4> scale{1, 1, 1, 1};
    for (const char* name : c.faster) scale[static_cast<size_t>(index_of(p, name))] = 1.1;
    for (const char* name : c.slower) scale[static_cast<size_t>(index_of(p, name))] = 0.9;
    v.set_commands(hover_commands(v, scale));
    v.settle_motors();
    run(v, 0.3);
    const VehicleTruth t = v.truth();
    const Eigen::Vector3d euler = euler_from_q_ib(t.q_ib);
    std::printf("%s torque (+-10 %% thrust, 0.3 s): FRD rates (%.4f, %.4f, %.4f) rad/s, angle %.4f rad, "
                "v_NED (%.4f, %.4f) m/s\n", c.name, t.rate_frd.x(), t.rate_frd.y(), t.rate_frd.z(), euler[c.axis],
                t.velocity_ned.x(), t.velocity_ned.y());
    EXPECT_GT(t.rate_frd[c.axis], 0.05) << c.name;
    EXPECT_GT(euler[c.axis], 0.005) << c.name;
    for (int other = 0; other < 3; ++other)
      if (other != c.axis) {
        EXPECT_LT(std::abs(t.rate_frd[other]), 1e-3 * std::abs(t.rate_frd[c.axis]) + 1e-9) << c.name;
      }
    if (c.axis == 0) {
      EXPECT_GT(t.velocity_ned.y(), 0.01) << "rolled right, the vehicle must drift East";
    }
    if (c.axis == 1) {
      EXPECT_LT(t.velocity_ned.x(), -0.01) << "nose up, the vehicle must drift South";
    }
  }
}

TEST(Physics, MotorLagAndSlowerSpinDown) {
  Motor m{MotorParams{}};
  const double target = m.commanded_speed(0.5);
  for (int i = 0; i < 50; ++i) m.step(0.5, 0.001);  // one time constant (0.05 s)
  EXPECT_NEAR(m.speed_rad_s() / target, 1.0 - std::exp(-1.0), 1e-3);
  m.settle(0.5);
  for (int i = 0; i < 50; ++i) m.step(0.0, 0.001);
  EXPECT_NEAR(m.speed_rad_s() / target, std::exp(-0.5), 1e-3) << "spin-down uses tau_down = 0.1 s";
  // Full command gives 880 g at 6500 RPM; the command is proportional to rotor speed (control/vehicle.h).
  m.settle(1.0);
  EXPECT_NEAR(m.thrust_n(), 0.880 * kG, 1e-9);
  EXPECT_NEAR(m.speed_rad_s(), 6500.0 * 2.0 * M_PI / 60.0, 1e-9);
  m.settle(0.5);
  EXPECT_NEAR(m.thrust_n(), 0.25 * 0.880 * kG, 1e-9);
  EXPECT_NEAR(m.speed_rad_s(), 0.5 * 6500.0 * 2.0 * M_PI / 60.0, 1e-9);
  m.set_efficiency(0.8);
  EXPECT_NEAR(m.thrust_n(), 0.8 * 0.25 * 0.880 * kG, 1e-9);
}

}  // namespace
}  // namespace quad::sim

namespace quad::sim {
namespace {

// The simulator's rotors sit and spin where the controller's mixer believes they do.
TEST(Physics, RotorLayoutMatchesTheControllersVehicleDescription) {
  const VehicleParams p = quad_c();
  Vehicle v(p);
  const mjModel* m = v.model();
  const ctrl::VehicleParams controller;
  for (int i = 0; i < 4; ++i) {
    const int a = mj_name2id(m, mjOBJ_ACTUATOR, p.rotor_order[static_cast<size_t>(i)].c_str());
    ASSERT_GE(a, 0);
    const int site = m->actuator_trnid[2 * a];
    const Eigen::Vector3d pos_frd = flu_to_frd({m->site_pos[3 * site], m->site_pos[3 * site + 1], m->site_pos[3 * site + 2]});
    const ctrl::MotorLayout layout = ctrl::motor_layout(controller.frame, controller.arm_length, i);
    EXPECT_NEAR(pos_frd.x(), layout.x, 1e-6) << "motor " << i;
    EXPECT_NEAR(pos_frd.y(), layout.y, 1e-6) << "motor " << i;
    // gear[5] is the yaw torque per newton about z up; spin +1 (CCW) means torque along FRD +z = -z up.
    const double yaw_frd_per_newton = -m->actuator_gear[6 * a + 5];
    EXPECT_GT(yaw_frd_per_newton * layout.spin, 0.0) << "motor " << i;
    EXPECT_NEAR(std::abs(yaw_frd_per_newton), controller.yaw_coeff / controller.thrust_coeff, 1e-6);
  }
}

}  // namespace
}  // namespace quad::sim
