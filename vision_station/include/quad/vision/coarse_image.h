// Whole-image steps of the robust detector's coarse search (star_detector_robust.cpp) as plain loops
// that the compiler vectorises (the morphology and below_level with OpenCV's universal intrinsics, where
// it did that poorly). Each gives exactly the OpenCV call named beside it, or says how it differs
// (tests/vision/test_coarse_image.cpp checks that against OpenCV): on images of a few hundred pixels a
// side OpenCV's general paths (border copies, dispatch, parallel_for_, kernel setup) cost several times
// the arithmetic.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

namespace quad::vision {

// The half-resolution copy: the mean of each pixel pair of a row (rows_too false) or of each 2 × 2
// block, rounded half up. (No OpenCV twin: cv::resize INTER_AREA rounds half to even.)
void half_resolution(const cv::Mat& view, bool rows_too, cv::Mat& out);

// cv::resize(src, dst, src.size() / 4, 0, 0, cv::INTER_AREA) for a CV_8UC1 image whose sides are
// multiples of 4 (any other size goes to cv::resize).
void quarter_area(const cv::Mat& src, cv::Mat& dst);

// cv::erode / cv::dilate of a whole CV_8UC1 image with a width × height rectangle, default anchor,
// iterations and borders; dst must not be src.
void erode_rect(const cv::Mat& src, cv::Mat& dst, int width, int height);
void dilate_rect(const cv::Mat& src, cv::Mat& dst, int width, int height);

// cv::erode (minimum) or cv::dilate of image(roi) with a width × height rectangle into `out` (roi's size):
// like OpenCV on a sub-matrix, the window reads the image's pixels around the roi.
void extremum_in(const cv::Mat& image, const cv::Rect& roi, int width, int height, bool minimum, cv::Mat& out,
                 cv::Mat& scratch);

// cv::mean(values, mask)[0] (0 for an empty mask) in `mean`; returns cv::countNonZero(mask). CV_8UC1 both.
int masked_mean(const cv::Mat& values, const cv::Mat& mask, double& mean);

// cv::erode then cv::dilate with a k × k rectangle and the default borders (an opening) of a whole
// CV_8UC1 image; dst must not be src.
void open_rect(const cv::Mat& src, int k, cv::Mat& dst, cv::Mat& scratch);

// Rows 1 … n−2 of `image` replaced by the median of themselves and their two neighbours (the image's
// first and last rows kept): cv::min/cv::max on row blocks.
void vertical_median_3(cv::Mat& image, cv::Mat& scratch);

// The window `out_region` of src enlarged fx × fy times (each 1, 2 or 4; CV_8UC1) by bilinear
// interpolation, sampled as cv::resize INTER_LINEAR samples (output pixel i at source coordinate
// (i + ½)/f − ½, the edge pixels replicated): each value is the exact interpolation rounded half up, where
// OpenCV's fixed-point vector path rounds some down (within one grey level of cv::resize). Only the
// window is computed; it lies within the enlarged image.
void upsample_linear(const cv::Mat& src, int fx, int fy, const cv::Rect& out_region, cv::Mat& out);

// out = 255 where image · 256 < floor · q (q ≤ 256: a ratio in 1/256), else 0; same-size CV_8UC1.
void below_level(const cv::Mat& image, const cv::Mat& floor, uint16_t q, cv::Mat& out);

}  // namespace quad::vision
