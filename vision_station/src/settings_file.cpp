#include "quad/vision/settings_file.h"

#include <cmath>
#include <stdexcept>
#include <variant>
#include <vector>

namespace quad::vision {

StationSettings load_station_settings(const std::string& path) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception&) {
    throw std::runtime_error(path + ": not a readable OpenCV YAML file");
  }
  if (!fs.isOpened()) throw std::runtime_error(path + ": cannot open settings file");
  StationSettings s;
  DetectorSettings& d = s.locator.detector;
  LocatorSettings& l = s.locator;
  using Field = std::variant<int*, double*, bool*>;
  const std::vector<std::pair<const char*, Field>> fields{
      {"background_cell_px", &d.background_cell_px}, {"background_window_px", &d.background_window_px},
      {"min_threshold_ratio", &d.min_threshold_ratio}, {"max_threshold_ratio", &d.max_threshold_ratio},
      {"morphology_kernel_px", &d.morphology_kernel_px}, {"refine_midpoint", &d.refine_midpoint}, {"edge_margin_px", &d.edge_margin_px},
      {"min_area_px", &d.min_area_px}, {"raw_area_prefilter", &d.raw_area_prefilter},
      {"min_aspect", &d.min_aspect}, {"ideal_vertex_count", &d.ideal_vertex_count},
      {"vertex_count_tolerance", &d.vertex_count_tolerance}, {"polygon_epsilon", &d.polygon_epsilon},
      {"min_hu_distance", &d.min_hu_distance}, {"max_hu_distance", &d.max_hu_distance},
      {"inner_ratio", &d.inner_ratio}, {"min_solidity", &d.min_solidity}, {"max_solidity", &d.max_solidity},
      {"max_row_difference_px", &l.max_row_difference_px}, {"min_range_m", &l.min_range_m},
      {"max_range_m", &l.max_range_m}, {"centroid_sigma_px", &l.centroid_sigma_px}, {"track_roi", &l.track_roi},
      {"roi_growth", &l.roi_growth}, {"roi_margin_px", &l.roi_margin_px}, {"guided_search", &l.guided_search},
      {"row_window_px", &l.row_window_px}, {"guided_min_scale", &l.guided_min_scale},
      {"guided_max_scale", &l.guided_max_scale},
      {"undistort_iterations", &l.undistort_iterations}, {"estimate_pose", &l.estimate_pose},
      {"pose_edge_passes", &l.pose_edge_passes},
      {"position_from_pose", &l.position_from_pose}, {"require_pose_beyond_rad", &l.require_pose_beyond_rad}, {"max_pose_offset", &l.max_pose_offset},
      {"max_pose_size_error", &l.max_pose_size_error},
      {"attitude_max_rms_px", &l.attitude_max_rms_px},
      {"attitude_max_gradient_error", &l.attitude_max_gradient_error}, {"outline_disparity", &l.outline_disparity},
      {"coarse_pose_max_disparity_px", &l.coarse_pose_max_disparity_px}, {"max_off_axis_rad", &l.max_off_axis_rad},
      {"star_tip_radius_m", &l.pose.tip_radius_m},
      {"pose_max_rms_px", &l.pose.max_rms_px}, {"pose_min_edge_sigma_px", &l.pose.min_edge_sigma_px},
      {"send_covariance", &s.send_covariance}, {"max_pair_skew_ms", &s.max_pair_skew_ms},
      {"field_period_ms", &s.field_period_ms},
      {"robust_window_px", &d.robust_window_px}, {"robust_min_ratio", &d.robust_min_ratio},
      {"robust_max_ratio", &d.robust_max_ratio},
      {"robust_low_ratio", &d.robust_low_ratio}, {"robust_low_level_always", &d.robust_low_level_always},
      {"robust_split_merged", &d.robust_split_merged}, {"max_elongation", &d.shape.max_elongation},
      {"max_profile_rms", &d.shape.max_profile_rms}, {"min_fourfold", &d.shape.min_fourfold},
      {"max_other_harmonic", &d.shape.max_other_harmonic}, {"min_shape_solidity", &d.shape.min_solidity},
      {"max_shape_solidity", &d.shape.max_solidity}, {"retry_max_profile_rms", &d.retry_shape.max_profile_rms},
      {"retry_min_fourfold", &d.retry_shape.min_fourfold}, {"retry_max_other_harmonic", &d.retry_shape.max_other_harmonic},
      {"retry_min_solidity", &d.retry_shape.min_solidity}, {"retry_max_solidity", &d.retry_shape.max_solidity},
      {"robust_require_midlevel", &d.robust_require_midlevel}, {"robust_floor_closing", &d.robust_floor_closing},
      {"robust_sync_repair", &d.robust_sync_repair}, {"robust_row_median", &d.robust_row_median},
      {"guided_acceptance", &l.guided_acceptance}, {"outline_transfer", &l.outline_transfer}, {"guided_min_area_ratio", &l.guided_min_area_ratio},
      {"guided_max_area_ratio", &l.guided_max_area_ratio}, {"guided_max_residual_px", &l.guided_max_residual_px},
      {"guided_max_row_difference_px", &l.guided_max_row_difference_px}, {"guided_max_elongation", &d.near_miss_shape.max_elongation},
      {"guided_max_profile_rms", &d.near_miss_shape.max_profile_rms}, {"guided_min_fourfold", &d.near_miss_shape.min_fourfold},
      {"guided_max_other_harmonic", &d.near_miss_shape.max_other_harmonic},
      {"guided_min_solidity", &d.near_miss_shape.min_solidity}, {"guided_max_solidity", &d.near_miss_shape.max_solidity}};
  for (const cv::FileNode& node : fs.root()) {
    const std::string key = node.name();
    if (key == "camera_to_body_R" || key == "camera_to_body_t") {
      cv::Mat m;
      node >> m;
      if (key == "camera_to_body_R" && m.total() == 9) {
        m.convertTo(m, CV_64F);
        s.mount.R_BC = cv::Matx33d(m.reshape(1, 3));
      } else if (key == "camera_to_body_t" && m.total() == 3) {
        m.convertTo(m, CV_64F);
        s.mount.t_BC = cv::Vec3d(m.reshape(1, 3));
      } else {
        throw std::runtime_error(path + ": key '" + key + "' must be a " + (key.back() == 'R' ? "3x3" : "3x1") + " matrix");
      }
      continue;
    }
    if (key == "method" || key == "deinterlace") {  // the two words-valued settings
      const std::string word = node.isString() ? static_cast<std::string>(node) : "";
      const bool ok = key == "method" ? parse_detector_method(word, d.method) : parse_deinterlace(word, d.deinterlace);
      if (!ok) {
        throw std::runtime_error(path + ": key '" + key + "' must be " +
                                 (key == "method" ? "thesis or robust" : "none, field or blend"));
      }
      continue;
    }
    bool known = false;
    for (const auto& [name, field] : fields) {
      if (key != name) continue;
      known = true;
      if (!node.isReal() && !node.isInt()) throw std::runtime_error(path + ": key '" + key + "' must be a number");
      const double value = static_cast<double>(node);
      if (auto p = std::get_if<int*>(&field)) **p = static_cast<int>(value);
      if (auto p = std::get_if<double*>(&field)) **p = value;
      if (auto p = std::get_if<bool*>(&field)) **p = value != 0.0;
    }
    if (!known) throw std::runtime_error(path + ": unknown setting '" + key + "'");
  }
  if (!(s.field_period_ms >= 0.0 && s.field_period_ms <= 100.0)) {
    throw std::runtime_error(path + ": key 'field_period_ms' must be within [0, 100]");
  }
  return s;
}

int64_t view_time_offset_us(Deinterlace deinterlace, double field_period_ms) {
  switch (deinterlace) {
    case Deinterlace::kField: return -std::llround(field_period_ms * 1e3);
    case Deinterlace::kBlend: return -std::llround(field_period_ms * 0.5e3);
    case Deinterlace::kNone: break;
  }
  return 0;
}

}  // namespace quad::vision
