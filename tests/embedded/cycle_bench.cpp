// Cycle benchmark of the flight core on the ATmega2560 (run by tools/avr_cycles on simavr).
// Each section runs one call on inputs the compiler cannot see, between two probes.
#include "cycle_probe.h"
#include "quad/math/math.h"

namespace {
volatile float g_in[8] = {0.11f, -0.23f, 0.31f, 0.01f, 0.7f, 0.1f, -0.2f, 0.67f};

quad::Vec3 input_vec(int i) { return {g_in[i], g_in[i + 1], g_in[i + 2]}; }

template <typename F>
void measure(const char* name, F&& f) {
  quad_probe::name(name);
  quad_probe::start();
  f();
  quad_probe::stop();
}
}  // namespace

int main() {
  const quad::Vec3 w = input_vec(0);
  const quad::Quat q = quad::normalized(quad::Quat{g_in[4], g_in[5], g_in[6], g_in[7]});
  const float dt = g_in[3];

  measure("overhead", [] {});
  measure("float_mul", [&] { quad_probe::keep(g_in[0] * g_in[1]); });
  measure("float_div", [&] { quad_probe::keep(g_in[0] / g_in[1]); });
  measure("sqrtf", [&] { quad_probe::keep(sqrtf(g_in[4])); });
  measure("sinf", [&] { quad_probe::keep(sinf(g_in[4])); });
  measure("atan2f", [&] { quad_probe::keep(atan2f(g_in[4], g_in[5])); });
  measure("quat_mul", [&] { quad_probe::keep(q * q); });
  measure("quat_mul_normalize", [&] { quad_probe::keep(quad::normalized(q * q)); });
  measure("rotate_vec", [&] { quad_probe::keep(quad::rotate(q, w)); });
  measure("to_dcm", [&] { quad_probe::keep(quad::to_dcm(q)); });
  measure("integrate_exact", [&] { quad_probe::keep(quad::integrate_exact(q, w, dt)); });
  measure("integrate_second_order", [&] { quad_probe::keep(quad::integrate_second_order(q, w, dt)); });
  measure("to_euler", [&] { quad_probe::keep(quad::to_euler(q)); });
  quad_probe::done();
  for (;;) {
  }
}
