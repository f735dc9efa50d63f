// Four-pointed-star detection in one greyscale image. Two methods (DetectorSettings::method):
//  - thesis: the pipeline of thesis sec. 8.1 (steps 1–5, filters 1–5) with the project's threshold,
//    solidity filter and mid-level refinement; the documented baseline.
//  - robust (default): segmentation on a half-resolution copy against the local floor brightness, the
//    affine-invariant radial-profile shape test (star_shape.h), then the mid-level contour at full
//    resolution for the centroid. Survives textured floors, blur, compression and the analog link's
//    faults (docs/vision_station.md).
// Both find contours in the raw frame and rectify only their points, through a RectifyTable, so the
// strong barrel distortion near the image edge does not squash the star out of the filters.
// Interlaced sources: Deinterlace picks one field or the blend of both; contour rows are mapped back to
// frame rows (2·row, or 2·row + ½) before rectification, so the geometry is the frame's.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/point_rectifier.h"
#include "quad/vision/rectify_table.h"
#include "quad/vision/star_shape.h"

namespace quad::vision {

// The contour of largest area (nullptr when none has any): the refined outline of a candidate.
const std::vector<cv::Point>* largest_contour(const std::vector<std::vector<cv::Point>>& contours);

enum class DetectorMethod { kThesis, kRobust };
// none: progressive frames; field: the even rows only (the first field, one instant, half the pixels);
// blend: the mean of each row pair (both fields, two instants 1/60 s apart).
enum class Deinterlace { kNone, kField, kBlend };

const char* to_string(DetectorMethod method);
const char* to_string(Deinterlace deinterlace);
bool parse_detector_method(const std::string& text, DetectorMethod& out);
bool parse_deinterlace(const std::string& text, Deinterlace& out);

// Every threshold of the detector. Defaults are the thesis' values (sec. 8.1) unless marked (project).
struct DetectorSettings {
  DetectorMethod method = DetectorMethod::kRobust;  // (project) chosen on the evaluation sets
  Deinterlace deinterlace = Deinterlace::kField;    // (project) chosen on the evaluation sets

  // Threshold (project): the floor brightness is estimated as the local maximum over a window larger
  // than the star's dark core on a 1/cell-size image; Otsu on the image/floor ratio picks the contrast
  // threshold, clamped to [min, max] so that an empty floor does not split its own noise.
  int background_cell_px = 8;
  int background_window_px = 192;
  double min_threshold_ratio = 0.25;
  double max_threshold_ratio = 0.85;
  int morphology_kernel_px = 3;      // square structuring element of erode, dilate ×2, erode
  // (project) Re-threshold each accepted star at the mid-level between its own grey and the local floor,
  // so that its edge sits where the pixel coverage is ½ whatever the Otsu level was: a uniform edge shift
  // is not uniform after undistortion (the lens magnifies the edge nearer the image border) and would
  // bias the centroid.
  bool refine_midpoint = true;

  int edge_margin_px = 2;            // filter 1: contour at least this far from the image edge
  double min_area_px = 350.0;        // filter 2: rectified contour area strictly above this
  double raw_area_prefilter = 0.25;  // (project) raw area must exceed this fraction of min_area_px
                                     // before its points are rectified (edge distortion shrinks areas)
  double min_aspect = 0.7;           // filter 3: bounding-box height/width within [min, 1/min]
  int ideal_vertex_count = 8;        // filter 4: polygon vertex count within tolerance of this
  int vertex_count_tolerance = 1;
  double polygon_epsilon = 0.025;    // (project) approxPolyDP tolerance, fraction of the perimeter
  double min_hu_distance = 1e-7;     // filter 5: Hu-moment distance (CONTOURS_MATCH_I1) in (min, max)
  double max_hu_distance = 0.5;
  double inner_ratio = 0.4;          // ideal star: inner vertex radius / tip radius
  // (project) sixth filter, area / convex-hull area. The ideal star has 0.566; circles, squares and
  // blobs are near 1, which the Hu distance alone does not separate (a 4-fold symmetric shape has
  // h2..h7 ≈ 0, so I1 compares h1 only).
  double min_solidity = 0.42;
  double max_solidity = 0.75;

