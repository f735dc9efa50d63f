// Failure analysis of the station on a generated set: for every star in full view that the station did
// not find (and every false fix), why. Each view is searched again with a traced detector (star_detector.h
// TracedContour) and the contours whose box holds the star's true centre (projected through the
// calibration) tell the stage that lost it:
//   no_contour        nothing dark enough there at any threshold level (or removed by the opening)
//   too_few_points, touches_border, small_raw_area, small_area
//   shape/merged      the contour failed the shape test and is much larger than the star (texture,
//                     shadow or a neighbour joined it)
//   shape/<limit>     the shape test failed on its own: elongation, profile, fourfold, harmonic, solidity
// and when both views accepted it: row_gate (rectified rows too far apart), rank (not among the best
// three of its view), lost_to_false (another pair won), range, inaccurate (found beyond 5 % of range).
//   vision_eval_explain --sets DIR --calib calib.yaml [--settings S.yaml] [--conditions a,b] [--list]
//                       [--crops DIR]   (both views around each lost star, enlarged, for looking at)
//                       [--features F.csv]  (one line per fix or refused pair: what the station measured, and its error;
//                                            guided: one view's outline a near miss;
//                                            transferred: found by the other view's outline;
//                                            split: an outline found inside a larger one (split_merged);
//                                            refused: why the station dropped it)
// Use on the tuning split only: the held-out split is for the final measurement.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/ideal_star.h"
#include "quad/vision/settings_file.h"
#include "quad/vision/stereo_locator.h"

namespace {

using namespace quad::vision;
namespace fs = std::filesystem;

constexpr double kMatchFraction = 0.05;  // as vision_eval.py: a fix within 5 % of the range is the star
constexpr double kStarAreaM2 = 0.04525;  // 0.40 m tip to tip, inner ratio 0.4: 8 · ½ · 0.2 · 0.08 · sin 45°
constexpr double kMergedAreaFactor = 1.6;

struct Truth {
  std::string left, right;
  bool in_view = false;
  cv::Vec3d p;
  double range = 0.0;
};

std::vector<std::string> cells(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string c;
  while (std::getline(ss, c, ',')) out.push_back(c);
  return out;
}

std::vector<Truth> read_truth(const fs::path& dir) {
  std::ifstream pairs(dir / "pairs.csv"), truth(dir / "truth.csv");
  if (!pairs || !truth) throw std::runtime_error(dir.string() + ": pairs.csv or truth.csv missing");
  std::string p, t;
  std::getline(pairs, p);
  std::getline(truth, t);
  std::vector<Truth> out;
  while (std::getline(pairs, p) && std::getline(truth, t)) {
    const std::vector<std::string> names = cells(p), c = cells(t);
    if (names.size() < 2 || c.size() < 7) throw std::runtime_error((dir / "truth.csv").string() + ": bad line");
    out.push_back({(dir / names[0]).string(), (dir / names[1]).string(), c[1] == "1",
                   cv::Vec3d(std::stod(c[3]), std::stod(c[4]), std::stod(c[5])), std::stod(c[6])});
  }
  return out;
}

// The true centre in one camera's raw image.
cv::Point2d project(const StereoCalibration& c, int camera, const cv::Vec3d& p_left) {
  const cv::Vec3d p = camera == 0 ? p_left : c.rig.R * p_left + c.rig.T;
  std::vector<cv::Point2d> px;
  const CameraIntrinsics& k = camera == 0 ? c.rig.left : c.rig.right;
  cv::projectPoints(std::vector<cv::Point3d>{cv::Point3d(p)}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k.K, k.D, px);
  return px[0];
}

std::string shape_limit(const StarShapeScore& s, const StarShapeLimits& l) {
  if (s.elongation > l.max_elongation) return "elongation";
  if (s.profile_rms > l.max_profile_rms) return "profile";
  if (s.fourfold < l.min_fourfold) return "fourfold";
  if (s.other_harmonic > l.max_other_harmonic) return "harmonic";
  return "solidity";
}

// Why one view lost the star: the most advanced fate among the contours around its true centre.
std::string view_reason(const std::vector<TracedContour>& trace, cv::Point2d centre, double expected_area,
                        const StarShapeLimits& limits, std::string* detail) {
  const TracedContour* best = nullptr;
  for (const TracedContour& t : trace) {
    if (!t.frame_box.contains(cv::Point(cvRound(centre.x), cvRound(centre.y)))) continue;
    if (best == nullptr || static_cast<int>(t.fate) > static_cast<int>(best->fate)) best = &t;
  }
  if (best == nullptr) return "no_contour";
  if (best->fate != ContourFate::kShape) return to_string(best->fate);
  if (best->area > kMergedAreaFactor * expected_area) return "shape/merged";
  if (detail != nullptr) {
    char text[160];
    std::snprintf(text, sizeof text, " [area/expected %.2f elong %.2f profile %.3f fourfold %.3f harmonic %.2f solidity %.2f]",
                  best->area / expected_area, best->shape.elongation, best->shape.profile_rms, best->shape.fourfold,
                  best->shape.other_harmonic, best->shape.solidity);
    *detail += text;
  }
  return "shape/" + shape_limit(best->shape, limits);
}

}  // namespace

