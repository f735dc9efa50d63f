// Instruction count of the EKF (quad/estimation/delayed_ekf.h, EST_TYPE 1) on the Cortex-M4F, run on
// QEMU's mps2-an386 with `-icount shift=0` (ctest cortexm_ekf_instruction_count, docs/estimation.md):
// the same SysTick method and calibration as instruction_count.cpp (one tick per 40 instructions).
//
// The EKF's share of the firmware's 400 Hz iteration (state_estimator_ekf.cpp): every iteration takes the
// IMU sample (and a magnetometer sample on 3 of 16); every fourth runs the 100 Hz predict, which takes the
// increments that came of age 100 ms behind now (one covariance prediction each), fuses the fixes
// captured within them and carries the state back to now through the younger increments. A fix (the
// star's position and attitude, as the station sends at 30 Hz) is queued 40 ms after its capture. The
// figures: the mean iteration without a predict, with a predict, with a predict that fuses a fix, and
// the largest predict-with-fix iteration seen over 4 simulated seconds. Results go to UART0 as
// "name instructions" lines, then the image exits through semihosting.
#include <stdint.h>

#include "quad/estimation/delayed_ekf.h"
#include "quad/estimation/position_filter.h"
#include "quad/math/math.h"
#include "bench_noise.h"
#include "instruction_counter.h"
#include "loop_timing_400hz.h"

namespace {

using quad::Vec3;

// ---- the EKF in a hover, as the firmware runs it at 400 Hz ----------------------------------------
using quad_bench::noise;

// The firmware's EKF: 250 ms of 100 Hz increments (kPositionHistory), 100 ms behind now.
quad::est::DelayedEkf<quad::est::history_length(100)> g_ekf;
uint32_t g_now_us = 1000000;
uint32_t g_step = 0;
const Vec3 kStar{0.0f, 0.0f, 0.0f};
const Vec3 kHover{0.0f, 0.0f, -1.5f};

// One 400 Hz iteration: the IMU (and magnetometer) sample; every fourth the predict; a fix queued when
// one arrives (its capture kFixDelayUs ago).
void iteration(bool mag, bool fix) {
  g_now_us += kPeriodUs;
  ++g_step;
  const Vec3 gyro{noise(0.01f), noise(0.01f), noise(0.01f)};
  const Vec3 accel{noise(0.2f), noise(0.2f), -quad::kGravity + noise(0.2f)};
  g_ekf.imu(gyro, accel, kDt);
  if (mag) g_ekf.mag(Vec3{0.42f + noise(0.005f), noise(0.005f), 0.91f + noise(0.005f)});
  if (fix) {
    quad::est::StarFix f;
    f.capture_us = g_now_us - kFixDelayUs;
    f.star_body = kStar - kHover + Vec3{noise(0.003f), noise(0.003f), noise(0.003f)};
    f.q_bs = quad::Quat{1.0f, noise(0.002f), noise(0.002f), noise(0.002f)};
    f.has_attitude = true;
    const float pos_cov[6] = {4e-6f, 0.0f, 0.0f, 4e-6f, 0.0f, 9e-6f};
    const float att_cov[6] = {4e-6f, 0.0f, 0.0f, 4e-6f, 0.0f, 1e-6f};
    for (int i = 0; i < 6; ++i) {
      f.pos_cov[i] = pos_cov[i];
      f.att_cov[i] = att_cov[i];
    }
    f.has_covariance = true;
    g_ekf.queue_fix(f);
  }
  if (g_step % 4u == 0u) g_ekf.predict(g_now_us, false, true);
}

// 400 Hz iterations from step k: magnetometer on 3 of 16, a fix every 12th (33 Hz).
bool mag_at(uint32_t k) { return k % 16u < 3u; }
bool fix_at(uint32_t k) { return k % 12u == 1u; }

}  // namespace

int main() {
  start_and_calibrate();

  quad::est::EkfParams p;
  p.star_ned = kStar;
  p.star_attitude = quad::est::StarAttitudeUse::kFull;  // the costlier setting (EST_STAR_ATT 2)
  g_ekf.set_params(p, 0.1f, true, true);
  g_ekf.reset(quad::Quat::identity(), Vec3{}, Vec3{}, g_now_us);
  // Warm-up: two seconds of hover with fixes (the first sets the position).
  for (uint32_t k = 0; k < 800; ++k) iteration(mag_at(g_step + 1), fix_at(g_step + 1));

  // Each kind of iteration measured alone, over four simulated seconds; the predict's iterations sorted
  // by whether a fix was fused in them.
  uint32_t sum[3] = {0, 0, 0}, count[3] = {0, 0, 0}, worst_fix = 0;
  for (uint32_t k = 0; k < 1600; ++k) {
    const uint32_t step = g_step + 1;
    const uint32_t fused_before = g_ekf.health().positions_fused;
    const uint32_t start = kSystCvr;
    iteration(mag_at(step), fix_at(step));
    const uint32_t n = ticks_between(start, kSystCvr) * kInstructionsPerTick;
    const bool predicted = step % 4u == 0u;
    const bool fused = g_ekf.health().positions_fused != fused_before;
    const int kind = !predicted ? 0 : fused ? 2 : 1;
    sum[kind] += n;
    ++count[kind];
    if (kind == 2 && n > worst_fix) worst_fix = n;
  }
  const char* names[3] = {"ekf_iteration_imu", "ekf_iteration_predict", "ekf_iteration_predict_with_fix"};
  for (int kind = 0; kind < 3; ++kind) {
    put(names[kind]);
    put(' ');
    put_number(count[kind] == 0 ? 0 : (sum[kind] + count[kind] / 2u) / count[kind]);
    put('\n');
  }
  put("ekf_iteration_predict_with_fix_max ");
  put_number(worst_fix);
  put('\n');
  put("ekf_fixes_fused_in_measurement ");
  put_number(count[2]);
  put('\n');
  put(g_ekf.position_initialized() && g_ekf.finite() ? "ekf_state_ok 1\n" : "ekf_state_ok 0\n");
  put("done\n");
  semihosting_exit();
  for (;;) {
  }
}
