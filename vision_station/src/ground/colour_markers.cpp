#include "quad/vision/ground/colour_markers.h"

#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace quad::vision::ground {

const char* colour_name(MarkerColour colour) {
  switch (colour) {
    case MarkerColour::kRed: return "red";
    case MarkerColour::kGreen: return "green";
    case MarkerColour::kBlue: return "blue";
    case MarkerColour::kYellow: return "yellow";
  }
  return "?";
}

namespace {

// 1 + the colour index whose chromaticity reference is within the radius, else 0.
uint8_t classify_rgb(double red, double green, double blue, const ColourThresholds& t) {
  const double sum = red + green + blue;
  if (sum < t.min_sum) return 0;
  const double r = red / sum, g = green / sum;
  const double gr = r - 1.0 / 3.0, gg = g - 1.0 / 3.0;
  if (gr * gr + gg * gg < t.min_grey_distance * t.min_grey_distance) return 0;
  for (int k = 0; k < kMarkerColours; ++k) {
    const double dr = r - t.reference[k][0], dg = g - t.reference[k][1];
    if (dr * dr + dg * dg < t.radius * t.radius) return static_cast<uint8_t>(k + 1);
  }
  return 0;
}

bool same(const ColourThresholds& a, const ColourThresholds& b) {
  return a.reference == b.reference && a.radius == b.radius && a.min_grey_distance == b.min_grey_distance &&
         a.min_sum == b.min_sum;
}

// The classification of every colour quantised to 6 bits a channel (the bin's centre: chromaticity off
// by at most ~0.005), built once per set of thresholds: one lookup a pixel.
const std::vector<uint8_t>& lookup_table(const ColourThresholds& t) {
  thread_local ColourThresholds built_for;
  thread_local std::vector<uint8_t> table;
  if (table.empty() || !same(built_for, t)) {
    table.assign(64 * 64 * 64, 0);
    for (int b = 0; b < 64; ++b) {
      for (int g = 0; g < 64; ++g) {
        for (int r = 0; r < 64; ++r) table[(b << 12) | (g << 6) | r] = classify_rgb(r * 4 + 1.5, g * 4 + 1.5, b * 4 + 1.5, t);
      }
    }
    built_for = t;
  }
  return table;
}

cv::Mat classify(const cv::Mat& bgr, const ColourThresholds& t) {
  const std::vector<uint8_t>& table = lookup_table(t);
  cv::Mat labels(bgr.size(), CV_8U);
  for (int y = 0; y < bgr.rows; ++y) {
    const cv::Vec3b* row = bgr.ptr<cv::Vec3b>(y);
    uint8_t* out = labels.ptr<uint8_t>(y);
    for (int x = 0; x < bgr.cols; ++x) out[x] = table[((row[x][0] >> 2) << 12) | ((row[x][1] >> 2) << 6) | (row[x][2] >> 2)];
  }
  return labels;
}

}  // namespace

std::vector<MarkerBlob> detect_markers(const cv::Mat& bgr, const ColourThresholds& t, cv::Rect region) {
  if (bgr.type() != CV_8UC3) throw std::invalid_argument("detect_markers: expected an 8-bit BGR image");
  const cv::Rect full(0, 0, bgr.cols, bgr.rows);
  region = region.area() == 0 ? full : (region & full);
  std::vector<MarkerBlob> blobs;
  if (region.area() == 0) return blobs;
  cv::Mat view = bgr(region), smooth;
  if (t.smoothing_px > 1) {
    cv::GaussianBlur(view, smooth, cv::Size(t.smoothing_px | 1, t.smoothing_px | 1), 0);
  } else {
    smooth = view;
  }
  const cv::Mat labels = classify(smooth, t);
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(t.morphology_px, t.morphology_px));
  const bool left = region.x > 0, top = region.y > 0;
  const bool right = region.br().x < bgr.cols, bottom = region.br().y < bgr.rows;
  for (int k = 0; k < kMarkerColours; ++k) {
    cv::Mat mask = labels == (k + 1);
    if (cv::countNonZero(mask) < t.min_area_px) continue;
    if (t.morphology_px > 1) {
      cv::morphologyEx(mask, mask, cv::MORPH_OPEN, kernel);
      cv::morphologyEx(mask, mask, cv::MORPH_CLOSE, kernel);
    }
    cv::Mat component, stats, centroids;
    const int n = cv::connectedComponentsWithStats(mask, component, stats, centroids, 8, CV_32S);
    for (int i = 1; i < n; ++i) {
      const int area = stats.at<int>(i, cv::CC_STAT_AREA);
      if (area < t.min_area_px || area > t.max_area_px) continue;
      MarkerBlob blob;
      blob.colour = static_cast<MarkerColour>(k);
      blob.centre = cv::Point2d(centroids.at<double>(i, 0) + region.x, centroids.at<double>(i, 1) + region.y);
      blob.area_px = area;
      const int x0 = stats.at<int>(i, cv::CC_STAT_LEFT), y0 = stats.at<int>(i, cv::CC_STAT_TOP);
      const int x1 = x0 + stats.at<int>(i, cv::CC_STAT_WIDTH), y1 = y0 + stats.at<int>(i, cv::CC_STAT_HEIGHT);
      blob.touches_border = (left && x0 == 0) || (top && y0 == 0) || (right && x1 == region.width) ||
                            (bottom && y1 == region.height);
      blobs.push_back(blob);
    }
  }
  return blobs;
}

}  // namespace quad::vision::ground
