#include "quad/vision/stereo_locator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/ideal_star.h"
#include "quad/vision/outline_transfer.h"

namespace quad::vision {
namespace {

using Clock = std::chrono::steady_clock;

double microseconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

// Candidates considered per view when pairing left with right.
constexpr size_t kMaxCandidatesPerView = 3;

// Contour points per view the pose is fitted to (star_pose.h).
constexpr size_t kMaxPoseContourPoints = 240;

double star_area(const StarShape& shape) {
  std::vector<cv::Point2f> outline;
  for (const cv::Point2d& p : star_vertices(shape)) outline.emplace_back(p);
  return std::fabs(cv::contourArea(outline));
}

}  // namespace

cv::Vec3d camera_to_body(const CameraMount& mount, const cv::Vec3d& p_camera) {
  return mount.R_BC * p_camera + mount.t_BC;  // thesis eq. 7.22
}

cv::Vec3d vehicle_position_from_star(const cv::Matx33d& R_IB, const CameraMount& mount,
                                     const cv::Vec3d& p_camera) {
  return -(R_IB * camera_to_body(mount, p_camera));  // thesis eq. 8.5 (erratum: sign and t_BC)
}

StereoStarLocator::StereoStarLocator(const StereoCalibration& calibration, const LocatorSettings& settings)
    : calibration_(calibration),
      settings_(settings),
      left_detector_(detector_settings(settings), PointRectifier(calibration, 0, settings.undistort_iterations)),
      right_detector_(detector_settings(settings), PointRectifier(calibration, 1, settings.undistort_iterations)),
      left_near_(calibration, 0),
      right_near_(calibration, 1),
      star_area_m2_(star_area(StarShape{settings.pose.tip_radius_m, settings.detector.inner_ratio})) {}

DetectorSettings StereoStarLocator::detector_settings(const LocatorSettings& settings) {
  DetectorSettings d = settings.detector;
  // A near miss's fix stands only on the outlines' alignment, which needs the edge points (estimate_pose).
  d.keep_near_misses = settings.guided_acceptance && settings.estimate_pose && d.method == DetectorMethod::kRobust;
  return d;
}

double StereoStarLocator::disparity_for_area(double area_px) const {
  return calibration_.baseline() * std::sqrt(area_px / star_area_m2_);
}

bool StereoStarLocator::guided_pair(const StarCandidate& strict, const StarCandidate& loose, double disparity) const {
  // The near miss must be the same star: as large as the passing one, and at the depth its size implies
  // (disparity_for_area), so a decoy on the same row at another depth is not taken.
  const double area_ratio = loose.area / strict.area;
  if (!(area_ratio >= settings_.guided_min_area_ratio && area_ratio <= settings_.guided_max_area_ratio)) return false;
  const double d = disparity_for_area(strict.area);
  return disparity >= settings_.guided_min_scale * d && disparity <= settings_.guided_max_scale * d;
}

namespace {

// o = the cubic midpoint (9 (b + c) − a − d) / 16 of four rows a, b, c, d one row pair apart, rounded and
// clamped. `__restrict` (o is written, a–d only read) and 16-bit arithmetic (|9 (b + c) − a − d + 8| <
// 2¹⁵) let the compiler vectorise it.
void cubic_middle_row(const uint8_t* __restrict a, const uint8_t* __restrict b, const uint8_t* __restrict c,
                      const uint8_t* __restrict d, uint8_t* __restrict o, int n) {
  for (int x = 0; x < n; ++x) {
    const int16_t v = static_cast<int16_t>((9 * (b[x] + c[x]) - a[x] - d[x] + 8) >> 4);
    o[x] = static_cast<uint8_t>(v < 0 ? 0 : v > 255 ? 255 : v);
  }
}

}  // namespace

cv::Mat first_field(const cv::Mat& gray, const cv::Rect& region) {
  // The frame's even rows (the first field) as they are, each odd row interpolated from the four even rows
  // around it (cubic: a linear mean biases a blurred edge's sub-pixel position with its phase to the rows).
  cv::Mat out(region.size(), CV_8UC1);
  const int last_even = (gray.rows - 1) & ~1;
  auto even_row = [&](int r) { return gray.ptr<uint8_t>(std::clamp(r, 0, last_even)) + region.x; };
  for (int y = 0; y < region.height; ++y) {
    const int row = region.y + y;
    uint8_t* o = out.ptr<uint8_t>(y);
    if (row % 2 == 0) {
      std::copy(even_row(row), even_row(row) + region.width, o);
      continue;
    }
    cubic_middle_row(even_row(row - 3), even_row(row - 1), even_row(row + 1), even_row(row + 3), o, region.width);
  }
  return out;
}

std::vector<cv::Point2f> StereoStarLocator::rectified_edges(const EdgeView& view, const StarCandidate& star,
                                                            const NearRectifier& rectifier) const {
  // Neighbouring edge points share pixels and carry nearly the same information: at most
  // kMaxPoseContourPoints evenly spaced points per view keep a near star as cheap as a far one.
  const size_t n = std::min(star.contour.size(), star.rectified.size());
  const size_t stride = std::max<size_t>((n + kMaxPoseContourPoints - 1) / kMaxPoseContourPoints, 1);
  std::vector<cv::Point> sampled;
  std::vector<cv::Point2f> guesses;
  for (size_t i = 0; i < n; i += stride) {
    sampled.push_back(star.contour[i]);
    guesses.push_back(star.rectified[i]);  // the detector's rectified copy of the same raw pixel
  }
  for (cv::Point& p : sampled) p -= view.origin;
  std::vector<cv::Point2f> raw = subpixel_edges(view.image, sampled);
  for (cv::Point2f& p : raw) p += cv::Point2f(view.origin);
  std::vector<cv::Point2f> rectified(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) rectified[i] = rectifier.rectified(raw[i], guesses[i]);
  return rectified;
}

StereoStarLocator::EdgeView StereoStarLocator::edge_view(const cv::Mat& gray, const StarCandidate& star) const {
  if (settings_.detector.deinterlace != Deinterlace::kField || star.contour.empty()) return EdgeView{gray, cv::Point(0, 0)};
  // The detector saw the first field only: so must the edges, or they mix two instants 1/60 s apart
  // (a vehicle climbing at 1 m/s moves its star's image a pixel between them). The field is made over
  // the star's box grown by the edge search's reach (5 px, bilinear one more) and a quarter of its size
  // (the refit's projected star reaches where a contour that left part of the star out did not).
  const cv::Rect box = cv::boundingRect(star.contour);
  const int margin = 8 + std::max(box.width, box.height) / 4;
  const cv::Rect region = cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
                          cv::Rect(0, 0, gray.cols, gray.rows);
  return EdgeView{first_field(gray, region), region.tl()};
}

StarPoseSettings StereoStarLocator::pose_settings() const {
  StarPoseSettings s = settings_.pose;
  s.inner_ratio = settings_.detector.inner_ratio;  // the star the detector looks for
  return s;
}

StarPose StereoStarLocator::refit_along_projection(const StarPose& pose, const EdgeView& left_view,
                                                   const EdgeView& right_view) const {
  // Points every kSpacingPx along the middle of each projected edge (its ends are the blurred corners),
  // each moved along the edge's normal (in raw pixels, through the lens) onto the grey-level edge. Two
  // pixels apart, no two points share a pixel of their bilinear samples, so their errors are independent
  // as the pose's covariance assumes.
  constexpr double kSpacingPx = 2.0, kInner = 0.15;
  constexpr int kMaxPerEdge = static_cast<int>(kMaxPoseContourPoints / 8);
  constexpr double kReachPx = 3.0;  // edge_near's whole window
  const StarPoseSettings star = pose_settings();
  StarPose current = pose;
  for (int pass = 0; pass < settings_.pose_edge_passes && current.valid; ++pass) {
    const std::array<std::array<cv::Point2d, 8>, 2> corners = projected_star(current, calibration_, star);
    StarEdgePoints points;
    for (int view = 0; view < 2; ++view) {
      const NearRectifier& near = view == 0 ? left_near_ : right_near_;
      const cv::Mat& image = (view == 0 ? left_view : right_view).image;
      const cv::Point2d origin = (view == 0 ? left_view : right_view).origin;
      for (int k = 0; k < 8; ++k) {
        const cv::Point2d a = corners[view][k], b = corners[view][(k + 1) % 8];
        const double length = cv::norm(b - a);
        if (!(length > 0.0)) continue;
        const cv::Point2d normal(-(b - a).y / length, (b - a).x / length);
        const int n = std::clamp(static_cast<int>((1.0 - 2.0 * kInner) * length / kSpacingPx), 2, kMaxPerEdge);
        for (int i = 0; i < n; ++i) {
          const cv::Point2d q = a + (kInner + (1.0 - 2.0 * kInner) * i / (n - 1)) * (b - a);
          const cv::Point2d raw = near.raw(q);
          cv::Point2d raw_normal = near.raw(q + normal) - raw;
          raw_normal /= std::max(cv::norm(raw_normal), 1e-9);
          cv::Point2d edge;
          if (!edge_near(image, raw - origin, raw_normal, edge, kReachPx)) continue;
          const cv::Point2d r = near.rectified(edge + origin, q);
          points[view][k].emplace_back(static_cast<float>(r.x), static_cast<float>(r.y));
        }
      }
    }
    current = refit_star_pose(current, points, calibration_, star);
  }
  return current;
}

cv::Vec3d StereoStarLocator::rectified_point(const cv::Point2d& left, double disparity) const {
  const cv::Matx34d& P1 = calibration_.P1;
  const double z = P1(0, 0) * calibration_.baseline() / disparity;  // thesis eq. 8.3
  const double x = z * (left.x - P1(0, 2)) / P1(0, 0);              // thesis eq. 8.4a
  const double y = z * (left.y - P1(1, 2)) / P1(1, 1);              // thesis eq. 8.4b
  return {x, y, z};
}

cv::Vec3d StereoStarLocator::triangulate(const cv::Point2d& left, double disparity) const {
  return calibration_.R1.t() * rectified_point(left, disparity);  // rectified left frame back to the left camera
}

void StereoStarLocator::add_pose(const std::vector<cv::Point2f>& left_edges,
                                 const std::vector<cv::Point2f>& right_edges, const EdgeView& left_view,
                                 const EdgeView& right_view, StarFix& fix) {
  const Clock::time_point t0 = Clock::now();
  fix.pose = estimate_star_pose(left_edges, right_edges, calibration_, pose_settings());
  fix.contour_size_ratio = fix.pose.size_ratio;
  if (fix.pose.valid && settings_.pose_edge_passes > 0) {
    // The refit replaces the contours' fit when its edge points lie closer to its star's edges.
    const StarPose refitted = refit_along_projection(fix.pose, left_view, right_view);
    if (refitted.valid && refitted.edge_sigma_px <= fix.pose.edge_sigma_px) {
      fix.pose = refitted;
      fix.pose_refitted = true;
    }
  }
  fix.times.pose_us += microseconds(t0, Clock::now());
  // The fitted star's centre is the better position: it uses every sub-pixel edge point of both views
  // and the star's true (perspective) shape, where the area centroid of a tilted star's image is not the
  // image of its centre. A fit that disagrees with the triangulated outline is not trusted: by more
  // than max_pose_offset of the range, or, for a coarse fit, by more than a fraction of a pixel of
  // disparity (its vertices then fit badly, and its depth is the first to go). A coarse fit refitted
  // along its projection no longer rests on its vertices: its own size checks it.
  const double offset = cv::norm(fix.pose.t_C - fix.p_left);
  fix.pose_offset = offset / cv::norm(fix.p_left);
  if (!fix.pose.valid) return;
  const double z_rectified = (calibration_.R1 * fix.pose.t_C)[2];
  fix.pose_disparity_px = calibration_.P1(0, 0) * calibration_.baseline() / z_rectified;
  const bool coarse = coarse_fit(fix.pose);
  const double disagreement_px = std::fabs(fix.pose_disparity_px - fix.outline_disparity_px);
  const bool disagrees = fix.outline.valid && disagreement_px > settings_.coarse_pose_max_disparity_px;
  if (settings_.position_from_pose && offset <= settings_.max_pose_offset * cv::norm(fix.p_left) &&
      !(coarse && (fix.pose_refitted ? wrong_size(fix.pose.size_ratio)
                                      : disagrees || wrong_size(fix.contour_size_ratio)))) {
    fix.p_left = fix.pose.t_C;
    fix.position_from_pose = true;
  }
}

bool StereoStarLocator::star_inside_images(const StarPose& pose) const {
  // The fitted star's tips and corners in raw pixels of both views, edge_margin_px inside the frame
  // like every contour.
  const std::array<std::array<cv::Point2d, 8>, 2> star = projected_star(pose, calibration_, pose_settings());
  const double margin = settings_.detector.edge_margin_px;
  const cv::Size size = calibration_.rig.image_size;
  for (int view = 0; view < 2; ++view) {
    for (const cv::Point2d& v : star[view]) {
      const cv::Point2d raw = (view == 0 ? left_near_ : right_near_).raw(v);
      if (!(raw.x >= margin && raw.y >= margin && raw.x <= size.width - 1 - margin && raw.y <= size.height - 1 - margin)) {
        return false;
      }
    }
  }
  return true;
}

bool StereoStarLocator::coarse_fit(const StarPose& pose) const { return pose.rms_px > settings_.attitude_max_rms_px; }

bool StereoStarLocator::wrong_size(double size_ratio) const {
  return std::fabs(size_ratio - 1.0) > settings_.max_pose_size_error;
}

void StereoStarLocator::reset_tracking() {
  last_left_box_ = cv::Rect();
  last_right_box_ = cv::Rect();
}

cv::Rect StereoStarLocator::right_search_window(const std::vector<StarCandidate>& left) const {
  const cv::Matx34d& P1 = calibration_.P1;
  const cv::Matx34d& P2 = calibration_.P2;
  const double f = P1(0, 0), b = calibration_.baseline();
  const double d_near = f * b / settings_.min_range_m, d_far = f * b / settings_.max_range_m;
  // The window in the right view's rectified pixels, sampled along its outline and taken to raw pixels
  // through the right camera's lens (a straight rectified edge is bent by the distortion).
  std::vector<cv::Point3f> rays;
  const size_t n = std::min(left.size(), kMaxCandidatesPerView);
  for (size_t i = 0; i < n; ++i) {
    const StarCandidate& c = left[i];
    if (c.rectified.empty() || !(c.area > 0.0)) continue;
    const double d = disparity_for_area(c.area);
    const double d_min = std::max(settings_.guided_min_scale * d, d_far);
    const double d_max = std::min(settings_.guided_max_scale * d, d_near);
    if (!(d_min <= d_max)) continue;
    // The star's rectified box, grown like a tracking ROI (LocatorSettings::roi_growth, roi_margin_px):
    // the detector measures the floor around the star, and drops an outline that touches the window.
    const cv::Rect2f box = cv::boundingRect(c.rectified);
    const double gx = 0.5 * (settings_.roi_growth - 1.0) * box.width + settings_.roi_margin_px;
    const double gy = 0.5 * (settings_.roi_growth - 1.0) * box.height + settings_.roi_margin_px + settings_.row_window_px;
    // x_r − cx2 = (x_l − cx1) − d
    const double x0 = box.x - gx - d_max - P1(0, 2) + P2(0, 2);
    const double x1 = box.x + box.width + gx - d_min - P1(0, 2) + P2(0, 2);
    const double y0 = box.y - gy, y1 = box.y + box.height + gy;
    constexpr int kSteps = 4;
    for (int k = 0; k <= kSteps; ++k) {
      const double tx = x0 + (x1 - x0) * k / kSteps, ty = y0 + (y1 - y0) * k / kSteps;
      for (const cv::Point2d& q : {cv::Point2d(tx, y0), cv::Point2d(tx, y1), cv::Point2d(x0, ty), cv::Point2d(x1, ty)}) {
        const cv::Vec3d ray = calibration_.R2.t() * cv::Vec3d((q.x - P2(0, 2)) / P2(0, 0), (q.y - P2(1, 2)) / P2(1, 1), 1.0);
        if (ray[2] > 1e-6) rays.emplace_back(static_cast<float>(ray[0]), static_cast<float>(ray[1]), static_cast<float>(ray[2]));
      }
    }
  }
  if (rays.empty()) return {};
  std::vector<cv::Point2f> raw;
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), calibration_.rig.right.K, calibration_.rig.right.D, raw);
  return cv::boundingRect(raw) & cv::Rect(cv::Point(0, 0), calibration_.rig.image_size);
}

