#include "eval_effects.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace vision_eval {

cv::Mat motion_blur(const cv::Mat& view, double length_px, double angle) {
  if (length_px < 0.5) return view.clone();
  // Kernel: a line of the given length sampled finely, anti-aliased by bilinear splatting.
  const int half = static_cast<int>(std::ceil(0.5 * length_px)) + 1;
  cv::Mat kernel(2 * half + 1, 2 * half + 1, CV_32F, cv::Scalar(0));
  const int samples = static_cast<int>(std::ceil(length_px * 8)) + 1;
  for (int i = 0; i < samples; ++i) {
    const double t = (i / static_cast<double>(samples - 1) - 0.5) * length_px;
    const double x = half + t * std::cos(angle), y = half + t * std::sin(angle);
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    kernel.at<float>(y0, x0) += static_cast<float>((1 - fx) * (1 - fy));
    kernel.at<float>(y0, x0 + 1) += static_cast<float>(fx * (1 - fy));
    kernel.at<float>(y0 + 1, x0) += static_cast<float>((1 - fx) * fy);
    kernel.at<float>(y0 + 1, x0 + 1) += static_cast<float>(fx * fy);
  }
  kernel /= cv::sum(kernel)[0];
  cv::Mat out;
  cv::filter2D(view, out, CV_32F, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  return out;
}

cv::Mat interlace(const cv::Mat& view, cv::Point2d shift) {
  cv::Mat second;
  const cv::Matx23d M(1, 0, shift.x, 0, 1, shift.y);
  cv::warpAffine(view, second, M, view.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::Mat out = view.clone();
  for (int r = 1; r < out.rows; r += 2) second.row(r).copyTo(out.row(r));
  return out;
}

cv::Mat rolling_skew(const cv::Mat& view, double skew_px, double zero_row) {
  cv::Mat mx(view.size(), CV_32F), my(view.size(), CV_32F);
  for (int r = 0; r < view.rows; ++r) {
    const float dx = static_cast<float>(skew_px * (r - zero_row) / view.rows);
    for (int c = 0; c < view.cols; ++c) {
      mx.at<float>(r, c) = c - dx;
      my.at<float>(r, c) = static_cast<float>(r);
    }
  }
  cv::Mat out;
  cv::remap(view, out, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

cv::Mat quantise(const cv::Mat& view, double noise_sigma, cv::RNG& rng) {
  cv::Mat noise(view.size(), CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, noise_sigma);
  cv::Mat out;
  cv::Mat(view + noise).convertTo(out, CV_8U);  // rounds and saturates
  return out;
}

void rf_snow(cv::Mat& image, double fraction, cv::RNG& rng) {
  const int count = static_cast<int>(fraction * image.total());
  for (int i = 0; i < count; ++i) {
    const int r = rng.uniform(0, image.rows), c = rng.uniform(0, image.cols);
    const int length = rng.uniform(1, 7);
    const uchar value = rng.uniform(0, 2) ? static_cast<uchar>(rng.uniform(200, 256)) : static_cast<uchar>(rng.uniform(0, 50));
    for (int k = 0; k < length && c + k < image.cols; ++k) image.at<uchar>(r, c + k) = value;
  }
}

void lost_sync(cv::Mat& image, int bands, cv::RNG& rng) {
  for (int b = 0; b < bands; ++b) {
    const int lines = rng.uniform(1, 9);
    const int top = rng.uniform(0, image.rows - lines);
    const bool blank = rng.uniform(0, 3) == 0;
    const int shift = rng.uniform(8, 81) * (rng.uniform(0, 2) ? 1 : -1);
    for (int r = top; r < top + lines; ++r) {
      cv::Mat row = image.row(r);
      if (blank) {
        row.setTo(cv::Scalar(rng.uniform(0, 2) ? 16 : 235));
        continue;
      }
      cv::Mat copy = row.clone();
      for (int c = 0; c < image.cols; ++c) row.at<uchar>(0, c) = copy.at<uchar>(0, ((c - shift) % image.cols + image.cols) % image.cols);
    }
  }
}

}  // namespace vision_eval
