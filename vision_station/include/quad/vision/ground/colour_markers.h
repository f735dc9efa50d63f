// Colour-marker detection (seed 003 sec. 3.2): red, green, blue and yellow balls found by thresholding
// each pixel's colour, smoothing and morphology, then the blobs' centre points.
//
// Colour space: normalised rgb chromaticity (r, g) = (R, G) / (R + G + B). A change of illumination
// intensity (a dimmer room, a shadow, the camera's gain) scales R, G and B together and leaves (r, g)
// unchanged, which thresholds on raw RGB (seed 003's) do not; a pixel is a marker colour when its
// chromaticity lies within `radius` of that colour's reference and it is bright enough for the ratio to
// be meaningful (dark pixels' chromaticity is mostly sensor noise).
#pragma once

#include <array>
#include <vector>

#include <opencv2/core.hpp>

namespace quad::vision::ground {

enum class MarkerColour { kRed = 0, kGreen = 1, kBlue = 2, kYellow = 3 };
inline constexpr int kMarkerColours = 4;
const char* colour_name(MarkerColour colour);

struct ColourThresholds {
  // Reference chromaticities (r, g) per colour, in MarkerColour order.
  std::array<cv::Vec2d, kMarkerColours> reference{cv::Vec2d(0.70, 0.15), cv::Vec2d(0.18, 0.62),
                                                   cv::Vec2d(0.15, 0.25), cv::Vec2d(0.48, 0.43)};
  double radius = 0.13;           // chromaticity distance accepted around a reference
  double min_grey_distance = 0.15;  // chromaticity distance from grey (1/3, 1/3): not a washed-out pixel
  int min_sum = 90;               // R + G + B at least this (of 765)
  int smoothing_px = 3;           // Gaussian smoothing before thresholding (seed 003: smoothing)
  int morphology_px = 3;          // opening, then closing, of each colour's mask (seed 003: morphology)
  int min_area_px = 6;            // smaller blobs are noise
  int max_area_px = 6000;         // larger ones are not a marker ball at flight range
};

struct MarkerBlob {
  MarkerColour colour;
  cv::Point2d centre;  // pixels of the distorted image
  int area_px = 0;
  bool touches_border = false;  // cut by the searched region's border (centre unreliable)
};

// The blobs of every colour inside `region` of a BGR image (the whole image for an empty rectangle).
std::vector<MarkerBlob> detect_markers(const cv::Mat& bgr, const ColourThresholds& thresholds,
                                       cv::Rect region = cv::Rect());

}  // namespace quad::vision::ground
