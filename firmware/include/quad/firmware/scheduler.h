// Fixed-rate scheduling: the control loop's period, its measured execution time and overruns, and
// dividers that run slower tasks (telemetry, parameters) every n-th iteration.
#pragma once

#include <stdint.h>

namespace quad {
namespace fw {

// Decides when the next control iteration is due on a free-running microsecond clock and measures
// each iteration. Periods are kept on a fixed grid (no drift); when an iteration starts later than one
// whole period after its slot the missed slots are skipped and counted as overruns.
class LoopTimer {
 public:
  void set_rate_hz(float hz);
  uint32_t period_us() const { return period_us_; }
  // The period in seconds, float(period_us()) * 1e-6f, computed when the rate is set.
  float period_s() const { return period_s_; }

  // True when an iteration is due at `now_us`; advances the grid. The first call always fires.
  bool due(uint32_t now_us);

  // Brackets one iteration (start/end on the same clock) to measure its execution time.
  void begin(uint32_t now_us) { begin_us_ = now_us; }
  void end(uint32_t now_us);
  // The time since begin().
  uint32_t elapsed_us(uint32_t now_us) const { return now_us - begin_us_; }

  // Ticks of the grid that passed without an iteration, plus iterations that took longer than a
  // period.
  uint32_t overruns() const { return overruns_; }
  uint32_t iterations() const { return iterations_; }
  uint32_t last_exec_us() const { return last_exec_us_; }
  uint32_t max_exec_us() const { return max_exec_us_; }
  // Share of the period spent in the loop, 0..1000 per mille (SYS_STATUS.load), filtered over 64 iterations.
  uint16_t load_permille() const { return static_cast<uint16_t>((load_q8_ + 128) >> 8); }

 private:
  uint32_t period_us_ = 10000;
  float period_s_ = static_cast<float>(10000u) * 1e-6f;
  uint32_t next_us_ = 0;
  bool started_ = false;
  uint32_t begin_us_ = 0;
  uint32_t last_exec_us_ = 0;
  uint32_t max_exec_us_ = 0;
  uint32_t overruns_ = 0;
  uint32_t iterations_ = 0;
  uint32_t load_scale_ = (1000u * 65536u + 5000u) / 10000u;  // set_rate_hz(): 1000 * 2^16 / period_us_
  uint32_t load_q8_ = 0;  // filtered load, per mille x 256
};

// Runs a task at `rate_hz` out of a loop at `loop_hz` by counting iterations (deterministic in
// lockstep). A rate of 0 turns the task off; rates above the loop rate run every iteration. A rate that
// does not divide the loop rate is kept on average (30 Hz out of 100 Hz: 3 runs in every 10
// iterations), by a phase accumulator in tenths of a hertz (integers: no drift, 6 bytes of RAM).
//
// Tasks at the same or related rates would all fire in the same iteration (every 100th at 1 Hz and
// 10 Hz out of 100 Hz), and on the AVR four telemetry frames to two ports take about 45 000 cycles: a
// `slot` delays the task's grid by that many iterations, so tasks given different slots never share an
// iteration while the gaps between their runs allow it.
class RateDivider {
 public:
  void configure(float rate_hz, float loop_hz, uint8_t slot = 0);
  bool tick();  // call once per loop iteration; true when the task should run now

 private:
  uint16_t step_ = 0;    // rate, 0.1 Hz (0: off)
  uint16_t period_ = 0;  // loop rate, 0.1 Hz
  uint16_t phase_ = 0;   // accumulated, < period_
};

}  // namespace fw
}  // namespace quad
