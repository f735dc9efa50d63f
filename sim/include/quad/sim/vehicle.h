// The vehicle in MuJoCo: rigid body with landing gear (MJCF), four motor models driving the rotor
// actuators, air drag relative to the wind. All state leaves this class in NED / FRD (frames.h).
#pragma once

#include <array>
#include <memory>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <mujoco/mujoco.h>

#include "quad/sim/motor.h"

namespace quad::sim {

struct VehicleParams {
  std::string model_path;  // MJCF
  MotorParams motor;
  // Actuator names in the firmware mixer's motor order: controls[i] drives rotor_order[i].
  std::array<std::string, 4> rotor_order{"rotor_front", "rotor_left", "rotor_back", "rotor_right"};
  // Air drag on the airframe relative to the wind: F = -(c1 + c2 |v_rel|) v_rel (rotor drag dominates c1).
  double drag_linear_n_per_m_s = 0.15;
  double drag_quadratic_n_per_m2_s2 = 0.06;
};

struct VehicleTruth {
  double t = 0.0;
  Eigen::Vector3d position_ned = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_ned = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_ib = Eigen::Quaterniond::Identity();
  Eigen::Vector3d rate_frd = Eigen::Vector3d::Zero();
  // What an ideal accelerometer at the IMU site reads (MuJoCo's accelerometer), in FRD.
  Eigen::Vector3d specific_force_frd = Eigen::Vector3d::Zero();
};

class Vehicle {
 public:
  explicit Vehicle(const VehicleParams& params);
  ~Vehicle();
  Vehicle(const Vehicle&) = delete;
  Vehicle& operator=(const Vehicle&) = delete;

  // Puts the vehicle at rest: horizontal position (NED), height of the centre of mass above the resting
  // height on its gear (0 = standing on the ground), yaw (rad, NED).
  void reset(const Eigen::Vector2d& north_east, double height_above_rest_m, double yaw_rad);

  // Lets the vehicle settle on its gear (motors off) for `seconds`, then restarts the clock at zero, so
  // a run begins at rest rather than with the contact still springing.
  void settle_on_ground(double seconds);

  // Motor commands in [0, 1], in the mixer's order; held until changed.
  void set_commands(const std::array<double, 4>& commands) { commands_ = commands; }
  // Puts every rotor at the steady speed of its current command (a run that starts in the air).
  void settle_motors();
  void set_wind_ned(const Eigen::Vector3d& wind) { wind_ned_ = wind; }
  void set_motor_efficiency(int motor, double efficiency);

  // One physics step (the model's timestep). Afterwards truth() holds the state at the end of the step;
  // its specific force is MuJoCo's accelerometer, which mj_step evaluates before integrating (one step old).
  void step();

  double time() const { return data_->time; }
  double timestep() const { return model_->opt.timestep; }
  VehicleTruth truth() const;
  // Centre-of-mass height in NED z when standing on the gear (negative).
  double rest_down_m() const { return -rest_height_m_; }
  double mass_kg() const;

  const Motor& motor(int i) const { return motors_[static_cast<size_t>(i)]; }
  // Mean rotor speed over the maximum, in [0, 1] (drives the IMU's vibration noise).
  double mean_speed_fraction() const;
  const std::array<double, 4>& commands() const { return commands_; }

  const mjModel* model() const { return model_; }
  mjModel* model() { return model_; }
  mjData* data() { return data_; }

 private:
  VehicleParams p_;
  mjModel* model_ = nullptr;
  mjData* data_ = nullptr;
  int body_ = -1;
  std::array<int, 4> actuator_{};
  int accel_adr_ = -1;
  double rest_height_m_ = 0.0;
  std::array<Motor, 4> motors_;
  std::array<double, 4> commands_{};
  Eigen::Vector3d wind_ned_ = Eigen::Vector3d::Zero();
};

}  // namespace quad::sim
