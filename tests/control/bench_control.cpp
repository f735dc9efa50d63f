// Host timing of one control step and of its pieces (Google Benchmark). The inputs change every
// iteration (a slowly turning state) so nothing is constant-folded; the AVR and Cortex-M cycle counts
// are measured separately on the emulated processors (docs/performance.md).
#include <benchmark/benchmark.h>

#include "quad/control/cascade.h"
#include "quad/control/manual.h"
#include "quad/control/setpoint_shaper.h"

namespace {

using quad::Quat;
using quad::Vec3;

// A family of plausible in-flight states, indexed by the iteration count.
quad::ctrl::VehicleState state_at(int k) {
  const float t = static_cast<float>(k & 1023) * 1e-3f;
  quad::ctrl::VehicleState s;
  s.p = {0.3f + t, -0.2f * t, -1.4f + 0.1f * t};
  s.v = {0.1f, -0.05f + t, 0.02f};
  s.q = quad::normalized(Quat{1.0f, 0.02f + 0.01f * t, -0.03f, 0.1f * t});
  s.omega = {0.1f * t, -0.2f, 0.05f};
  return s;
}

void BM_CascadeStep(benchmark::State& st) {
  quad::ctrl::Cascade cascade;
  quad::ctrl::PositionSetpoint sp;
  sp.p_d = {0.0f, 0.0f, -1.5f};
  sp.yaw_d = 0.3f;
  int k = 0;
  for (auto _ : st) {
    const quad::ctrl::CascadeOutput& out = cascade.step(state_at(k++), sp);
    benchmark::DoNotOptimize(out.motors.command[0]);
  }
}
BENCHMARK(BM_CascadeStep);

void BM_PositionController(benchmark::State& st) {
  const quad::ctrl::PositionController pc;
  quad::ctrl::PositionSetpoint sp;
  int k = 0;
  for (auto _ : st) {
    const quad::ctrl::VehicleState s = state_at(k++);
    benchmark::DoNotOptimize(pc.update(sp, s.p, s.v));
  }
}
BENCHMARK(BM_PositionController);

void BM_ThrustAttitude(benchmark::State& st) {
  quad::ctrl::ThrustAttitude ta;
  int k = 0;
  for (auto _ : st) {
    const float t = static_cast<float>(k++ & 1023) * 1e-3f;
    benchmark::DoNotOptimize(ta.update(Vec3{0.5f - t, -0.3f, 0.2f * t}, 0.3f));
  }
}
BENCHMARK(BM_ThrustAttitude);

void BM_AttitudeController(benchmark::State& st) {
  const quad::ctrl::AttitudeController ac;
  const Quat q_d = quad::normalized(Quat{1.0f, 0.05f, -0.02f, 0.15f});
  int k = 0;
  for (auto _ : st) {
    const quad::ctrl::VehicleState s = state_at(k++);
    benchmark::DoNotOptimize(ac.update(s.q, s.omega, q_d));
  }
}
BENCHMARK(BM_AttitudeController);

void BM_Mixer(benchmark::State& st) {
  const quad::ctrl::Mixer mixer;
  int k = 0;
  for (auto _ : st) {
    const float t = static_cast<float>(k++ & 1023) * 1e-3f;
    const quad::ctrl::MixerOutput out = mixer.mix(13.7f + t, Vec3{0.2f * t, -0.1f, 0.05f});
    benchmark::DoNotOptimize(out.command[0]);
  }
}
BENCHMARK(BM_Mixer);

void BM_ManualUpdate(benchmark::State& st) {
  quad::ctrl::ManualControl manual;
  manual.reset(0.0f);
  int k = 0;
  for (auto _ : st) {
    const uint16_t roll = static_cast<uint16_t>(1300 + (k++ & 255));
    benchmark::DoNotOptimize(manual.update(quad::ctrl::RcSticks{roll, 1600, 1700, 1450}, 0.01f));
  }
}
BENCHMARK(BM_ManualUpdate);

void BM_SetpointShaper(benchmark::State& st) {
  quad::ctrl::SetpointShaper shaper;
  shaper.reset(Vec3{});
  quad::ctrl::PositionSetpoint sp;
  int k = 0;
  for (auto _ : st) {
    if ((k++ & 1023) == 0) shaper.set_target(Vec3{(k & 2048) ? 3.0f : -3.0f, 1.0f, -1.5f});
    shaper.update(0.01f, sp);
    benchmark::DoNotOptimize(sp.p_d.x);
  }
}
BENCHMARK(BM_SetpointShaper);

}  // namespace

BENCHMARK_MAIN();
