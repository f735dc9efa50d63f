#include "quad/firmware/scheduler.h"

#include "quad/math/float_bits.h"
#include "quad/math/scalar.h"

namespace quad {
namespace fw {

void LoopTimer::set_rate_hz(float hz) {
  if (!(hz >= 1.0f)) hz = 1.0f;
  period_us_ = static_cast<uint32_t>(1e6f / hz + 0.5f);
  period_s_ = static_cast<float>(period_us_) * 1e-6f;
}

bool LoopTimer::due(uint32_t now_us) {
  if (!started_) {
    started_ = true;
    next_us_ = now_us + period_us_;
    return true;
  }
  const int32_t late = static_cast<int32_t>(now_us - next_us_);
  if (late < 0) return false;
  const uint32_t missed = static_cast<uint32_t>(late) / period_us_;
  overruns_ += missed;
  next_us_ += (missed + 1u) * period_us_;
  return true;
}

void LoopTimer::end(uint32_t now_us) {
  last_exec_us_ = now_us - begin_us_;
  if (last_exec_us_ > max_exec_us_) max_exec_us_ = last_exec_us_;
  if (last_exec_us_ > period_us_) ++overruns_;
  ++iterations_;
  const float load = 1000.0f * static_cast<float>(last_exec_us_) / static_cast<float>(period_us_);
  // First-order filter with a time constant of about 100 iterations (1 s at 100 Hz).
  // load > 1000.0f on the bits (load >= 0, or a NaN, which passes as through the float comparison).
  const uint32_t b = float_bits(load);
  const bool above = b > float_bits(1000.0f) && b <= kFloatInfBits;
  load_permille_ += 0.01f * ((above ? 1000.0f : load) - load_permille_);
}

void RateDivider::configure(float rate_hz, float loop_hz, uint8_t slot) {
  phase_ = 0;
  step_ = period_ = 0;
  if (!(rate_hz > 0.0f) || !(loop_hz > 0.0f)) return;
  // SYS_LOOP_HZ <= 1000 Hz: 10 000 tenths, so phase_ + step_ < 2 period_ fits 16 bits.
  const float loop = minf(loop_hz, 1000.0f);
  period_ = static_cast<uint16_t>(loop * 10.0f + 0.5f);
  const float rate = minf(rate_hz, loop);
  step_ = static_cast<uint16_t>(rate * 10.0f + 0.5f);
  if (step_ == 0) step_ = 1;
  // A head start of `slot` steps: the task runs `slot` iterations earlier on its grid than one without.
  phase_ = static_cast<uint16_t>((static_cast<uint32_t>(slot) * step_) % period_);
}

bool RateDivider::tick() {
  if (step_ == 0) return false;
  phase_ = static_cast<uint16_t>(phase_ + step_);
  if (phase_ < period_) return false;
  phase_ = static_cast<uint16_t>(phase_ - period_);
  return true;
}

}  // namespace fw
}  // namespace quad
