// Stereo fix of the star (thesis eq. 8.2–8.5, errata applied): detect the star in both views, undistort
// and rectify the contour points, take the centroid from the contour's moments, match by rectified row,
// triangulate from the disparity, and express the result in the left camera frame and the body frame.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/outline_alignment.h"
#include "quad/vision/star_detector.h"
#include "quad/vision/star_pose.h"
#include "quad/vision/stereo_calibration.h"

namespace quad::vision {

struct LocatorSettings {
  DetectorSettings detector;
  double max_row_difference_px = 2.5;  // rectified centroid rows must agree within this
  double min_range_m = 0.2;            // depths outside [min, max] are no fix
  double max_range_m = 6.0;
  double centroid_sigma_px = 0.1;      // 1-σ noise of one rectified centroid coordinate (uncertainty)
  bool track_roi = true;               // search around the last fix first, full frame as fallback
  double roi_growth = 1.6;             // ROI = last contour box scaled by this about its centre ...
  int roi_margin_px = 24;              // ... plus this margin on every side
  // The right view is searched only where the left view's candidates can appear in it: their rectified
  // rows (± row_window_px), at disparities between guided_min_scale and guided_max_scale times the one
  // their area implies for a star of pose.tip_radius_m (a tilted star looks smaller, so farther), within
  // the range limits. Off (and for the thesis method): the whole right frame.
  bool guided_search = true;
  double row_window_px = 8.0;
  double guided_min_scale = 0.6;
  double guided_max_scale = 1.5;
  // Guided acceptance (robust method): an outline that fails the shape test but is within
  // detector.near_miss_shape (a near miss: a tip notched, blurred or faulted in one view) pairs with a star
  // that passes it in the other view, never with another near miss, when no two passing stars pair up.
  // Its area must be within [guided_min_area_ratio, guided_max_area_ratio] of the star's, the disparity
  // within [guided_min_scale, guided_max_scale] of the one the star's area implies, and the centroids'
  // rows within guided_max_row_difference_px (the defect moves the near miss's centroid). A left view with
  // near misses only places the right search at them. Two passing stars whose centroids' rows are beyond
  // max_row_difference_px but within guided_max_row_difference_px pair under the same checks (a defect
  // of one view moved its centroid). The fix stands only if the two outlines lay onto
  // each other (outline_alignment.h) within guided_max_residual_px RMS, at rows within
  // max_row_difference_px: a defect confined to a tip leaves the rest of the outline aligned, a torn or
  // merged outline or another shape does not. Needs estimate_pose (the edge points).
  bool guided_acceptance = true;
  double guided_min_area_ratio = 0.7;
  double guided_max_area_ratio = 1.4;
  double guided_max_row_difference_px = 6.0;
  double guided_max_residual_px = 1.3;
  // Outline transfer (robust method, with guided acceptance): when nothing pairs, or a guided pair is
  // refused by the checks after the pose step, a passing star of one view is sought in the other by its
  // outline (outline_transfer.h), at the guided search's disparities and rows within
  // guided_max_row_difference_px; the pair is then judged as a guided pair.
  bool outline_transfer = true;
  int undistort_iterations = 40;       // the thesis lenses are strongly distorted (κ1 ≈ −0.5)
  bool estimate_pose = true;           // the star's attitude from its eight vertices (star_pose.h)
  StarPoseSettings pose;               // its inner_ratio follows detector.inner_ratio
  // The fix's position is the fitted pose's centre when the fit is valid and within this fraction of the
  // range of the centroids' triangulation (else the triangulated centroids). sigma and the covariance
  // stay those of the centroid model (conservative for the pose centre). A valid fit of the right size
  // is the better position even several per cent from the centroids: there a merge, a shadow edge or a
  // fault displaced one view's centroid, not the eight edges of both.
  bool position_from_pose = true;
  // The pose's edge points sought again along the fitted star's own projected edges (pose_edge_passes
  // searches, each followed by the edge fit; the refit is kept when its points lie closer to its edges
  // than the contours' to theirs): where the contour left part of the star out or took in some floor (a
  // shadow across it, a fault band at a tip), the contour's edge points are off the star's edge by more
  // than the ±2 px their search reaches; the fitted star's edges are not.
  int pose_edge_passes = 1;
  // With estimate_pose: a fix this far off the left camera's axis (radians) needs a valid pose fit.
  double require_pose_beyond_rad = 0.785;
  double max_pose_offset = 0.2;
  // A close pose fit (vertex RMS up to attitude_max_rms_px) whose fitted size differs from the star's
  // (pose.tip_radius_m) by more than this fraction contradicts the fix (no fix then): the fit's size
  // scales with its depth, so a size 7 % off is a range 7 % off (the outline of one view cut into or grown
  // by a shadow, a merge or a fault). A coarse fit of the wrong size is only not used for the position:
  // its vertices are off, not the star (on the tuning split, 4 160 stars, the 22 such fixes took their
  // position from the outlines: within 1.4 % of the range, one 3.9 %). The size checked is the fit's to
  // the contours (StarFix::contour_size_ratio): the refit along the projection (pose_edge_passes) grows
  // a small, strongly blurred star, whose blunted tips and filled corners the sharp model does not
  // have, by up to 12 % without moving its range.
  double max_pose_size_error = 0.07;
  // The pose's attitude is reported (StarFix::pose.valid) only for a vertex RMS up to this; a fit up to
  // pose.max_rms_px still gives the position and the checks above.
  double attitude_max_rms_px = 1.5;
  // Nor when the disparity gradient the fitted star's plane implies (b (n_x, n_y) / (n · t), rectified
  // pixels per pixel) differs from the aligned outlines' by more than this. On four conditions of the
  // tuning split (analog faults, combined, lighting, plain) the 35 attitudes more than 10° off (most of
  // them fits tilted 25–90° on far stars with blurred or distorted outlines) differed by 0.007–0.065,
  // 32 of them by more than 0.02; the 1 527 others by 0.0034 in the median, 0.021 at the 99th percentile.
  double attitude_max_gradient_error = 0.02;
  // The centroids' disparity is replaced by the one that lays the right outline onto the left
  // (outline_alignment.h): a local defect of one view moves that view's centroid, not the whole
  // outline's fit. The fix's position without a pose comes from it. Needs estimate_pose (its edge points).
  bool outline_disparity = true;
  // A coarse pose (vertex RMS above attitude_max_rms_px) whose centre's disparity differs from the
  // outline's by more than this (pixels) is not used for the position: the outline's is. A coarse pose
  // refitted along its projection (pose_edge_passes) no longer rests on its vertices: it gives the
  // position unless its own size is off by more than max_pose_size_error.
  double coarse_pose_max_disparity_px = 0.6;
  // No fix beyond this angle off the left camera's axis. The default, 55°, is beyond the corners of a
  // 720 × 480 FPV image (54°): a calibration from chessboards seen up to the image's edges put the tuning
  // split's stars 43–48° off the axis within 3 % of the range (84 fixes of 4 160 stars). Lower it to about the angle `calibrate`
  // prints (StereoCalibrationResult::widest_off_axis_rad) plus a few degrees when the chessboards did not
  // reach the edges: beyond, the lens model is extrapolated (a calibration whose corners reached 42° put
  // stars 46° off the axis 4–6 % off).
  double max_off_axis_rad = 0.96;
};

// Wall time of each stage of one stereo frame, microseconds.
struct StageTimes {
  double threshold_morphology_us = 0.0;
  double contours_filters_us = 0.0;
  double rectify_points_us = 0.0;
  double triangulation_us = 0.0;
  double pose_us = 0.0;
  double total_us() const {
    return threshold_morphology_us + contours_filters_us + rectify_points_us + triangulation_us + pose_us;
  }
};

struct StarFix {
  bool found = false;
  cv::Vec3d p_left;                   // star in the left camera frame (OpenCV axes), metres
  cv::Vec3d sigma_left;               // 1-σ of each coordinate from the centroid noise
  cv::Matx33d cov_left = cv::Matx33d::zeros();  // the full covariance of p_left, m²
  StarPose pose;                      // the star's attitude (valid when its eight vertices were fitted)
  double contour_size_ratio = 1.0;    // the size of the pose fitted to the contours (max_pose_size_error's)
  bool pose_refitted = false;         // the pose is its refit along its projection (pose_edge_passes)
  cv::Point2d left_rectified;         // rectified centroids, pixels
  cv::Point2d right_rectified;
  double disparity_px = 0.0;
  double row_difference_px = 0.0;
  std::vector<cv::Point> left_contour;   // raw image pixels, for display
  std::vector<cv::Point> right_contour;
  StarCandidate left_candidate, right_candidate;  // the paired candidates (areas, shape distances)
  bool guided = false;                // a guided pair: a near miss, rows beyond the gate, or transferred
  bool transferred = false;           // one of them was found by the other's outline (outline_transfer)
  bool used_roi = false;
  bool position_from_pose = false;    // p_left is the pose's centre (else the triangulated centroids)
  cv::Vec3d p_centroids;              // the triangulated centroids (p_left unless from the pose)
  double pose_offset = 0.0;           // |pose centre − triangulated centroids| / range (valid pose)
  OutlineAlignment outline;           // the right outline laid onto the left (sub-pixel edges, rectified)
  double outline_disparity_px = 0.0;  // the disparity that alignment gives (valid outline only)
  cv::Vec3d p_outline;                // the star triangulated with it (p_centroids without it)
  double pose_disparity_px = 0.0;     // the pose centre's disparity (valid pose only)
  double pose_gradient_error = 0.0;   // |the pose plane's disparity gradient − the outlines'| (both valid)
  const char* refused = nullptr;      // why a paired star gave no fix (the checks after the pose step)
  StageTimes times;
};

// An interlaced frame's first field over `region` at full height: the even rows as they are, each odd row
// interpolated (cubic) from the four even rows around it, so the edge search of a `deinterlace: field`
// fix sees one instant.
cv::Mat first_field(const cv::Mat& gray, const cv::Rect& region);

// p_B = R_BC·p_C + t_BC (thesis eq. 7.22): the star relative to the vehicle in body FRD.
cv::Vec3d camera_to_body(const CameraMount& mount, const cv::Vec3d& p_camera);

// The vehicle's position relative to the star in NED given R_IB (thesis eq. 8.5 with the erratum:
// p_I = −R_IB (R_BC p_C + t_BC)).
cv::Vec3d vehicle_position_from_star(const cv::Matx33d& R_IB, const CameraMount& mount,
                                     const cv::Vec3d& p_camera);

class StereoStarLocator {
 public:
  StereoStarLocator(const StereoCalibration& calibration, const LocatorSettings& settings);