  // Robust method (project). Floor brightness: local maximum over this window (frame pixels) on a
  // 1/8-size copy; Otsu on the image/floor ratio, clamped to [min, max], is the contrast threshold.
  int robust_window_px = 160;
  double robust_min_ratio = 0.25;
  double robust_max_ratio = 0.8;
  double robust_low_ratio = 0.55;  // second, lower level: this fraction of the first (not below min)
  bool robust_low_level_always = false;  // search the second level even when the first found a candidate
  // With no candidate at either level, the largest outlines of the first level that touch the image's
  // edge or fail the shape test (a star merged with a shadow or dark texture) are searched again, each
  // at a level of its own: Otsu on its pixels' image/floor ratios.
  bool robust_split_merged = true;
  bool robust_floor_closing = true;  // floor = closing (max then min) over the window, else its maximum
  bool robust_sync_repair = true;    // interpolate the rows of lost-sync bands (sync_repair.cpp)
  bool robust_row_median = true;     // 3-row vertical median of the half-resolution copy (RF snow)
  StarShapeLimits shape;
  // A coarse outline within these looser limits that fails `shape` is tested again on its mid-level
  // outline at full resolution (small and blurred stars lose their tips on the coarse copy).
  StarShapeLimits retry_shape{2.6, 0.3, 0.12, 1.5, 0.35, 0.92};
  // A candidate without a mid-level outline that passes the shape test is dropped (with refine_midpoint).
  bool robust_require_midlevel = false;
  // (robust) An outline that fails the shape test (and its second chance) but is within near_miss_shape
  // is kept apart (StarDetector::near_misses): the locator may pair it with a star that passes the test
  // in the other view (LocatorSettings::guided_acceptance sets keep_near_misses).
  bool keep_near_misses = false;
  StarShapeLimits near_miss_shape{2.6, 0.3, 0.15, 1.5, 0.4, 0.9};
};

// One contour that passed every filter.
struct StarCandidate {
  std::vector<cv::Point> contour;       // raw image pixels
  std::vector<cv::Point2f> rectified;   // the same points undistorted and rectified
  cv::Rect box;                         // raw bounding box
  cv::Point2d centroid;                 // rectified, from the polygon's moments (sub-pixel)
  double area = 0.0;                    // rectified pixels²
  double hu_distance = 0.0;             // shape distance, smaller is better: Hu I1 (thesis) or profile RMS (robust)
  double solidity = 0.0;
  int vertices = 0;
  bool refined = false;                 // (robust) the outline is the full-resolution mid-level one
  bool strict = true;                   // passed the shape test (false: a near miss, the coarse outline)
  bool split = false;                   // (robust) found inside a larger outline at its own level (split_merged)
};

// What became of one contour of the robust method (failure analysis: tools/vision_eval explain).
enum class ContourFate {
  kTooFewPoints, kTouchesBorder, kSmallRawArea, kSmallArea, kShape, kDuplicate, kNoMidLevel, kAccepted
};
const char* to_string(ContourFate fate);

struct TracedContour {
  cv::Rect frame_box;      // raw frame pixels
  double level = 0.0;      // the threshold ratio whose binary image it came from
  ContourFate fate = ContourFate::kTooFewPoints;
  double area = 0.0;       // rectified pixels² (0 when dropped before rectification)
  StarShapeScore shape;    // filled from kShape on
  bool refined = false;    // accepted with the mid-level contour (false: the coarse one)
};

// Wall time of the detector's stages, microseconds (accumulated over calls).
struct DetectorTimes {
  double threshold_morphology_us = 0.0;
  double contours_filters_us = 0.0;
  double rectify_points_us = 0.0;
};

// Holds the settings, the ideal star's Hu moments and scratch images, so that a frame allocates little
// once the buffers have grown.
class StarDetector {
 public:
  StarDetector(const DetectorSettings& settings, const PointRectifier& rectifier = PointRectifier());

