// Locator settings from an OpenCV FileStorage YAML: any subset of the keys below overrides the defaults;
// an unknown key or a non-numeric value is an error naming the file and key.
//   background_cell_px background_window_px min_threshold_ratio max_threshold_ratio morphology_kernel_px
//   refine_midpoint
//   edge_margin_px min_area_px raw_area_prefilter min_aspect ideal_vertex_count vertex_count_tolerance
//   polygon_epsilon min_hu_distance max_hu_distance inner_ratio min_solidity max_solidity
//   max_row_difference_px min_range_m max_range_m centroid_sigma_px track_roi roi_growth roi_margin_px
//   guided_search row_window_px guided_min_scale guided_max_scale
//   undistort_iterations estimate_pose pose_max_rms_px pose_min_edge_sigma_px
//   send_covariance (1: LANDING_TARGET_COVARIANCE after each LANDING_TARGET)
//   max_pair_skew_ms (left/right capture times further apart are no pair; 0: half the frame period)
//   field_period_ms (interlaced sources: the time between the two fields of a frame)
//   method (thesis | robust), deinterlace (none | field | blend), robust_window_px robust_min_ratio
//   robust_max_ratio robust_low_ratio robust_low_level_always robust_split_merged max_elongation max_profile_rms min_fourfold max_other_harmonic min_shape_solidity
//   max_shape_solidity robust_floor_closing robust_sync_repair robust_row_median robust_require_midlevel
//   retry_max_profile_rms retry_min_fourfold retry_max_other_harmonic retry_min_solidity retry_max_solidity
//   guided_acceptance guided_min_area_ratio guided_max_area_ratio guided_max_row_difference_px
//   guided_max_residual_px (a near miss pairs with a star: LocatorSettings) outline_transfer
//   guided_max_elongation guided_max_profile_rms guided_min_fourfold guided_max_other_harmonic
//   guided_min_solidity guided_max_solidity (DetectorSettings::near_miss_shape)
//   position_from_pose max_pose_offset require_pose_beyond_rad max_pose_size_error attitude_max_rms_px
//   attitude_max_gradient_error
//   star_tip_radius_m (the marker's centre-to-tip radius, metres)
//   camera_to_body_R (3x3), camera_to_body_t (3x1): thesis eq. 7.22 by default
#pragma once

#include <cstdint>
#include <string>

#include "quad/vision/stereo_locator.h"

namespace quad::vision {

struct StationSettings {
  LocatorSettings locator;
  CameraMount mount = thesis_camera_mount();
  bool send_covariance = true;
  double max_pair_skew_ms = 0.0;  // 0: half the measured frame period
  double field_period_ms = 1000.0 / 59.94;  // NTSC; 20 for PAL
};

// The instant the detector's view of a frame shows, relative to the frame's time stamp (microseconds,
// negative: earlier). A frame is stamped when it has been received, at the end of its last field; with
// `deinterlace: field` the detector sees the first field (the even rows), which ended one field period
// before the stamp; with `blend` the mean of both fields, half a period before it; with `none`
// (progressive sources) the frame at its stamp. The fix sent for the frame carries this capture time.
int64_t view_time_offset_us(Deinterlace deinterlace, double field_period_ms);

StationSettings load_station_settings(const std::string& path);  // throws std::runtime_error

}  // namespace quad::vision
