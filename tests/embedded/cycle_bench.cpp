// Cycle benchmark of the flight core's parts on the ATmega2560 (run by tools/avr_cycles on simavr; the
// table of docs/performance.md, "Flight core parts"). The firmware's own iterations are measured in
// flight, on the flight image (avr_pil's profile, docs/performance.md); this bench gives the parts.
//
// The figures are the control stages as the firmware runs them in the automatic mode (its default
// parameters, including the position filter's horizontal bias states), without I/O. The state is warmed
// up by a simulated flight segment first, so every section runs on realistic numbers. The single-rate
// iteration holds every stage: observer step, kinematic acceleration, position-filter predict (and a
// vision fix when one arrives), setpoint shaper, position control, thrust and attitude, attitude PD,
// mixer:
//   iteration_typical  no magnetometer sample, no fix, hovering near the setpoint
//   iteration_worst    magnetometer sample, vision fix fused, shaper moving, large position and
//                      velocity errors (tanh in its rational branch), tilt limited, mixer desaturating
// Each branch the worst case claims to take is checked; a failed check shows as a section named
// "check_failed:...". Sensor inputs come from volatile memory so the compiler cannot fold them.
#include "cycle_probe.h"
#include "quad/control/approx.h"
#include "quad/control/cascade.h"
#include "quad/control/setpoint_shaper.h"
#include "quad/estimation/conditioned_observer.h"
#include "quad/estimation/position_filter.h"
#include "quad/math/math.h"
// The bench's own headers last: before the flight core's they move the shaper's code in the link and its
// cycle figure by one.
#include "bench_hover_sensors.h"
#include "bench_noise.h"

namespace {

using quad::Quat;
using quad::Vec3;

constexpr uint32_t kPeriodUs = 10000;  // 100 Hz, the thesis' loop (the cycle figure is per iteration)
constexpr float kDt = 1e-6f * kPeriodUs;
constexpr uint32_t kFixDelayUs = 40000;  // vision latency: capture to arrival

volatile float g_in[8] = {0.11f, -0.23f, 0.31f, 0.01f, 0.7f, 0.1f, -0.2f, 0.67f};

// Deterministic small sensor noise, so the warm-up is not a constant input.
using quad_bench::noise;

// The classic bit-level inverse square root with one Newton step (relative error < 1.8e-3), measured
// against 1 / sqrtf to show that it does not pay on this chip (docs/performance.md).
float inv_sqrt_newton(float x) {
  uint32_t i;
  memcpy(&i, &x, sizeof i);
  i = 0x5F3759DFu - (i >> 1);
  float y;
  memcpy(&y, &i, sizeof y);
  return y * (1.5f - 0.5f * x * y * y);
}

using quad_bench::hover_sample;
using quad_bench::Sensors;

// The flight core as the firmware holds it (static storage, as in FlightApp).
quad::est::ConditionedObserver g_observer;
quad::est::PositionFilter<quad::est::history_length(100)> g_filter;
quad::ctrl::SetpointShaper g_shaper;
quad::ctrl::Cascade g_cascade;
quad::ctrl::PositionSetpoint g_setpoint;
// The cascade's pieces on their own, with the same parameters, for the per-stage table.
quad::ctrl::PositionController g_position;
quad::ctrl::ThrustAttitude g_thrust_attitude;
quad::ctrl::AttitudeController g_attitude;
quad::ctrl::Mixer g_mixer;

uint32_t g_now_us = 1000000;
uint32_t g_step = 0;

using quad_probe::check;
using quad_probe::measure;

quad::ctrl::VehicleState vehicle_state() {
  return {g_filter.position(), g_filter.velocity(), g_observer.attitude(), g_observer.rate()};
}

// The estimation part of one iteration (firmware: FlightApp::estimate at the position rate of 100 Hz).
void estimate(const Sensors& s, bool mag_new) {
  g_observer.update(s.gyro, s.accel, s.mag, mag_new, kDt);
  g_filter.predict(quad::est::kinematic_acceleration(g_observer.dcm(), s.accel), g_now_us);
}

// A vision fix of the hover point, a few centimetres of noise on it.
const Vec3 kHoverPoint{0.0f, 0.0f, -1.5f};
quad::est::FixResult fuse_fix() {
  return g_filter.fuse_position(kHoverPoint + Vec3{noise(0.03f), noise(0.03f), noise(0.03f)}, g_now_us - kFixDelayUs);
}

// Warm-up: two simulated seconds of hover with a magnetometer sample on three of four steps (75 Hz of
// 100 Hz) and a vision fix every fourth step (25 Hz).
void warm_up() {
  const Sensors s0 = hover_sample(0);
  g_observer.initialize(s0.accel, s0.mag);
  for (uint32_t k = 0; k < 200; ++k) {
    g_now_us += kPeriodUs;
    ++g_step;
    estimate(hover_sample(g_step), g_step % 4u != 0u);
    if (g_step % 4u == 2u) fuse_fix();
    g_shaper.update(kDt, g_setpoint);
    g_cascade.step(vehicle_state(), g_setpoint);
  }
}

}  // namespace

