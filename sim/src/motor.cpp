#include "quad/sim/motor.h"

#include <algorithm>
#include <cmath>

namespace quad::sim {

double Motor::commanded_speed(double command) const {
  const double c = std::clamp(command, 0.0, 1.0);
  if (!(c >= p_.idle_command)) return 0.0;  // also catches NaN
  const double a = p_.thrust_curve;
  const double thrust = p_.max_thrust_n * ((1.0 - a) * c + a * c * c);
  return std::sqrt(thrust / p_.thrust_coefficient());
}

void Motor::step(double command, double dt) {
  const double target = commanded_speed(command);
  const double tau = target >= speed_ ? p_.tau_up_s : p_.tau_down_s;
  // Exact discretisation of the first-order lag, stable for any dt.
  speed_ = target + (speed_ - target) * std::exp(-dt / tau);
}

double Motor::thrust_n() const { return efficiency_ * p_.thrust_coefficient() * speed_ * speed_; }

}  // namespace quad::sim