  // Finds the star candidates inside `roi` (clipped to the image; an empty rect means the whole image),
  // best first (smallest Hu distance). A contour touching an ROI border that is not an image border is
  // dropped as possibly cut. `gray` must be CV_8UC1. level_ratio > 0 (robust method): the contrast level
  // ρ to use instead of measuring it on the ROI (the other view's, so both views cut the star alike).
  std::vector<StarCandidate> detect(const cv::Mat& gray, cv::Rect roi, DetectorTimes* times = nullptr,
                                    double level_ratio = 0.0);

  const DetectorSettings& settings() const { return settings_; }

  // The last call's near misses (DetectorSettings::keep_near_misses), best first, none where a candidate
  // is; empty without keep_near_misses.
  const std::vector<StarCandidate>& near_misses() const { return near_misses_; }

  // Record every contour's fate into `trace` (appended; nullptr stops). For analysis, not for speed.
  void set_trace(std::vector<TracedContour>* trace) { trace_ = trace; }

  // The binary image of the last call (inside its ROI, in the deinterlaced view; the half-resolution copy
  // for the robust method) and its threshold ratio, for display and tests.
  const cv::Mat& last_binary() const { return binary_; }
  double last_threshold_ratio() const { return threshold_ratio_; }

 private:
  // The deinterlaced view of gray(roi) and how its pixel coordinates map back to frame pixels.
  void make_view(const cv::Mat& gray, const cv::Rect& roi);
  void to_frame(const std::vector<cv::Point>& view_points, cv::Point2f view_scale, std::vector<cv::Point2f>& frame) const;
  void rectify(const std::vector<cv::Point>& view_points, cv::Point2f view_scale, std::vector<cv::Point2f>& out);
  // True when the contour's box touches a border of the view that is not inside the image margin.
  bool touches_border(const cv::Rect& box, cv::Size view_size, int margin) const;

  std::vector<StarCandidate> detect_thesis(DetectorTimes* times);
  std::vector<StarCandidate> detect_robust(const cv::Mat& gray, const cv::Rect& roi, double level_ratio, DetectorTimes* times);
  // The frame region whose floor the robust method measures for a search of `roi`: the ROI grown by the
  // floor's reach, on the full frame's grid of 8 × 8 pixels (its 1/8-size copy), within the image.
  cv::Rect floor_region(const cv::Rect& roi, cv::Size image) const;
  // The local floor at half resolution over `window` (coarse pixels of the floor region), interpolated
  // from the 1/8-size floor exactly as for the whole region.
  void upsample_floor(const cv::Rect& window);
  cv::Point2f coarse_scale() const;  // view pixels per pixel of the half-resolution copy (x, y)
  // Lost-sync bands (sync_repair.cpp): rows [a, b) of `view` shifted or blanked as a whole, at most
  // max_band rows each; repair_sync_bands interpolates them in a copy of view_ and points view_ at it.
  bool find_sync_bands(const cv::Mat& view, int max_band, std::vector<cv::Vec2i>& bands);
  void repair_sync_bands();
  double unexplained_jump(const cv::Mat& image, int a, int b);
  // The half-resolution copy's vertical 3-row median (RF snow is streaks one line high).
  void row_median();
  // The floor over the view (the floor region) and the level ρ (level_ratio when > 0, else Otsu), then
  // the view and the half-resolution copy cut to the search window (`window`, view pixels).
  void robust_floor(const cv::Rect& window, double level_ratio);
  void robust_threshold(double ratio);
  // The contours of binary_(region) through the filters and the shape test; with `collect_merged`, those
  // that touch the border or fail the shape test (large enough) are kept in merged_ for split_merged.
  void robust_candidates(std::vector<StarCandidate>& candidates, double& refine_us, const cv::Rect& region,
                         bool collect_merged);
  // robust_split_merged: each kept outline's pixels thresholded at a level of its own, searched again.
  void split_merged(std::vector<StarCandidate>& candidates, double& refine_us);
  // The candidate's mid-level outline at full resolution (false: none that passes the shape test; its
  // score in `score`).
  bool robust_refine(const cv::Rect& coarse_box, StarCandidate& c, StarShapeScore& score);
  // refine_binary_: the view's pixels in `region` below the mid-level between the star and the local floor
  // around the coarse candidate in `grown` (false: no floor around it).
  bool mid_level_threshold(const cv::Rect& grown, const cv::Rect& region);
  // Shape test, second chance, duplicate check and refinement of one contour that passed the area filters
  // (m: the moments of its rectified outline, c.rectified).
  void robust_accept(const std::vector<cv::Point>& contour, const cv::Rect& box, const cv::Moments& m,
                     StarCandidate& c, std::vector<StarCandidate>& candidates);
  // Keeps a contour that failed the shape test with `score` as a near miss when within near_miss_shape.
  void keep_near_miss(const std::vector<cv::Point>& contour, const StarShapeScore& score, StarCandidate& c);
  // Drops near misses where a candidate (or a better near miss) is, keeps the best few, best first.
  void prune_near_misses(const std::vector<StarCandidate>& candidates);
  // The largest outline of refine_binary_ (the pixels of `region` below the mid-level), smoothed.
  const std::vector<cv::Point>* mid_level_outline(const cv::Rect& region);

