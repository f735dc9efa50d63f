// Closed-loop runs of the control library against the rigid-body model: the controller sees the true
// state (converted to float) at the control rate and its motor commands are held between its steps
// while RK4 integrates the model at 1 kHz.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "eigen_oracle.h"
#include "quad/control/cascade.h"
#include "rigid_body.h"

namespace quad_test {

inline quad::ctrl::VehicleState to_vehicle_state(const RigidBodyState& s) {
  quad::ctrl::VehicleState v;
  v.p = from_eigen(s.p);
  v.v = from_eigen(s.v);
  v.q = from_eigen(s.q);
  v.omega = from_eigen(s.w);
  return v;
}

inline RigidBodyParams model_of(const quad::ctrl::VehicleParams& v) {
  RigidBodyParams m;
  m.mass = v.mass;
  m.inertia = to_eigen(v.inertia);
  m.arm = v.arm_length;
  m.max_motor_thrust = v.max_motor_thrust;
  m.yaw_per_thrust = static_cast<double>(v.yaw_coeff) / static_cast<double>(v.thrust_coeff);
  m.x_frame = v.frame == quad::ctrl::Frame::kX;
  return m;
}

struct Sample {
  double t;
  RigidBodyState s;
};

// Runs `duration` seconds. `control(t, state) -> motor commands` is called every 1/rate seconds.
template <class Control>
std::vector<Sample> run_closed_loop(const RigidBody& body, RigidBodyState s, double duration, double rate,
                                    Control control) {
  constexpr double kPhysicsDt = 1e-3;
  const int substeps = std::max(1, static_cast<int>(std::lround(1.0 / (rate * kPhysicsDt))));
  const int steps = static_cast<int>(std::lround(duration * rate));
  std::vector<Sample> log;
  log.reserve(static_cast<size_t>(steps) + 1);
  double t = 0.0;
  log.push_back({t, s});
  for (int k = 0; k < steps; ++k) {
    const std::array<double, 4> u = control(t, s);
    for (int j = 0; j < substeps; ++j) {
      body.step(s, u, kPhysicsDt);
      t += kPhysicsDt;
    }
    log.push_back({t, s});
  }
  return log;
}

inline std::array<double, 4> commands_of(const quad::ctrl::MixerOutput& m) {
  return {m.command[0], m.command[1], m.command[2], m.command[3]};
}

// The last time the distance to `target` exceeded `tolerance` (the settling time), or -1 if it never
// came within it by the end of the log.
inline double settling_time(const std::vector<Sample>& log, const Eigen::Vector3d& target, double tolerance) {
  double last_outside = 0.0;
  for (const Sample& x : log) {
    if ((x.s.p - target).norm() > tolerance) last_outside = x.t;
  }
  if ((log.back().s.p - target).norm() > tolerance) return -1.0;
  return last_outside;
}

// Overshoot of one axis relative to its initial offset: how far, as a fraction of that offset, the
// position went past the target on the other side (0 if it never crossed).
inline double overshoot(const std::vector<Sample>& log, const Eigen::Vector3d& target, int axis) {
  const double start = log.front().s.p(axis) - target(axis);
  if (std::abs(start) < 1e-9) return 0.0;
  double worst = 0.0;
  for (const Sample& x : log) worst = std::max(worst, -(x.s.p(axis) - target(axis)) / start);
  return worst;
}

}  // namespace quad_test