namespace {

// One camera's traced search and the candidate (index in best-first order) that holds the true centre.
struct ViewAnalysis {
  std::string reason;
  int rank = -1;
  cv::Point2d centroid;  // rectified
};

class Explainer {
 public:
  Explainer(const StereoCalibration& calibration, const LocatorSettings& settings)
      : calibration_(calibration), settings_(settings), locator_(calibration, no_tracking(settings)) {
    std::vector<cv::Point2f> ideal;
    for (const cv::Point2d& p : star_vertices(StarShape{})) ideal.emplace_back(p * 1000.0);
    const cv::Moments m = cv::moments(ideal);
    ideal_sigma_ = std::sqrt(m.mu20 / m.m00) / 1000.0;
    for (int camera = 0; camera < 2; ++camera) {
      detectors_.emplace_back(settings.detector, PointRectifier(calibration, camera, settings.undistort_iterations));
    }
  }

  // 3-D errors (% of range) of the found stars: the fix, and the star pose's centre.
  std::vector<double> centroid_errors, pose_errors;
  std::string details;  // shape scores of the last explain()'s lost views
  StarFix last_fix;     // the last explain()'s fix (its outlines drawn on the crops)

  // The pair's outcome: "found", "no_star" (nothing expected, nothing fixed), "false_fix", or why missed.
  std::string explain(const Truth& t, const cv::Mat& left, const cv::Mat& right, std::FILE* features = nullptr,
                      const std::string& condition = "") {
    details.clear();
    last_fix = locator_.locate(left, right);
    const StarFix& fix = last_fix;
    if (features != nullptr && (fix.found || fix.refused != nullptr)) write_features(features, condition, t, fix);
    const bool hit = fix.found && t.in_view && cv::norm(fix.p_left - t.p) <= kMatchFraction * t.range;
    if (hit) {
      centroid_errors.push_back(100.0 * cv::norm(fix.p_left - t.p) / t.range);
      if (fix.pose.valid) pose_errors.push_back(100.0 * cv::norm(fix.pose.t_C - t.p) / t.range);
      return "found";
    }
    if (!t.in_view) return fix.found ? "false_fix/no_star" : "no_star";
    if (fix.found && cv::norm(fix.p_left - t.p) <= 0.2 * t.range) {
      char text[160];
      std::snprintf(text, sizeof text, " [error %.1f %% of range, rows %.2f px, from pose %d, pose valid %d rms %.2f px error %.1f %%]",
                    100.0 * cv::norm(fix.p_left - t.p) / t.range, fix.row_difference_px, fix.position_from_pose ? 1 : 0,
                    fix.pose.valid ? 1 : 0, fix.pose.rms_px, 100.0 * cv::norm(fix.pose.t_C - t.p) / t.range);
      details = text;
      return "inaccurate";
    }
    const ViewAnalysis views[2] = {analyse(0, left, t), analyse(1, right, t)};
    std::string why;
    for (int camera = 0; camera < 2; ++camera) {
      if (views[camera].rank >= 0) continue;
      why += std::string(why.empty() ? "" : " ") + (camera == 0 ? "L:" : "R:") + views[camera].reason;
    }
    if (!why.empty()) return why;
    if (fix.found) return "lost_to_false";
    if (std::max(views[0].rank, views[1].rank) >= 3) return "rank";
    if (fix.refused != nullptr) {
      char text[240];
      std::snprintf(text, sizeof text,
                    " [refused: %s; off the axis %.1f°, pose valid %d, size ratio %.3f, rms %.2f px; outlines aligned %d,"
                    " residual %.2f px, row shift %.2f px]",
                    fix.refused, std::acos(std::clamp(t.p[2] / t.range, -1.0, 1.0)) * 180.0 / CV_PI,
                    fix.pose.valid ? 1 : 0, fix.contour_size_ratio, fix.pose.rms_px, fix.outline.valid ? 1 : 0,
                    fix.outline.residual_px, fix.outline.shift.y);
      details = text;
      return "range";
    }
    if (std::fabs(views[0].centroid.y - views[1].centroid.y) > settings_.max_row_difference_px) {
      char text[80];
      std::snprintf(text, sizeof text, " [rows %.2f px apart]", std::fabs(views[0].centroid.y - views[1].centroid.y));
      details = text;
      return "row_gate";
    }
    return "range";
  }

