// Cost of one estimation step on the host (Google Benchmark). The AVR cycle counts come from the
// embedded benchmarks on simavr; these numbers compare the variants against each other.
#include <benchmark/benchmark.h>

#include "quad/estimation/estimation.h"

namespace {

using quad::Vec3;

// A slowly varying sample stream so that no branch or value is constant-folded.
struct Stream {
  float t = 0.0f;
  Vec3 gyro() const { return {0.3f * sinf(t), 0.2f * cosf(0.7f * t), 0.1f}; }
  Vec3 accel() const { return {0.5f * sinf(0.3f * t), -0.4f, -9.7f}; }
  Vec3 mag() const { return {0.2f + 0.01f * sinf(t), 0.05f, 0.45f}; }
  void next() { t += 0.01f; }
};

template <quad::est::Propagator kProp, quad::est::Innovation kInnov>
void BM_ObserverUpdate(benchmark::State& state) {
  quad::est::ObserverParams p;
  p.propagator = kProp;
  p.innovation = kInnov;
  quad::est::ConditionedObserver obs(p);
  Stream s;
  obs.initialize(s.accel(), s.mag());
  const Vec3 g = s.gyro(), a = s.accel(), m = s.mag();
  for (auto _ : state) {
    obs.update(g, a, m, true, 0.01f);
    benchmark::DoNotOptimize(obs.attitude());
  }
}
BENCHMARK_TEMPLATE(BM_ObserverUpdate, quad::est::Propagator::kSecondOrder, quad::est::Innovation::kConditioned)
    ->Name("observer_update/conditioned/second_order");
BENCHMARK_TEMPLATE(BM_ObserverUpdate, quad::est::Propagator::kExact, quad::est::Innovation::kConditioned)
    ->Name("observer_update/conditioned/exact");
BENCHMARK_TEMPLATE(BM_ObserverUpdate, quad::est::Propagator::kSecondOrder, quad::est::Innovation::kUnconditioned)
    ->Name("observer_update/unconditioned/second_order");

void BM_ObserverUpdateNoMag(benchmark::State& state) {
  quad::est::ConditionedObserver obs;
  Stream s;
  obs.initialize(s.accel(), s.mag());
  const Vec3 g = s.gyro(), a = s.accel(), m = s.mag();
  for (auto _ : state) {
    obs.update(g, a, m, false, 0.01f);
    benchmark::DoNotOptimize(obs.attitude());
  }
}
BENCHMARK(BM_ObserverUpdateNoMag)->Name("observer_update/conditioned/second_order/no_mag");

void BM_Mahony(benchmark::State& state) {
  quad::est::MahonyFilter f;
  Stream s;
  f.initialize(s.accel(), s.mag());
  const Vec3 g = s.gyro(), a = s.accel(), m = s.mag();
  for (auto _ : state) {
    f.update(g, a, m, true, 0.01f);
    benchmark::DoNotOptimize(f.attitude());
  }
}
BENCHMARK(BM_Mahony)->Name("baseline/mahony_update");

void BM_Linear(benchmark::State& state) {
  quad::est::LinearComplementaryFilter f;
  Stream s;
  f.initialize(s.accel(), s.mag());
  const Vec3 g = s.gyro(), a = s.accel(), m = s.mag();
  for (auto _ : state) {
    f.update(g, a, m, true, 0.01f);
    benchmark::DoNotOptimize(f.euler());
  }
}
BENCHMARK(BM_Linear)->Name("baseline/linear_complementary_update");

void BM_PositionPredict(benchmark::State& state) {
  quad::est::PositionFilterParams p;
  p.z_accel_bias = state.range(0) != 0;
  quad::est::PositionFilter<quad::est::history_length(100)> kf(p);
  uint32_t now = 0;
  kf.predict(Vec3{}, now);
  kf.reset(Vec3{}, Vec3{}, now);
  const Vec3 u{0.1f, -0.2f, 0.05f};
  for (auto _ : state) {
    kf.predict(u, now += 10000);
    benchmark::DoNotOptimize(kf.position());
  }
}
BENCHMARK(BM_PositionPredict)->Name("position_filter/predict")->ArgName("z_bias")->Arg(0)->Arg(1);

// One fix at 30 Hz among 100 Hz predictions, captured `delay` ms before it is fused.
void BM_PositionPredictAndFuse(benchmark::State& state) {
  quad::est::PositionFilterParams p;
  p.z_accel_bias = true;
  quad::est::PositionFilter<quad::est::history_length(100)> kf(p);
  uint32_t now = 0;
  kf.predict(Vec3{}, now);
  kf.reset(Vec3{}, Vec3{}, now);
  const uint32_t delay_us = static_cast<uint32_t>(state.range(0)) * 1000u;
  for (int k = 0; k < 30; ++k) kf.predict(Vec3{}, now += 10000);
  for (auto _ : state) {
    kf.predict(Vec3{}, now += 10000);
    benchmark::DoNotOptimize(kf.fuse_position(Vec3{0.001f, 0.0f, 0.0f}, now - delay_us));
  }
  state.counters["fused_fraction"] =
      static_cast<double>(kf.health().fused) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_PositionPredictAndFuse)->Name("position_filter/predict_and_fuse")->ArgName("delay_ms")->Arg(0)->Arg(100);

void BM_KinematicAcceleration(benchmark::State& state) {
  const quad::Quat q = quad::from_euler({0.1f, -0.2f, 0.3f});
  Vec3 a{0.1f, 0.2f, -9.8f};
  for (auto _ : state) {
    benchmark::DoNotOptimize(quad::est::kinematic_acceleration(q, a));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_KinematicAcceleration)->Name("position_filter/kinematic_acceleration");

}  // namespace
