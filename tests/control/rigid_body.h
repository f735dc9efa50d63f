// An ideal rigid-body quadrotor for the control tests, written independently of the control library:
// Eigen, double precision, RK4. Thesis eq. 5.9 in the project's convention (NED, FRD, q = q_IB):
//   p' = v
//   m v' = m g e_z - T R e_3                 (thrust along body -e_3; errata 5.2/5.9b)
//   q' = 1/2 q (x) [0, Omega]               (eq. 5.9c)
//   I Omega' = -Omega x I Omega + tau        (eq. 5.9d; Euler's equation. The thesis prints
//                                            +sk(Omega) I Omega, which has the gyroscopic term's sign
//                                            flipped.)
// The rotors are placed from the table in quad/control/vehicle.h (angle positions, not the library's
// code), and each one's thrust f_i = f_max u_i^2 acts at its position along body -z, with a drag torque
// s_i (kappa/b) f_i about body z: forces and torques come from r x F, not from the mixer's matrix.
// Optionally each rotor follows its command with a first-order lag (RotorS: 1/80 s spinning up, 1/40 s
// down) instead of instantly.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <array>
#include <cmath>

namespace quad_test {

struct RigidBodyParams {
  double mass = 1.4;
  Eigen::Vector3d inertia{0.015, 0.015, 0.027};
  double arm = 0.26;
  double max_motor_thrust = 0.880 * 9.80665;
  double yaw_per_thrust = 0.016;  // kappa / b, m
  bool x_frame = false;
  double gravity = 9.80665;
  double motor_tau_up = 0.0;    // s; 0: the rotor speed follows the command instantly
  double motor_tau_down = 0.0;  // s
};

struct RigidBodyState {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  Eigen::Vector4d rotor = Eigen::Vector4d::Zero();  // normalised rotor speeds (only with a motor lag)
};

struct RigidBodyRates {
  Eigen::Vector3d p_dot, v_dot;
  Eigen::Vector4d q_dot;  // (w, x, y, z)
  Eigen::Vector3d w_dot;
  Eigen::Vector4d rotor_dot = Eigen::Vector4d::Zero();
};

class RigidBody {
 public:
  explicit RigidBody(const RigidBodyParams& prm = RigidBodyParams{}) : prm_(prm) {
    for (int i = 0; i < 4; ++i) {
      // Counter-clockwise seen from above = towards -y from +x in FRD (y is right): angle -i * 90 deg,
      // starting at the front (plus) or at -45 deg, the front-left arm (X).
      const double angle = (prm.x_frame ? -M_PI / 4.0 : 0.0) - i * M_PI / 2.0;
      rotor_pos_[i] = Eigen::Vector3d(prm.arm * std::cos(angle), prm.arm * std::sin(angle), 0.0);
      spin_[i] = (i % 2 == 0) ? 1.0 : -1.0;  // front/back (plus) CCW: drag torque along +z
    }
  }

  // Body-frame force and torque of the four motor commands u_i in [0, 1].
  void wrench(const std::array<double, 4>& u, Eigen::Vector3d& force_b, Eigen::Vector3d& torque_b) const {
    force_b.setZero();
    torque_b.setZero();
    for (int i = 0; i < 4; ++i) {
      const double ui = std::min(1.0, std::max(0.0, u[i]));
      const double f = prm_.max_motor_thrust * ui * ui;
      const Eigen::Vector3d force(0.0, 0.0, -f);
      force_b += force;
      torque_b += rotor_pos_[i].cross(force) + Eigen::Vector3d(0.0, 0.0, spin_[i] * prm_.yaw_per_thrust * f);
    }
  }

  bool has_motor_lag() const { return prm_.motor_tau_up > 0.0 && prm_.motor_tau_down > 0.0; }

  RigidBodyRates rates(const RigidBodyState& s, const std::array<double, 4>& u) const {
    Eigen::Vector3d f_b, tau_b;
    std::array<double, 4> speed = u;
    RigidBodyRates r;
    if (has_motor_lag()) {
      for (int i = 0; i < 4; ++i) {
        speed[i] = s.rotor(i);
        const double target = std::min(1.0, std::max(0.0, u[i]));
        const double tau = target > s.rotor(i) ? prm_.motor_tau_up : prm_.motor_tau_down;
        r.rotor_dot(i) = (target - s.rotor(i)) / tau;
      }
    }
    wrench(speed, f_b, tau_b);
    const Eigen::Quaterniond q = s.q.normalized();
    r.p_dot = s.v;
    r.v_dot = Eigen::Vector3d(0.0, 0.0, prm_.gravity) + q * f_b / prm_.mass;
    const Eigen::Quaterniond dq = s.q * Eigen::Quaterniond(0.0, s.w.x(), s.w.y(), s.w.z());
    r.q_dot = 0.5 * Eigen::Vector4d(dq.w(), dq.x(), dq.y(), dq.z());
    const Eigen::Vector3d iw = prm_.inertia.cwiseProduct(s.w);
    r.w_dot = (-s.w.cross(iw) + tau_b).cwiseQuotient(prm_.inertia);
    return r;
  }

  // One classical Runge-Kutta step with the commands held constant.
  void step(RigidBodyState& s, const std::array<double, 4>& u, double dt) const {
    const RigidBodyRates k1 = rates(s, u);
    const RigidBodyRates k2 = rates(advance(s, k1, 0.5 * dt), u);
    const RigidBodyRates k3 = rates(advance(s, k2, 0.5 * dt), u);
    const RigidBodyRates k4 = rates(advance(s, k3, dt), u);
    s.p += dt / 6.0 * (k1.p_dot + 2.0 * k2.p_dot + 2.0 * k3.p_dot + k4.p_dot);
    s.v += dt / 6.0 * (k1.v_dot + 2.0 * k2.v_dot + 2.0 * k3.v_dot + k4.v_dot);
    const Eigen::Vector4d dq = dt / 6.0 * (k1.q_dot + 2.0 * k2.q_dot + 2.0 * k3.q_dot + k4.q_dot);
    s.q = Eigen::Quaterniond(s.q.w() + dq(0), s.q.x() + dq(1), s.q.y() + dq(2), s.q.z() + dq(3)).normalized();
    s.w += dt / 6.0 * (k1.w_dot + 2.0 * k2.w_dot + 2.0 * k3.w_dot + k4.w_dot);
    s.rotor += dt / 6.0 * (k1.rotor_dot + 2.0 * k2.rotor_dot + 2.0 * k3.rotor_dot + k4.rotor_dot);
  }

  const RigidBodyParams& params() const { return prm_; }

 private:
  static RigidBodyState advance(const RigidBodyState& s, const RigidBodyRates& r, double h) {
    RigidBodyState n;
    n.p = s.p + h * r.p_dot;
    n.v = s.v + h * r.v_dot;
    n.q = Eigen::Quaterniond(s.q.w() + h * r.q_dot(0), s.q.x() + h * r.q_dot(1), s.q.y() + h * r.q_dot(2),
                             s.q.z() + h * r.q_dot(3));
    n.w = s.w + h * r.w_dot;
    n.rotor = s.rotor + h * r.rotor_dot;
    return n;
  }

  RigidBodyParams prm_;
  std::array<Eigen::Vector3d, 4> rotor_pos_;
  std::array<double, 4> spin_;
};

}  // namespace quad_test