 private:
  // One line of --features: what the station knows about a fix, and the truth's verdict.
  void write_features(std::FILE* out, const std::string& condition, const Truth& t, const StarFix& fix) const {
    const double range = cv::norm(fix.p_left);
    const double error = t.in_view ? 100.0 * cv::norm(fix.p_left - t.p) / t.range : -1.0;
    const double centroid_error = t.in_view ? 100.0 * cv::norm(fix.p_centroids - t.p) / t.range : -1.0;
    const double outline_error = t.in_view ? 100.0 * cv::norm(fix.p_outline - t.p) / t.range : -1.0;
    const double pose_error = t.in_view && fix.pose.valid ? 100.0 * cv::norm(fix.pose.t_C - t.p) / t.range : -1.0;
    const double off_axis = std::acos(std::clamp(fix.p_left[2] / range, -1.0, 1.0)) * 180.0 / CV_PI;
    const double f = calibration_.rectified_focal();
    const double expected = f * f * kStarAreaM2 / (range * range);
    const StarCandidate& l = fix.left_candidate;
    const StarCandidate& r = fix.right_candidate;
    // Depth from the outline's size: the larger second-moment axis of the rectified outline against the
    // ideal star's (tilt shortens the other axis only), over the fix's own depth.
    auto size_depth = [&](const StarCandidate& c) {
      const cv::Moments m = cv::moments(c.rectified);
      const double a = m.mu20 / m.m00, b = m.mu11 / m.m00, cc = m.mu02 / m.m00;
      const double l1 = 0.5 * (a + cc) + std::sqrt(0.25 * (a - cc) * (a - cc) + b * b);
      return f * ideal_sigma_ / std::sqrt(l1) / (calibration_.R1 * fix.p_left)[2];
    };
    const double outline_dd = fix.outline.valid ? fix.outline_disparity_px - fix.disparity_px : 0.0;
    const double outline_dy = fix.outline.valid ? fix.outline.shift.y - (fix.left_rectified.y - fix.right_rectified.y) : 0.0;
    std::fprintf(out, "%s,%s,%d,%.3f,%.3f,%.2f,%.3f,%.3f,%.3f,%.3f,%.4f,%.4f,%.3f,%.3f,%d,%d,%d,%.3f,%.4f,%.4f,%d,%.4f,%.4f,%.3f,%.3f,%d,%.4f,%.4f,%.4f,%.3f,%.5f,%.5f,%.5f,%.4f,%.3f,%d,%d,%d,%s\n",
                 condition.c_str(), fs::path(t.left).filename().c_str(), t.in_view ? 1 : 0, error, range, off_axis,
                 fix.row_difference_px, fix.disparity_px, l.area / expected, r.area / expected, l.hu_distance,
                 r.hu_distance, l.solidity, r.solidity, l.refined ? 1 : 0, r.refined ? 1 : 0, fix.pose.valid ? 1 : 0,
                 fix.pose.rms_px, fix.pose_offset, fix.contour_size_ratio, fix.position_from_pose ? 1 : 0,
                 size_depth(l), size_depth(r), centroid_error, pose_error, fix.outline.valid ? 1 : 0, outline_dd,
                 outline_dy, fix.outline.residual_px, fix.outline.inlier_fraction, cv::norm(fix.p_centroids),
                 cv::norm(fix.pose.t_C), cv::norm(fix.p_outline), fix.pose_disparity_px - fix.outline_disparity_px,
                 outline_error, fix.guided ? 1 : 0, fix.transferred ? 1 : 0, l.split || r.split ? 1 : 0, fix.refused != nullptr ? fix.refused : "");
  }