StereoStarLocator::ViewResult StereoStarLocator::detect_view(StarDetector& detector, const cv::Mat& gray,
                                                             const cv::Rect& last_box, DetectorTimes* times) {
  ViewResult result;
  if (settings_.track_roi && !last_box.empty()) {
    const double w = last_box.width * settings_.roi_growth + 2.0 * settings_.roi_margin_px;
    const double h = last_box.height * settings_.roi_growth + 2.0 * settings_.roi_margin_px;
    const double cx = last_box.x + 0.5 * last_box.width;
    const double cy = last_box.y + 0.5 * last_box.height;
    const cv::Rect roi(cvRound(cx - 0.5 * w), cvRound(cy - 0.5 * h), cvRound(w), cvRound(h));
    result.candidates = detector.detect(gray, roi, times);
    if (!result.candidates.empty()) {
      result.used_roi = true;
      result.near_misses = detector.near_misses();
      return result;
    }
  }
  result.candidates = detector.detect(gray, cv::Rect(), times);
  result.near_misses = detector.near_misses();
  return result;
}

StarCandidate StereoStarLocator::transfer_candidate(const StarCandidate& star, bool star_is_left,
                                                    const cv::Mat& left_gray, const cv::Mat& right_gray) const {
  StarCandidate other;
  const cv::Matx34d& P1 = calibration_.P1;
  const cv::Matx34d& P2 = calibration_.P2;
  const double f = P1(0, 0), b = calibration_.baseline();
  const double d = disparity_for_area(star.area);
  const double d_min = std::max(settings_.guided_min_scale * d, f * b / settings_.max_range_m);
  const double d_max = std::min(settings_.guided_max_scale * d, f * b / settings_.min_range_m);
  if (!(d_min <= d_max)) return other;
  // x_l − x_r = d + cx1 − cx2 (rectified pixels); the transfer's shift is other − found.
  const double offset = P1(0, 2) - P2(0, 2);
  OutlineTransferSearch search;
  search.min_shift_x = star_is_left ? -(d_max + offset) : d_min + offset;
  search.max_shift_x = star_is_left ? -(d_min + offset) : d_max + offset;
  search.max_shift_y = settings_.guided_max_row_difference_px;
  search.edge_margin_px = settings_.detector.edge_margin_px + 1.0;
  const cv::Mat& found_gray = star_is_left ? left_gray : right_gray;
  const cv::Mat& other_gray = star_is_left ? right_gray : left_gray;
  const NearRectifier& found_view = star_is_left ? left_near_ : right_near_;
  const NearRectifier& other_view = star_is_left ? right_near_ : left_near_;
  const EdgeView found = edge_view(found_gray, star);
  const std::vector<cv::Point2f> edges = rectified_edges(found, star, found_view);
  TransferredOutline t;
  if (settings_.detector.deinterlace == Deinterlace::kField && !edges.empty()) {
    // The edges are the first field's (rectified_edges): so must the samples be. Only the pixels the
    // transfer can read are filled: around the star (the field its edges were found in), and around every
    // shifted outline in the other view.
    constexpr double kReach = 8.0;  // the edge search's reach from a point, and bilinear interpolation
    const cv::Rect2f box = cv::boundingRect(edges);
    auto raw_box = [&](const NearRectifier& view, double x0, double y0, double x1, double y1) {
      std::vector<cv::Point2f> raw;
      constexpr int kSteps = 8;  // the lens bends a rectified box's sides
      for (int k = 0; k <= kSteps; ++k) {
        const double tx = x0 + (x1 - x0) * k / kSteps, ty = y0 + (y1 - y0) * k / kSteps;
        for (const cv::Point2d& q : {cv::Point2d(tx, y0), cv::Point2d(tx, y1), cv::Point2d(x0, ty), cv::Point2d(x1, ty)}) {
          raw.emplace_back(view.raw(q));
        }
      }
      const cv::Rect2f r = cv::boundingRect(raw);
      return cv::Rect(cvFloor(r.x - kReach), cvFloor(r.y - kReach), cvCeil(r.width + 2 * kReach) + 1,
                      cvCeil(r.height + 2 * kReach) + 1) & cv::Rect(cv::Point(0, 0), other_gray.size());
    };
    const cv::Rect other_region = raw_box(other_view, box.x + search.min_shift_x, box.y - search.max_shift_y,
                                          box.x + box.width + search.max_shift_x, box.y + box.height + search.max_shift_y);
    cv::Mat found_field(found_gray.size(), CV_8UC1), other_field(other_gray.size(), CV_8UC1);
    found.image.copyTo(found_field(cv::Rect(found.origin, found.image.size())));
    if (!other_region.empty()) first_field(other_gray, other_region).copyTo(other_field(other_region));
    t = transfer_outline(edges, found_field, found_view, other_field, other_view, search);
  } else {
    t = transfer_outline(edges, found_gray, found_view, other_gray, other_view, search);
  }
  if (!t.found) return other;
  other.contour = std::move(t.contour);
  other.rectified = std::move(t.rectified);
  other.box = cv::boundingRect(other.contour);
  const cv::Moments m = cv::moments(other.rectified);
  if (!(std::fabs(m.m00) > 0.0)) return StarCandidate();
  other.area = std::fabs(m.m00);
  other.centroid = cv::Point2d(m.m10 / m.m00, m.m01 / m.m00);
  other.hu_distance = 1.0 - t.edge_fraction;
  other.vertices = 8;
  other.strict = false;
  return other;
}

