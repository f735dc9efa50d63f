// What the EKF (quad/estimation/delayed_ekf.h, EST_TYPE 1) would cost on the ATmega2560, whose flight
// image holds only the thesis pair: the EKF compiled for the AVR in a bench image of its own, run by
// tools/avr_cycles on simavr (exact cycles at 16 MHz; docs/estimation.md, "The EKF on the AVR").
//
// The EKF runs as the firmware runs it (state_estimator_ekf.cpp): the IMU sample every iteration, the
// 100 Hz predict (the increments 100 ms behind now into the filter, one covariance prediction each, the
// fixes captured within them fused, the state carried back to now), fixes of the star's position and
// attitude (EST_STAR_ATT 2) queued 40 ms after their capture. The state is warmed up by two simulated seconds of hover.
//   ekf_imu                 one IMU sample into the increment (and the output carried)
//   ekf_predict             a 100 Hz predict without a fix
//   ekf_predict_with_fix    a 100 Hz predict whose step fuses a fix (position and the star's attitude)
//   ekf_filter_predict      the filter's own prediction alone (nominal state and covariance, eq. 3.6-3.19)
//   ekf_fuse_star           the filter's update with a star fix alone (position and attitude groups)
// A failed scenario check shows as a section named "check_failed:...".
#include "cycle_probe.h"
#include "quad/estimation/delayed_ekf.h"
#include "quad/estimation/position_filter.h"
#include "quad/math/math.h"
#include "bench_noise.h"

namespace {

using quad::Vec3;

constexpr uint32_t kPeriodUs = 10000;  // the 100 Hz predict: one IMU sample per predict (the AVR's loop)
constexpr float kDt = 1e-6f * kPeriodUs;
constexpr uint32_t kFixDelayUs = 40000;

using quad_bench::noise;

quad::est::DelayedEkf<quad::est::history_length(100)> g_ekf;
uint32_t g_now_us = 1000000;
const Vec3 kStar{0.0f, 0.0f, 0.0f};
const Vec3 kHover{0.0f, 0.0f, -1.5f};

using quad_probe::check;
using quad_probe::measure;

quad::est::StarFix star_fix(uint32_t capture_us) {
  quad::est::StarFix f;
  f.capture_us = capture_us;
  f.star_body = kStar - kHover + Vec3{noise(0.003f), noise(0.003f), noise(0.003f)};
  f.q_bs = quad::Quat{1.0f, noise(0.002f), noise(0.002f), noise(0.002f)};
  f.has_attitude = true;
  return f;
}

void imu_sample() {
  g_ekf.imu(Vec3{noise(0.01f), noise(0.01f), noise(0.01f)},
            Vec3{noise(0.2f), noise(0.2f), -quad::kGravity + noise(0.2f)}, kDt);
}

// One 100 Hz step: the IMU sample, the magnetometer on 3 of 4, a fix queued on every third.
void step(uint32_t k) {
  g_now_us += kPeriodUs;
  imu_sample();
  if (k % 4u != 0u) g_ekf.mag(Vec3{0.42f + noise(0.005f), noise(0.005f), 0.91f + noise(0.005f)});
  if (k % 3u == 0u) g_ekf.queue_fix(star_fix(g_now_us - kFixDelayUs));
  g_ekf.predict(g_now_us, false, true);
}

}  // namespace

int main() {
  quad::est::EkfParams p;
  p.star_ned = kStar;
  p.star_attitude = quad::est::StarAttitudeUse::kFull;  // the costlier setting (EST_STAR_ATT 2)
  g_ekf.set_params(p, 0.1f, true, true);
  g_ekf.reset(quad::Quat::identity(), Vec3{}, Vec3{}, g_now_us);
  uint32_t k = 0;
  for (; k < 200; ++k) step(k);
  check(g_ekf.position_initialized() && g_ekf.finite(), "warm_up");

  measure("overhead", [] {});
  measure("ekf_imu", [] { imu_sample(); });
  // A predict with no fix due: no fix queued for the last 150 ms.
  for (uint32_t i = 0; i < 15; ++i) {
    g_now_us += kPeriodUs;
    imu_sample();
    g_ekf.predict(g_now_us, false, true);
  }
  g_now_us += kPeriodUs;
  imu_sample();
  uint32_t fused = g_ekf.health().positions_fused;
  measure("ekf_predict", [] { g_ekf.predict(g_now_us, false, true); });
  check(g_ekf.health().positions_fused == fused, "ekf_predict_fused_nothing");
  // A fix captured 40 ms ago, fused when the filter (100 ms behind) reaches its capture time.
  g_ekf.queue_fix(star_fix(g_now_us - kFixDelayUs));
  for (uint32_t i = 0; i < 5; ++i) {
    g_now_us += kPeriodUs;
    imu_sample();
    g_ekf.predict(g_now_us, false, true);
  }
  g_now_us += kPeriodUs;
  imu_sample();
  fused = g_ekf.health().positions_fused;
  measure("ekf_predict_with_fix", [] { g_ekf.predict(g_now_us, false, true); });
  check(g_ekf.health().positions_fused == fused + 1u, "ekf_predict_with_fix_fused_one");

  // The filter's parts alone, on the live state.
  quad::est::ErrorStateEkf filter = g_ekf.filter();
  const Vec3 da{noise(1e-4f), noise(1e-4f), noise(1e-4f)};
  const Vec3 dv{noise(2e-3f), noise(2e-3f), -quad::kGravity * kDt};
  measure("ekf_filter_predict", [&] { filter.predict(da, dv, kDt); });
  const quad::est::StarFix fix = star_fix(0);
  quad::est::EkfFuse pr = quad::est::EkfFuse::kRejectedInvalid, ar = pr;
  measure("ekf_fuse_star", [&] { filter.fuse_star(fix, &pr, &ar); });
  check(pr == quad::est::EkfFuse::kFused && ar == quad::est::EkfFuse::kFused, "ekf_fuse_star_fused");
  quad_probe::keep(filter);
  quad_probe::done();
  for (;;) {
  }
}
