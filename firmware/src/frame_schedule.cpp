#include "quad/firmware/frame_schedule.h"

namespace quad {
namespace fw {

void StageClock::configure(float rate_hz, float loop_hz) {
  frame_.configure(rate_hz, loop_hz);
  index_ = 0;
  per_frame_ = 1;
  if (!(rate_hz > 0.0f) || !(loop_hz > rate_hz)) return;
  const float n = loop_hz / rate_hz;  // SYS_LOOP_HZ <= 1000: at most 20 iterations of a 50 Hz frame
  per_frame_ = n >= 255.0f ? 255u : static_cast<uint8_t>(n);
}

void StageClock::tick() {
  if (frame_.tick()) {
    index_ = 0;
  } else if (index_ < 255u) {
    ++index_;
  }
}

uint16_t BackgroundBudget::log_bytes(uint32_t elapsed_us) const {
  if (!kBudgeted) return 0xFFFFu;
  if (elapsed_us + kLogAppendUs >= deadline_us_) return 0;
  const uint32_t bytes = (deadline_us_ - elapsed_us - kLogAppendUs) / kLogByteUs;
  return bytes < 0xFFFFu ? static_cast<uint16_t>(bytes) : 0xFFFFu;
}

IterationPlan FrameSchedule::next(float dt, bool fix_in_progress) {
  // The clock counts every iteration (calibration and disarmed ones too); the time each stage covers is
  // accumulated here and handed to the iteration that runs it.
  stages_.tick();
  correction_dt_ += dt;
  frame_dt_ += dt;
  IterationPlan plan;
  plan.multi_rate = stages_.per_frame() > 1;
  plan.correct = stages_.runs(kStageCorrect);
  plan.predict = stages_.runs(kStagePredict);
  plan.position_loop = stages_.runs(kStagePositionLoop);
  plan.frame_work = stages_.runs(kStageFrameWork);
  if (plan.frame_work) {
    if (fix_in_progress && frame_work_deferred_ < kMaxFrameWorkDeferred) {
      plan.fix_step = true;
      plan.frame_work = false;
      ++frame_work_deferred_;
    } else {
      frame_work_deferred_ = 0;
    }
  }
  plan.correction_dt = correction_dt_;
  if (plan.correct) correction_dt_ = 0.0f;
  plan.frame_dt = frame_dt_;
  if (plan.frame_work) frame_dt_ = 0.0f;
  return plan;
}

}  // namespace fw
}  // namespace quad
