#include "quad/vision/station.h"

#include <stdexcept>
#include <string>

namespace quad::vision {
namespace {

void check_size(const cv::Mat& image, const char* which, const StereoFrame& frame, cv::Size expected) {
  if (image.size() != expected || image.type() != CV_8UC1) {
    throw std::runtime_error(std::string(which) + " image" + (frame.label.empty() ? "" : " of " + frame.label) +
                             " is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                             (image.type() == CV_8UC1 ? "" : " (not 8-bit grey)") + ", the calibration is for " +
                             std::to_string(expected.width) + "x" + std::to_string(expected.height));
  }
}

}  // namespace

StationStep Station::step() {
  StationStep step;
  step.status = source_.read(step.frame, timeout_);
  if (step.status != ReadStatus::kFrame) {
    locator_.reset_tracking();
    return step;
  }
  const cv::Size size = locator_.calibration().rig.image_size;
  check_size(step.frame.left, "left", step.frame, size);
  check_size(step.frame.right, "right", step.frame, size);
  const int64_t start = monotonic_us();
  step.fix = locator_.locate(step.frame.left, step.frame.right);
  source_.processed(step.frame, static_cast<double>(monotonic_us() - start));
  return step;
}

}  // namespace quad::vision