  static LocatorSettings no_tracking(LocatorSettings s) {
    s.track_roi = false;  // independent pairs
    return s;
  }

  ViewAnalysis analyse(int camera, const cv::Mat& gray, const Truth& t) {
    std::vector<TracedContour> trace;
    detectors_[camera].set_trace(&trace);
    const std::vector<StarCandidate> candidates = detectors_[camera].detect(gray, cv::Rect());
    detectors_[camera].set_trace(nullptr);
    const cv::Point2d centre = project(calibration_, camera, t.p);
    ViewAnalysis v;
    for (size_t i = 0; i < candidates.size(); ++i) {
      if (!candidates[i].box.contains(cv::Point(cvRound(centre.x), cvRound(centre.y)))) continue;
      v.rank = static_cast<int>(i);
      v.centroid = candidates[i].centroid;
      return v;
    }
    const double f = calibration_.rectified_focal();
    const double expected_area = f * f * kStarAreaM2 / (t.range * t.range);
    v.reason = view_reason(trace, centre, expected_area, settings_.detector.shape, &details);
    return v;
  }

  StereoCalibration calibration_;
  LocatorSettings settings_;
  StereoStarLocator locator_;
  std::vector<StarDetector> detectors_;
  double ideal_sigma_ = 0.0;  // the ideal star's second-moment radius, metres
};

std::map<std::string, std::string> options(int argc, char** argv) {
  std::map<std::string, std::string> o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--list") o[a] = "1";
    else if (i + 1 < argc) o[a] = argv[++i];
    else throw std::runtime_error("option " + a + " needs a value");
  }
  if (!o.count("--sets") || !o.count("--calib")) {
    throw std::runtime_error("usage: vision_eval_explain --sets DIR --calib calib.yaml [--settings S.yaml] "
                             "[--conditions a,b] [--list] [--crops DIR] [--features F.csv]");
  }
  return o;
}

// Both views around the star's true centre (around the fix on a pair without a star in full view),
// enlarged ×3, side by side: DIR/<condition>_<left name>.png.
// The station's outlines, when it paired two, are drawn in white.
void write_crops(const fs::path& dir, const std::string& condition, const Truth& t, const StereoCalibration& c,
                 const StarFix& fix) {
  constexpr int kHalf = 60;
  std::vector<cv::Mat> crops;
  for (int camera = 0; camera < 2; ++camera) {
    const cv::Mat gray = cv::imread(camera == 0 ? t.left : t.right, cv::IMREAD_GRAYSCALE);
    const cv::Point2d centre = project(c, camera, !t.in_view && fix.found ? fix.p_left : t.p);
    const cv::Rect box = cv::Rect(cvRound(centre.x) - kHalf, cvRound(centre.y) - kHalf, 2 * kHalf, 2 * kHalf) &
                         cv::Rect(0, 0, gray.cols, gray.rows);
    cv::Mat crop(2 * kHalf, 2 * kHalf, CV_8UC1, cv::Scalar(128)), big;
    if (!box.empty()) gray(box).copyTo(crop(cv::Rect(0, 0, box.width, box.height)));
    cv::resize(crop, big, cv::Size(), 3, 3, cv::INTER_NEAREST);
    std::vector<cv::Point> outline = camera == 0 ? fix.left_contour : fix.right_contour;
    for (cv::Point& p : outline) p = (p - box.tl()) * 3 + cv::Point(1, 1);
    if (!outline.empty()) cv::polylines(big, std::vector<std::vector<cv::Point>>{outline}, true, cv::Scalar(255));
    crops.push_back(big);
  }
  cv::Mat both;
  cv::hconcat(crops, both);
  fs::create_directories(dir);
  cv::imwrite((dir / (condition + "_" + fs::path(t.left).stem().string() + ".png")).string(), both);
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * (v.size() - 1) + 0.5)];
}