  void threshold(const cv::Mat& gray);
  // The mid-level contour of an accepted candidate (raw pixels), or false to keep the original.
  bool midpoint_contour(const cv::Mat& gray, const cv::Rect& roi, const cv::Rect& box, std::vector<cv::Point>& out);
  double hu_distance(const cv::Moments& moments) const;

  DetectorSettings settings_;
  PointRectifier rectifier_;
  RectifyTable table_;
  StarShapeTest shape_test_;
  StarShapeLimits loosest_shape_;  // each limit the loosest of `shape`, `retry_shape` (and near_miss_shape)
  std::vector<StarCandidate> near_misses_;
  cv::Mat view_;                   // deinterlaced gray(roi)
  cv::Mat blend_;                  // storage of the blended view
  cv::Point2f view_origin_;        // frame pixel of view pixel (0, 0)
  float view_row_scale_ = 1.0f;    // frame rows per view row
  bool roi_border_[4] = {};        // left, top, right, bottom edges of the searched ROI are not image edges
  bool image_border_[4] = {};
  cv::Mat coarse_, coarse_floor_, coarse_threshold_;
  cv::Mat coarse_region_;          // the half-resolution copy of the whole floor region (coarse_ is inside it)
  std::vector<cv::Point2f> frame_points_;
  std::array<double, 7> ideal_hu_log_{};  // sign(h)·log10|h| of the ideal star, 0 where |h| is negligible
  cv::Mat kernel_;
  cv::Mat small_, background_, ratio_, threshold_small_, threshold_full_;
  cv::Mat binary_;
  cv::Mat scratch_;
  cv::Mat refine_binary_, refine_scratch_, interior_, midpoint_;
  cv::Mat refine_ratio_, refine_floor_, refine_level_;
  cv::Mat repaired_, median_lo_, median_hi_, band_top_, band_bottom_;
  std::vector<double> row_jump_, sorted_jump_;
  std::vector<cv::Vec2i> sync_bands_;
  std::vector<std::vector<cv::Point>> refine_contours_;
  double threshold_ratio_ = 0.0;
  std::vector<std::vector<cv::Point>> contours_;
  struct MergedOutline {
    double area = 0.0;               // half-resolution pixels²
    std::vector<cv::Point> contour;  // half-resolution copy
  };
  std::vector<MergedOutline> merged_;  // split_merged's outlines, all of the first level
  std::vector<uchar> blob_ratios_;
  bool splitting_ = false;  // inside split_merged
  cv::Mat blob_mask_, blob_binary_;
  std::vector<TracedContour>* trace_ = nullptr;
  double level_ = 0.0;  // the threshold ratio of the binary image being searched
  void note(const cv::Rect& coarse_box, ContourFate fate, double area = 0.0, const StarShapeScore& shape = {},
            bool refined = false);
};

}  // namespace quad::vision