  // One stereo frame (CV_8UC1 images of the calibrated size) to a fix.
  StarFix locate(const cv::Mat& left_gray, const cv::Mat& right_gray);

  // Forget the last fix: the next frame searches the full images.
  void reset_tracking();
  bool coarse_fit(const StarPose& pose) const;  // vertex RMS above attitude_max_rms_px
  bool wrong_size(double size_ratio) const;  // a fitted size off by more than max_pose_size_error

  const StereoCalibration& calibration() const { return calibration_; }
  const LocatorSettings& settings() const { return settings_; }

 private:
  struct ViewResult {
    std::vector<StarCandidate> candidates;
    std::vector<StarCandidate> near_misses;  // LocatorSettings::guided_acceptance
    bool used_roi = false;
  };
  // The detector's settings for the locator's (near misses kept with guided acceptance).
  static DetectorSettings detector_settings(const LocatorSettings& settings);
  // The disparity of a star whose rectified outline has this area (A = S f² / Z², so d = f b / Z = b √(A / S)).
  double disparity_for_area(double area_px) const;
  // A near miss `loose` may pair with the star `strict` at `disparity` (LocatorSettings::guided_acceptance).
  bool guided_pair(const StarCandidate& strict, const StarCandidate& loose, double disparity) const;
  ViewResult detect_view(StarDetector& detector, const cv::Mat& gray, const cv::Rect& last_box,
                         DetectorTimes* times);
  // The right frame's pixels where the star of one of the left candidates can appear
  // (LocatorSettings::guided_search); empty when none can.
  cv::Rect right_search_window(const std::vector<StarCandidate>& left) const;