void print_counts(const std::string& title, const std::map<std::string, int>& counts, int stars) {
  std::printf("%s (%d stars in full view)\n", title.c_str(), stars);
  std::vector<std::pair<int, std::string>> sorted;
  for (const auto& [reason, n] : counts) sorted.emplace_back(-n, reason);
  std::sort(sorted.begin(), sorted.end());
  for (const auto& [n, reason] : sorted) std::printf("  %5d  %s\n", -n, reason.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::map<std::string, std::string> o = options(argc, argv);
    const StereoCalibration calibration = load_calibration(o.at("--calib"));
    const StationSettings settings = o.count("--settings") ? load_station_settings(o.at("--settings")) : StationSettings{};
    const std::string only = o.count("--conditions") ? "," + o.at("--conditions") + "," : "";
    Explainer explainer(calibration, settings.locator);
    std::map<std::string, int> total;
    int total_stars = 0;
    std::FILE* features = nullptr;
    if (o.count("--features")) {
      features = std::fopen(o.at("--features").c_str(), "w");
      if (features == nullptr) throw std::runtime_error(o.at("--features") + ": cannot write");
      std::fprintf(features, "condition,left,in_view,error_percent,range_m,off_axis_deg,row_difference_px,disparity_px,"
                             "area_left,area_right,profile_left,profile_right,solidity_left,solidity_right,"
                             "refined_left,refined_right,pose_valid,pose_rms_px,pose_offset,size_ratio,from_pose,size_depth_left,size_depth_right,centroid_error,pose_error,"
                             "outline_valid,outline_dd,outline_dy,outline_residual,outline_inliers,range_centroids,range_pose,range_outline,pose_outline_dd,outline_error,guided,transferred,split,refused\n");
    }
    std::vector<fs::path> dirs;
    for (const fs::directory_entry& d : fs::directory_iterator(o.at("--sets"))) {
      if (fs::exists(d.path() / "truth.csv")) dirs.push_back(d.path());
    }
    std::sort(dirs.begin(), dirs.end());
    for (const fs::path& dir : dirs) {
      const std::string condition = dir.filename().string();
      if (!only.empty() && only.find("," + condition + ",") == std::string::npos) continue;
      std::map<std::string, int> counts;
      int stars = 0;
      for (const Truth& t : read_truth(dir)) {
        const std::string outcome = explainer.explain(t, cv::imread(t.left, cv::IMREAD_GRAYSCALE),
                                                      cv::imread(t.right, cv::IMREAD_GRAYSCALE), features, condition);
        stars += t.in_view ? 1 : 0;
        if (outcome == "found" || outcome == "no_star") continue;
        ++counts[outcome];
        if (o.count("--crops")) write_crops(o.at("--crops"), condition, t, calibration, explainer.last_fix);
        ++total[outcome];
        if (o.count("--list")) {
          std::printf("%s %s: %s%s\n", condition.c_str(), fs::path(t.left).filename().c_str(), outcome.c_str(),
                      explainer.details.c_str());
        }
      }
      total_stars += stars;
      print_counts(condition, counts, stars);
    }
    if (features != nullptr) std::fclose(features);
    print_counts("all", total, total_stars);
    std::printf("found stars: median error of the fix %.3f %% (p95 %.3f %%), of the pose centre %.3f %% (p95 %.3f %%)\n",
                percentile(explainer.centroid_errors, 0.5), percentile(explainer.centroid_errors, 0.95),
                percentile(explainer.pose_errors, 0.5), percentile(explainer.pose_errors, 0.95));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "vision_eval_explain: %s\n", e.what());
    return 1;
  }
}
