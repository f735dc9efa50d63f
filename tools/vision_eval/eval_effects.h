// What happens to a view between the lens and the station: motion blur, interlaced fields taken 1/60 s
// apart, rolling-shutter skew, sensor noise, the analog radio link's snow and lost sync lines, and the
// capture device's JPEG compression. All work on CV_32F grey levels except the final quantisation.
#pragma once

#include <opencv2/core.hpp>

namespace vision_eval {

// Linear motion blur: the average of the view shifted along `angle` over `length_px`, centred (the true
// position is the one at mid-exposure).
cv::Mat motion_blur(const cv::Mat& view, double length_px, double angle);

// Interlaced frame: even rows from `view` (first field), odd rows from the view shifted by `shift` px
// (the second field, exposed one field period later while the camera moved).
cv::Mat interlace(const cv::Mat& view, cv::Point2d shift);

// Rolling-shutter skew: row r shifted horizontally by skew_px·(r − zero_row)/rows.
cv::Mat rolling_skew(const cv::Mat& view, double skew_px, double zero_row);

// Sensor noise (Gaussian, σ grey levels) then quantisation to 8 bits.
cv::Mat quantise(const cv::Mat& view, double noise_sigma, cv::RNG& rng);

// RF snow: `fraction` of the pixels start a short bright or dark horizontal streak (1–6 px).
void rf_snow(cv::Mat& image, double fraction, cv::RNG& rng);

// Lost horizontal sync: `bands` bands of 1–8 lines displaced sideways by 8–80 px, or blanked.
void lost_sync(cv::Mat& image, int bands, cv::RNG& rng);

}  // namespace vision_eval
