#include "quad/firmware/calibration.h"

namespace quad {
namespace fw {

void BootCalibration::configure(const CalibrationConfig& config) {
  config_ = config;
  stats_ = est::StationaryCalibrator(config.limits);
}

void BootCalibration::restart() {
  stats_.reset();
  mag_sum_ = Vec3{};
  mag_n_ = 0;
  started_ = false;
  done_ = false;
}

BootCalibration::Event BootCalibration::add(uint32_t t_us, const Vec3& gyro, const Vec3& accel, const Vec3* mag) {
  if (done_) return Event::kCollecting;
  if (!started_) {
    started_ = true;
    start_us_ = t_us;
  }
  stats_.add(gyro, accel);
  if (mag != nullptr && is_finite(*mag)) {
    mag_sum_ += *mag;
    ++mag_n_;
  }
  const float elapsed_s = static_cast<float>(t_us - start_us_) * 1e-6f;
  if (elapsed_s < config_.duration_s) return Event::kCollecting;

  est::ImuBias bias;
  const est::CalibrationStatus status = stats_.result(bias);
  if (status == est::CalibrationStatus::kTooFewSamples) return Event::kCollecting;  // a slow loop: wait
  if (status != est::CalibrationStatus::kOk) {
    rejection_ = status;
    ++rejected_;
    restart();
    return Event::kWindowRejected;
  }
  result_.bias = bias;
  result_.mag_valid = mag_n_ > 0;
  result_.mag_mean = mag_n_ > 0 ? mag_sum_ * (1.0f / static_cast<float>(mag_n_)) : Vec3{};
  done_ = true;
  return Event::kDone;
}

}  // namespace fw
}  // namespace quad
