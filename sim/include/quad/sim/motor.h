// Brushless motor, ESC and propeller: command in [0, 1] to rotor speed to thrust.
#pragma once

namespace quad::sim {

struct MotorParams {
  // A2830-12 with a 10 x 4.7 prop: 880 g maximum thrust at about 6500 RPM (reference facts).
  double max_thrust_n = 0.880 * 9.80665;
  double max_speed_rad_s = 6500.0 * 2.0 * 3.14159265358979323846 / 60.0;
  // First-order speed lag; spin-down is slower than spin-up because the ESC does not brake.
  double tau_up_s = 0.05;
  double tau_down_s = 0.10;
  // ESC map: the thrust the command asks for, T_cmd = T_max ((1 - a) c + a c^2) (PX4's THR_MDL_FAC
  // form). a = 1 (default) makes the command proportional to rotor speed, the convention of
  // control/include/quad/control/vehicle.h; a = 0 makes thrust linear in the command. Below
  // `idle_command` the motor stops.
  double thrust_curve = 1.0;
  double idle_command = 0.02;
  // Yaw reaction torque = kappa * thrust (RotorS, Flightmare: 0.016 m). The sign per rotor is in the MJCF.
  double yaw_moment_coefficient_m = 0.016;

  // thrust = k w^2 with k from the two figures above.
  double thrust_coefficient() const { return max_thrust_n / (max_speed_rad_s * max_speed_rad_s); }
};

class Motor {
 public:
  explicit Motor(const MotorParams& params) : p_(params) {}

  // Advances the rotor speed by dt toward the speed the command asks for.
  void step(double command, double dt);

  double speed_rad_s() const { return speed_; }
  // thrust = efficiency * k w^2
  double thrust_n() const;
  // Steady-state speed for a command (the ESC map).
  double commanded_speed(double command) const;

  // Jumps to the steady state of a command (starting a run in the air).
  void settle(double command) { speed_ = commanded_speed(command); }

  void set_efficiency(double efficiency) { efficiency_ = efficiency; }
  double efficiency() const { return efficiency_; }
  const MotorParams& params() const { return p_; }

 private:
  MotorParams p_;
  double speed_ = 0.0;
  double efficiency_ = 1.0;
};

}  // namespace quad::sim
