// Instruction count of the control iteration on the Cortex-M4F, run on QEMU's mps2-an386 with
// `-icount shift=0` (ctest cortexm_instruction_count, docs/targets.md).
//
// Method: instruction_counter.h.
//
// The iteration is the one of docs/performance.md's cycle table, at the Cortex-M's 400 Hz: observer
// step, kinematic acceleration, position-filter predict (and a vision fix when one arrives), setpoint
// shaper, position control, thrust and attitude, attitude PD, mixer; no I/O. Sensor inputs come from
// volatile memory so the compiler cannot fold them. Results go to UART0 as "name instructions" lines,
// then the image exits through semihosting (QEMU's -semihosting).
#include <stdint.h>

#include "quad/control/cascade.h"
#include "quad/control/setpoint_shaper.h"
#include "quad/estimation/conditioned_observer.h"
#include "quad/estimation/position_filter.h"
#include "quad/math/math.h"
#include "bench_hover_sensors.h"
#include "bench_noise.h"
#include "instruction_counter.h"
#include "loop_timing_400hz.h"

namespace {

using quad::Vec3;

// ---- the flight core, as in the cycle bench ------------------------------------------------------
using quad_bench::hover_sample;
using quad_bench::noise;
using quad_bench::Sensors;

quad::est::ConditionedObserver g_observer;
quad::est::PositionFilter<quad::est::history_length(400)> g_filter;
quad::ctrl::SetpointShaper g_shaper;
quad::ctrl::Cascade g_cascade;
quad::ctrl::PositionSetpoint g_setpoint;
uint32_t g_now_us = 1000000;
uint32_t g_step = 0;
const Vec3 kHoverPoint{0.0f, 0.0f, -1.5f};

quad::ctrl::VehicleState vehicle_state() {
  return {g_filter.position(), g_filter.velocity(), g_observer.attitude(), g_observer.rate()};
}
void estimate(const Sensors& s, bool mag_new) {
  g_observer.update(s.gyro, s.accel, s.mag, mag_new, kDt);
  g_filter.predict(quad::est::kinematic_acceleration(g_observer.dcm(), s.accel), g_now_us);
}
void iteration(bool mag_new, bool fix) {
  g_now_us += kPeriodUs;
  ++g_step;
  estimate(hover_sample(g_step), mag_new);
  if (fix) g_filter.fuse_position(kHoverPoint + Vec3{noise(0.03f), noise(0.03f), noise(0.03f)}, g_now_us - kFixDelayUs);
  g_shaper.update(kDt, g_setpoint);
  keep(g_cascade.step(vehicle_state(), g_setpoint));
}

}  // namespace

int main() {
  start_and_calibrate();
  measure("loop_overhead", 10000, [] { __asm volatile("" ::: "memory"); });

  const Sensors s0 = hover_sample(0);
  g_observer.initialize(s0.accel, s0.mag);
  g_setpoint.p_d = kHoverPoint;
  g_shaper.set_target(kHoverPoint);
  // Warm-up: two seconds of hover, magnetometer on 3 of 16 steps (75 of 400 Hz), a fix every 16th (25 Hz).
  for (uint32_t k = 0; k < 800; ++k) iteration(k % 16u < 3u, k % 16u == 8u);

  // Means over one simulated second each.
  measure("iteration_typical", 400, [] { iteration(false, false); });
  measure("iteration_with_mag", 400, [] { iteration(true, false); });
  measure("iteration_with_mag_and_fix", 400, [] { iteration(true, true); });
  {
    // Worst case, once (+-40 instructions): magnetometer sample, a fix fused, the shaper moving towards
    // a far target, large tracking errors and a new heading (tilt limited, mixer desaturating).
    g_shaper.set_target(Vec3{5.0f, -3.0f, -2.5f});
    g_now_us += kPeriodUs;
    ++g_step;
    const Sensors sw = hover_sample(g_step);
    const Vec3 fix = g_filter.position() + Vec3{-0.02f, 0.01f, 0.015f};
    measure("iteration_worst", 1, [&] {
      estimate(sw, true);
      g_filter.fuse_position(fix, g_now_us - kFixDelayUs);
      g_shaper.update(kDt, g_setpoint);
      quad::ctrl::PositionSetpoint far = g_setpoint;
      far.p_d += Vec3{1.5f, -1.2f, 0.8f};
      far.v_d.x -= 1.0f;
      far.yaw_d = 0.7f;
      keep(g_cascade.step(vehicle_state(), far));
    });
    put(g_cascade.output().attitude.limited && g_cascade.output().motors.yaw_limited ? "worst_case_saturated 1\n"
                                                                                     : "worst_case_saturated 0\n");
  }
  // Stages on the live state.
  const Sensors s = hover_sample(g_step + 1);
  measure("observer_with_mag", 100, [&] { g_observer.update(s.gyro, s.accel, s.mag, true, kDt); });
  measure("observer_without_mag", 100, [&] { g_observer.update(s.gyro, s.accel, s.mag, false, kDt); });
  Vec3 u;
  measure("kinematic_acceleration", 100, [&] { u = quad::est::kinematic_acceleration(g_observer.dcm(), s.accel); });
  measure("kalman_predict", 100, [&] { g_filter.predict(u, g_now_us); });
  measure("kalman_fused_fix", 1, [&] {
    g_filter.fuse_position(g_filter.position() - g_filter.velocity() * (1e-6f * kFixDelayUs), g_now_us - kFixDelayUs);
  });
  measure("shaper", 100, [] { g_shaper.update(kDt, g_setpoint); });
  const quad::ctrl::VehicleState st = vehicle_state();
  measure("cascade_hover", 100, [&] { keep(g_cascade.step(st, g_setpoint)); });
  quad::ctrl::PositionSetpoint far = g_setpoint;
  far.p_d += Vec3{1.5f, -1.2f, 0.8f};
  far.v_d += Vec3{-1.0f, 0.8f, 0.5f};
  far.yaw_d += 0.7f;
  measure("cascade_large_errors", 100, [&] { keep(g_cascade.step(st, far)); });
  put("done\n");
  semihosting_exit();
  for (;;) {
  }
}