int main() {
  const quad::ctrl::CascadeParams params;
  g_position.set_gains(params.position);
  quad::ctrl::ThrustAttitudeParams tap = quad::ctrl::ThrustAttitudeParams::for_vehicle(params.vehicle);
  tap.max_tilt = params.max_tilt;
  g_thrust_attitude.set_params(tap);
  g_attitude.set_gains(params.attitude);
  g_mixer.set_vehicle(params.vehicle);
  // The position filter as the firmware configures it by default (KF_XY_BIAS 1: horizontal
  // acceleration-error states, so x and y carry 3x3 covariances and z its own 2x2).
  quad::est::PositionFilterParams fp;
  fp.xy_accel_bias = true;
  g_filter.set_params(fp);
  g_shaper.reset(kHoverPoint);
  g_setpoint.p_d = kHoverPoint;
  warm_up();

  measure("overhead", [] {});
  measure("float_mul", [] { quad_probe::keep(g_in[0] * g_in[1]); });
  measure("float_add", [] { quad_probe::keep(g_in[0] + g_in[1]); });
  measure("float_div", [] { quad_probe::keep(g_in[0] / g_in[1]); });
  measure("sqrtf", [] { quad_probe::keep(sqrtf(g_in[4])); });
  measure("sinf", [] { quad_probe::keep(sinf(g_in[4])); });
  measure("atan2f", [] { quad_probe::keep(atan2f(g_in[4], g_in[5])); });
  measure("inv_sqrtf", [] { quad_probe::keep(1.0f / sqrtf(g_in[4])); });
  measure("inv_sqrt_newton", [] { quad_probe::keep(inv_sqrt_newton(g_in[4])); });
  measure("tanhf", [] { quad_probe::keep(tanhf(g_in[4])); });
  measure("tanh_approx_small", [] { quad_probe::keep(quad::ctrl::tanh_approx(g_in[5])); });
  measure("tanh_approx_large", [] { quad_probe::keep(quad::ctrl::tanh_approx(g_in[4])); });
  {
    const Quat q = g_observer.attitude();
    const Vec3 w{g_in[0], g_in[1], g_in[2]};
    measure("quat_mul_normalize", [&] { quad_probe::keep(quad::normalized(q * q)); });
    measure("rotate_vec", [&] { quad_probe::keep(quad::rotate(q, w)); });
    measure("to_dcm", [&] { quad_probe::keep(quad::to_dcm(q)); });
    measure("integrate_second_order", [&] { quad_probe::keep(quad::integrate_second_order(q, w, kDt)); });
  }

  // Per-stage table, each on the live state of the warmed-up flight.
  {
    g_now_us += kPeriodUs;
    ++g_step;
    const Sensors s = hover_sample(g_step);
    measure("observer_with_mag", [&] { g_observer.update(s.gyro, s.accel, s.mag, true, kDt); });
    const Sensors s2 = hover_sample(g_step + 1);
    measure("observer_without_mag", [&] { g_observer.update(s2.gyro, s2.accel, s2.mag, false, kDt); });
    // The gyro-only step of a faster loop (400 Hz; no renormalisation between corrections).
    measure("observer_propagate", [&] { g_observer.propagate(s2.gyro, 0.25f * kDt); });
    g_observer.update(s2.gyro, s2.accel, s2.mag, false, kDt);  // back to the 100 Hz state
    Vec3 u;
    measure("kinematic_acceleration_quat",
            [&] { u = quad::est::kinematic_acceleration(g_observer.attitude(), s2.accel); });
    measure("kinematic_acceleration", [&] { u = quad::est::kinematic_acceleration(g_observer.dcm(), s2.accel); });
    measure("kalman_predict", [&] { g_filter.predict(u, g_now_us); });
    quad::est::FixResult fix = quad::est::FixResult::kRejectedInvalid;
    const Vec3 p = g_filter.position() - g_filter.velocity() * (1e-6f * kFixDelayUs);
    const Vec3 y = p + Vec3{0.02f, -0.01f, 0.015f};
    measure("kalman_fused_fix", [&] { fix = g_filter.fuse_position(y, g_now_us - kFixDelayUs); });
    check(fix == quad::est::FixResult::kFused, "kalman_fix_not_fused");
    // The same fusion in two steps (400 Hz): the gate, a predict, the update carried across it.
    g_now_us += kPeriodUs;
    g_filter.predict(u, g_now_us);
    const Vec3 y2 = g_filter.position() - g_filter.velocity() * (1e-6f * kFixDelayUs) + Vec3{-0.01f, 0.02f, 0.0f};
    g_filter.queue_fix(y2, g_now_us - kFixDelayUs);
    measure("kalman_fix_gate", [&] { fix = g_filter.advance_fix(); });
    check(fix == quad::est::FixResult::kPending, "kalman_fix_gate_failed");
    g_now_us += kPeriodUs;
    g_filter.predict(u, g_now_us);
    measure("kalman_fix_update", [&] { fix = g_filter.advance_fix(); });
    check(fix == quad::est::FixResult::kFused, "kalman_fix_update_failed");
    measure("shaper", [&] { g_shaper.update(kDt, g_setpoint); });

    const quad::ctrl::VehicleState st = vehicle_state();
    Vec3 mu;
    measure("position_control", [&] { mu = g_position.update(g_setpoint, st.p, st.v); });
    quad::ctrl::AttitudeCommand cmd;
    measure("thrust_attitude", [&] { cmd = g_thrust_attitude.update(mu, g_setpoint.yaw_d); });
    Vec3 tau;
    measure("attitude_control", [&] { tau = g_attitude.update(st.q, st.omega, cmd.q_d); });
    quad::ctrl::MixerOutput mix;
    measure("mixer", [&] { mix = g_mixer.mix(cmd.thrust, tau); });
    quad_probe::keep(mix);
    // The mixer's desaturation branches: yaw given up (priority 3), and roll/pitch scaled (priority 1).
    measure("mixer_yaw_saturated", [&] { mix = g_mixer.mix(cmd.thrust, Vec3{0.3f, -0.2f, 0.6f}); });
    check(mix.yaw_limited && !mix.roll_pitch_limited, "mixer_yaw_case");
    measure("mixer_roll_pitch_saturated", [&] { mix = g_mixer.mix(cmd.thrust, Vec3{4.0f, -3.0f, 0.6f}); });
    check(mix.roll_pitch_limited, "mixer_roll_pitch_case");
    // Manual flight and a faster inner loop run the attitude PD and the mixer alone.
    measure("attitude_and_mixer", [&] { quad_probe::keep(g_cascade.step_attitude(st, cmd)); });
    measure("attitude_held", [&] { quad_probe::keep(g_cascade.step_held(st)); });
    measure("cascade_hover", [&] { quad_probe::keep(g_cascade.step(st, g_setpoint)); });

    // Large errors: pushed 1.5 m off, moving at 1 m/s the wrong way, heading 40 deg off.
    quad::ctrl::PositionSetpoint far = g_setpoint;
    far.p_d += Vec3{1.5f, -1.2f, 0.8f};
    far.v_d += Vec3{-1.0f, 0.8f, 0.5f};
    far.yaw_d += 0.7f;
    measure("cascade_large_errors", [&] { quad_probe::keep(g_cascade.step(st, far)); });
    measure("position_control_large_errors", [&] { mu = g_position.update(far, st.p, st.v); });
    measure("thrust_attitude_tilt_limited", [&] { cmd = g_thrust_attitude.update(mu, far.yaw_d); });
    check(cmd.limited, "thrust_attitude_not_limited");
    {
      quad::ctrl::SetpointShaper moving;
      quad::ctrl::PositionSetpoint msp;
      moving.reset(kHoverPoint);
      moving.set_target(Vec3{5.0f, -3.0f, -2.5f});
      for (int i = 0; i < 50; ++i) moving.update(kDt, msp);  // accelerating towards the target
      measure("shaper_moving", [&] { moving.update(kDt, msp); });
    }
    check(g_cascade.output().attitude.limited, "large_errors_tilt_not_limited");
    check(g_cascade.output().motors.yaw_limited, "large_errors_yaw_not_limited");
  }

  // The whole iteration, typical: no magnetometer sample, no fix, hovering.
  g_cascade.step(vehicle_state(), g_setpoint);  // heading cache back at the hover setpoint
  {
    g_now_us += kPeriodUs;
    ++g_step;
    const Sensors s = hover_sample(g_step);
    measure("iteration_typical", [&] {
      estimate(s, false);
      g_shaper.update(kDt, g_setpoint);
      quad_probe::keep(g_cascade.step(vehicle_state(), g_setpoint));
    });
    check(!g_cascade.output().motors.yaw_limited && !g_cascade.output().attitude.limited, "typical_saturated");
  }

  // The whole iteration, worst case: magnetometer sample, a fix fused, shaper moving towards a far
  // target, and large tracking errors with a new heading.
  {
    g_now_us += kPeriodUs;
    ++g_step;
    const Sensors s = hover_sample(g_step);
    g_shaper.set_target(Vec3{5.0f, -3.0f, -2.5f});
    g_shaper.update(kDt, g_setpoint);
    quad::ctrl::PositionSetpoint far;
    quad::est::FixResult fix = quad::est::FixResult::kRejectedInvalid;
    const Vec3 p = g_filter.position() - g_filter.velocity() * (1e-6f * kFixDelayUs);
    const Vec3 y = p + Vec3{-0.02f, 0.01f, 0.015f};
    const Vec3 push{1.5f, -1.2f, 0.8f};
    measure("iteration_worst", [&] {
      estimate(s, true);
      fix = g_filter.fuse_position(y, g_now_us - kFixDelayUs);
      g_shaper.update(kDt, g_setpoint);
      far = g_setpoint;
      far.p_d += push;
      far.v_d.x -= 1.0f;
      far.yaw_d = 0.7f;
      quad_probe::keep(g_cascade.step(vehicle_state(), far));
    });
    check(fix == quad::est::FixResult::kFused, "worst_fix_not_fused");
    check(g_cascade.output().attitude.limited, "worst_tilt_not_limited");
    check(g_cascade.output().motors.yaw_limited, "worst_yaw_not_limited");
  }

  quad_probe::done();
  for (;;) {
  }
}