  // The image the edge searches around one star read: the frame itself, or (deinterlace: field) its
  // first field around the star, whose top-left is `origin` in frame pixels.
  struct EdgeView {
    cv::Mat image;
    cv::Point origin;
  };
  EdgeView edge_view(const cv::Mat& gray, const StarCandidate& star) const;

  // The star's pose from the paired candidates, and the fix's position from it (LocatorSettings).
  void add_pose(const std::vector<cv::Point2f>& left_edges, const std::vector<cv::Point2f>& right_edges,
                const EdgeView& left_view, const EdgeView& right_view, StarFix& fix);
  // The star the pose fit places (settings_.pose with the detector's inner_ratio).
  StarPoseSettings pose_settings() const;
  // The pose fitted again to edge points sought along its own projected edges (pose_edge_passes).
  StarPose refit_along_projection(const StarPose& pose, const EdgeView& left_view, const EdgeView& right_view) const;
  bool star_inside_images(const StarPose& pose) const;  // the fitted star's corners within both frames

  // The point at rectified left pixel `left` with disparity `disparity` (thesis eq. 8.3-8.4), in the
  // rectified left frame, and in the left camera's.
  cv::Vec3d rectified_point(const cv::Point2d& left, double disparity) const;
  cv::Vec3d triangulate(const cv::Point2d& left, double disparity) const;

  // A passing star of one view sought in the other by its outline (LocatorSettings::outline_transfer):
  // the other view's candidate, or none (empty contour).
  StarCandidate transfer_candidate(const StarCandidate& star, bool star_is_left, const cv::Mat& left_gray,
                                   const cv::Mat& right_gray) const;

  // A candidate's sub-pixel edge points, rectified.
  std::vector<cv::Point2f> rectified_edges(const EdgeView& view, const StarCandidate& star,
                                           const NearRectifier& rectifier) const;

  StereoCalibration calibration_;
  LocatorSettings settings_;
  StarDetector left_detector_;
  StarDetector right_detector_;
  cv::Rect last_left_box_;
  cv::Rect last_right_box_;
  NearRectifier left_near_, right_near_;
  double star_area_m2_;  // the marker's area (pose.tip_radius_m, detector.inner_ratio)
};

}  // namespace quad::vision