StarFix StereoStarLocator::locate(const cv::Mat& left_gray, const cv::Mat& right_gray) {
  CV_Assert(left_gray.type() == CV_8UC1 && right_gray.type() == CV_8UC1);
  CV_Assert(left_gray.size() == calibration_.rig.image_size && right_gray.size() == calibration_.rig.image_size);
  StarFix fix;
  DetectorTimes left_times, right_times;
  ViewResult left = detect_view(left_detector_, left_gray, last_left_box_, &left_times);
  // Nothing in the whole left image (detect_view falls back to it): no pair can form, so the right
  // image is searched only for outline transfer (a passing star there may find the left's lost outline).
  ViewResult right;
  // The right window is cut at the left view's contrast level: both outlines cut at the same level have
  // the same edge bias, which cancels in the disparity. The right view may be lit otherwise where the
  // star is (a shadow or a lamp seen from another angle, a fault of one video link), so the window is
  // searched again at its own level (Otsu over its floor region) when the left's finds no passing star,
  // and when what it finds pairs with nothing (on the tuning split 2 080 stars: six more found, no false
  // fix).
  bool right_at_left_level = false;
  bool right_whole = false;  // the right view searched whole (not only where the left's candidates can appear)
  const bool transfer_enabled = settings_.outline_transfer && settings_.guided_acceptance && settings_.estimate_pose &&
                                settings_.detector.method == DetectorMethod::kRobust;
  auto detect_right = [&](bool own_level) {
    right = ViewResult();
    right_at_left_level = false;
    right_whole = true;
    // A left view with near misses only: the right is searched where they can appear, for a passing star.
    const std::vector<StarCandidate>& placing = left.candidates.empty() ? left.near_misses : left.candidates;
    if (placing.empty()) {
      // Nothing at all in the left view: a passing star of the right view may still find the left's
      // outline (outline_transfer).
      if (transfer_enabled) right = detect_view(right_detector_, right_gray, cv::Rect(), &right_times);
      return;
    }
    // The thesis pipeline (the documented baseline) searches the whole right frame.
    if (!settings_.guided_search || settings_.detector.method == DetectorMethod::kThesis) {
      right = detect_view(right_detector_, right_gray, last_right_box_, &right_times);
      return;
    }
    right_whole = false;
    const cv::Rect window = right_search_window(placing);
    right.used_roi = left.used_roi;  // a fix from a tracked left ROI is a tracked fix
    if (window.empty()) return;
    if (!own_level) {
      right.candidates = right_detector_.detect(right_gray, window, &right_times, left_detector_.last_threshold_ratio());
      right.near_misses = right_detector_.near_misses();
      right_at_left_level = !right.candidates.empty();
      if (right_at_left_level) return;
    }
    right.candidates = right_detector_.detect(right_gray, window, &right_times);
    right.near_misses = right_detector_.near_misses();
  };
  detect_right(false);

  const cv::Matx34d& P1 = calibration_.P1;
  const cv::Matx34d& P2 = calibration_.P2;
  const double f = P1(0, 0);
  const double fy = P1(1, 1);
  const double cx1 = P1(0, 2);
  const double cx2 = P2(0, 2);
  const double b = calibration_.baseline();

  // A new fix from a pair of candidates (rectified centroids, thesis eq. 8.3-8.4); nothing of an earlier,
  // refused pair stays but the stages' times, which add up over the frame.
  auto make_fix = [&](const StarCandidate* best_l, const StarCandidate* best_r, bool guided, bool used_roi) {
    const StageTimes times = fix.times;
    fix = StarFix();
    fix.times = times;
    const cv::Point2d pl = best_l->centroid;
    const cv::Point2d pr = best_r->centroid;
    const double d = (pl.x - cx1) - (pr.x - cx2);
    const cv::Vec3d rectified = rectified_point(pl, d);
    const double x = rectified[0], y = rectified[1], z = rectified[2];
    // The triangulated point is in the rectified left frame; R1 rotated the left camera into it.
    const cv::Matx33d R1t = calibration_.R1.t();
    fix.p_left = R1t * rectified;
    fix.p_centroids = fix.p_left;
    // Uncertainty: first-order propagation of independent centroid noise on u_l, v_l, u_r.
    const cv::Matx33d J(-x / d + z / f, 0.0, x / d,   // ∂X/∂(u_l, v_l, u_r)
                        -y / d, z / fy, y / d,        // ∂Y/∂(...)
                        -z / d, 0.0, z / d);          // ∂Z/∂(...)
    const double s2 = settings_.centroid_sigma_px * settings_.centroid_sigma_px;
    const cv::Matx33d cov = R1t * (s2 * J * J.t()) * R1t.t();
    fix.sigma_left = cv::Vec3d(std::sqrt(cov(0, 0)), std::sqrt(cov(1, 1)), std::sqrt(cov(2, 2)));
    fix.cov_left = cov;
    fix.left_rectified = pl;
    fix.right_rectified = pr;
    fix.disparity_px = d;
    fix.row_difference_px = std::fabs(pl.y - pr.y);
    fix.left_contour = best_l->contour;
    fix.right_contour = best_r->contour;
    fix.left_candidate = *best_l;
    fix.right_candidate = *best_r;
    fix.guided = guided;
    fix.used_roi = used_roi;
    fix.found = true;
    last_left_box_ = best_l->box;
    last_right_box_ = best_r->box;
  };

  // Pair the candidates: rows must agree after rectification, the depth must be plausible; among the
  // valid pairs the best (smallest summed Hu distance) wins, not the first. Two passing stars are
  // preferred; without such a pair, a passing star with a near miss of the other view (guided_pair).
  auto try_pairs = [&](const ViewResult& l, const ViewResult& r) {
    const Clock::time_point t1 = Clock::now();
    double best_score = std::numeric_limits<double>::infinity();
    const StarCandidate* best_l = nullptr;
    const StarCandidate* best_r = nullptr;
    bool best_guided = false;
    // guided: which of the two is the near miss (0: neither, 1: left, 2: right; 3: neither, but their
    // centroids' rows too far apart for the strict gate).
    auto consider = [&](const std::vector<StarCandidate>& ls, const std::vector<StarCandidate>& rs, int guided) {
      const size_t nl = std::min(ls.size(), kMaxCandidatesPerView);
      const size_t nr = std::min(rs.size(), kMaxCandidatesPerView);
      for (size_t i = 0; i < nl; ++i) {
        for (size_t j = 0; j < nr; ++j) {
          const cv::Point2d& cl = ls[i].centroid;
          const cv::Point2d& cr = rs[j].centroid;
          const double row_difference = std::fabs(cl.y - cr.y);
          const double disparity = (cl.x - cx1) - (cr.x - cx2);
          const double max_rows = guided ? settings_.guided_max_row_difference_px : settings_.max_row_difference_px;
          if (!(row_difference <= max_rows) || !(disparity > 0.0)) continue;
          if (guided == 3 && row_difference <= settings_.max_row_difference_px) continue;  // tried strictly
          const double z = f * b / disparity;  // thesis eq. 8.3
          if (z < settings_.min_range_m || z > settings_.max_range_m) continue;
          if (guided == 1 && !guided_pair(rs[j], ls[i], disparity)) continue;
          if (guided == 2 && !guided_pair(ls[i], rs[j], disparity)) continue;
          if (guided == 3 && !guided_pair(ls[i], rs[j], disparity)) continue;
          const double score = ls[i].hu_distance + rs[j].hu_distance;
          if (score < best_score) {
            best_score = score;
            best_l = &ls[i];
            best_r = &rs[j];
            best_guided = guided != 0;
          }
        }
      }
    };
    consider(l.candidates, r.candidates, 0);
    if (!std::isfinite(best_score)) {
      consider(l.candidates, r.near_misses, 2);
      consider(l.near_misses, r.candidates, 1);
      // Two passing stars whose centroids' rows disagree: a defect of one view (a fault band, a shadow
      // edge, a merged blob) moved its centroid; the outlines' alignment decides, as for a near miss.
      if (settings_.guided_acceptance && settings_.estimate_pose) consider(l.candidates, r.candidates, 3);
    }
    if (std::isfinite(best_score)) make_fix(best_l, best_r, best_guided, l.used_roi && r.used_roi);
    fix.times.triangulation_us += microseconds(t1, Clock::now());
  };

  try_pairs(left, right);
  if (!fix.found && (left.used_roi || right.used_roi)) {
    // The tracked ROIs found something that does not pair up: search both full frames once.
    reset_tracking();
    left = detect_view(left_detector_, left_gray, last_left_box_, &left_times);
    detect_right(false);
    try_pairs(left, right);
  }
  if (!fix.found && right_at_left_level) {
    detect_right(true);
    try_pairs(left, right);
  }
  // The outlines laid onto each other, the pose, and the checks that may still refuse the fix (fix.refused).
  auto check_fix = [&]() {
    const Clock::time_point t0 = Clock::now();
    const EdgeView left_view = edge_view(left_gray, fix.left_candidate);
    const EdgeView right_view = edge_view(right_gray, fix.right_candidate);
    const std::vector<cv::Point2f> left_edges = rectified_edges(left_view, fix.left_candidate, left_near_);
    const std::vector<cv::Point2f> right_edges = rectified_edges(right_view, fix.right_candidate, right_near_);
    fix.outline = align_outlines(left_edges, right_edges, fix.left_rectified - fix.right_rectified);
    fix.p_outline = fix.p_centroids;
    if (fix.outline.valid) {
      fix.outline_disparity_px = fix.outline.shift_at(fix.left_rectified).x - P1(0, 2) + P2(0, 2);
      if (settings_.outline_disparity && fix.outline_disparity_px > 0.0) {
        fix.p_outline = triangulate(fix.left_rectified, fix.outline_disparity_px);
        fix.p_left = fix.p_outline;
      }
    }
    fix.times.pose_us += microseconds(t0, Clock::now());
    add_pose(left_edges, right_edges, left_view, right_view, fix);
    // No eight-vertex fit far off the axis, where the lens model is extrapolated and the star is most
    // distorted: the centroids are suspect (on the tuning sets such fixes were the ones more than 5 % of
    // the range off). A fit of the wrong size: the range is off (LocatorSettings::max_pose_size_error).
    // A fitted star reaching beyond the edge of a view: a star cut by it, whose outline stopped short of
    // the edge (the edge rows of a frame are often darker or brighter than the scene).
    const double off_axis = std::acos(std::clamp(fix.p_left[2] / cv::norm(fix.p_left), -1.0, 1.0));
    const bool contradicted = fix.pose.valid && !coarse_fit(fix.pose) && wrong_size(fix.contour_size_ratio);
    const bool misaligned = fix.guided && !(fix.outline.valid && fix.outline.residual_px <= settings_.guided_max_residual_px &&
                                            std::fabs(fix.outline.shift.y) <= settings_.max_row_difference_px);
    if (contradicted) fix.refused = "pose size";
    else if (misaligned) fix.refused = "guided outlines misaligned";
    else if (!fix.pose.valid && off_axis > settings_.require_pose_beyond_rad) fix.refused = "no pose off the axis";
    else if (off_axis > settings_.max_off_axis_rad) fix.refused = "off the axis";
    else if (fix.pose.valid && !star_inside_images(fix.pose)) fix.refused = "fitted star beyond the image edge";
    if (fix.refused != nullptr) fix.found = false;
    // A fit good enough for the position and the checks above may still be too coarse for the attitude,
    // or tilted against the disparity gradient the two outlines measure (LocatorSettings::
    // attitude_max_gradient_error).
    if (fix.pose.valid && fix.outline.valid) {
      fix.pose_gradient_error = cv::norm(plane_disparity_gradient(fix.pose.R_CS, fix.pose.t_C, calibration_) - fix.outline.gradient);
    }
    if (coarse_fit(fix.pose) || fix.pose_gradient_error > settings_.attitude_max_gradient_error) fix.pose.valid = false;
  };

  // A passing star of one view sought in the other by its outline, each candidate's fix judged by the
  // checks before the next is tried; `fine_pose`: the fix must also give a fine pose.
  auto try_transfer = [&](int first_view, bool fine_pose) {
    for (int view = first_view; view < 2; ++view) {
      const std::vector<StarCandidate>& stars = view == 0 ? left.candidates : right.candidates;
      for (size_t i = 0; i < std::min(stars.size(), kMaxCandidatesPerView); ++i) {
        const Clock::time_point t1 = Clock::now();
        const StarCandidate transferred = transfer_candidate(stars[i], view == 0, left_gray, right_gray);
        fix.times.triangulation_us += microseconds(t1, Clock::now());
        if (transferred.contour.empty()) continue;
        if (view == 0) make_fix(&stars[i], &transferred, true, false);
        else make_fix(&transferred, &stars[i], true, false);
        fix.transferred = true;
        check_fix();
        if (fix.found && fine_pose && !fix.pose.valid) {
          fix.refused = "found only in the whole right view, without a fine pose";
          fix.found = false;
        }
        if (fix.found) return;
      }
    }
  };

  // A pair is judged by the checks; still nothing paired: a passing star of one view sought in the other.
  // A frame without a fix keeps its last refused pair (its reason and figures) for diagnosis.
  if (fix.found && settings_.estimate_pose) check_fix();
  else if (!fix.found && transfer_enabled) try_transfer(0, false);
  if (fix.refused != nullptr && fix.guided && !fix.transferred && transfer_enabled) {
    // A guided pair the checks refused: the near miss (or the passing star beyond the row gate) was not
    // the star's own outline in its view (a merged or torn one, whose outline does not lay onto the
    // other's), so the passing star is sought in that view by its outline instead. On the tuning split
    // (4 160 stars) this finds 17 more stars, no false fix.
    try_transfer(0, false);
  }
  if (!fix.found && transfer_enabled && !right_whole) {
    // The left view's candidates placed the right view's search and nothing came of them: a passing star
    // elsewhere in the right view, whose left outline was lost (merged with a shadow that reaches the
    // image's edge, torn), is sought in the left view by its outline. Found only so, the star must also
    // give a fine pose. On the tuning sets this finds 7 more stars of 4 160 and 36 more of 12 480, for 8 %
    // more instructions per pair (10.1 M to 10.9 M); without the pose rule 13 and 52 more, with one false
    // fix more (6.4 % off) in the larger set.
    right = detect_view(right_detector_, right_gray, cv::Rect(), &right_times);
    try_transfer(1, true);
  }
  if (!fix.found) reset_tracking();
  fix.times.threshold_morphology_us = left_times.threshold_morphology_us + right_times.threshold_morphology_us;
  fix.times.contours_filters_us = left_times.contours_filters_us + right_times.contours_filters_us;
  fix.times.rectify_points_us = left_times.rectify_points_us + right_times.rectify_points_us;
  return fix;
}

}  // namespace quad::vision
