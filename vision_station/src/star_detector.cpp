#include "quad/vision/star_detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "quad/vision/coarse_image.h"
#include "quad/vision/ideal_star.h"

namespace quad::vision {

const std::vector<cv::Point>* largest_contour(const std::vector<std::vector<cv::Point>>& contours) {
  const std::vector<cv::Point>* best = nullptr;
  double best_area = 0.0;
  for (const std::vector<cv::Point>& contour : contours) {
    const double area = cv::contourArea(contour);
    if (area > best_area) {
      best_area = area;
      best = &contour;
    }
  }
  return best;
}

namespace {

using Clock = std::chrono::steady_clock;

double microseconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

// OpenCV's CONTOURS_MATCH_I1 works on m_i = sign(h_i)·log10|h_i| and skips invariants below this.
constexpr double kHuEpsilon = 1e-5;

std::array<double, 7> hu_log(const cv::Moments& moments) {
  double hu[7];
  cv::HuMoments(moments, hu);
  std::array<double, 7> m{};
  for (int i = 0; i < 7; ++i) {
    const double a = std::fabs(hu[i]);
    m[i] = a > kHuEpsilon ? std::copysign(std::log10(a), hu[i]) : 0.0;
  }
  return m;
}

}  // namespace

const char* to_string(DetectorMethod method) { return method == DetectorMethod::kThesis ? "thesis" : "robust"; }

const char* to_string(Deinterlace deinterlace) {
  return deinterlace == Deinterlace::kNone ? "none" : deinterlace == Deinterlace::kField ? "field" : "blend";
}

const char* to_string(ContourFate fate) {
  switch (fate) {
    case ContourFate::kTooFewPoints: return "too_few_points";
    case ContourFate::kTouchesBorder: return "touches_border";
    case ContourFate::kSmallRawArea: return "small_raw_area";
    case ContourFate::kSmallArea: return "small_area";
    case ContourFate::kShape: return "shape";
    case ContourFate::kDuplicate: return "duplicate";
    case ContourFate::kNoMidLevel: return "no_mid_level";
    case ContourFate::kAccepted: return "accepted";
  }
  return "?";
}

bool parse_detector_method(const std::string& text, DetectorMethod& out) {
  if (text == "thesis") out = DetectorMethod::kThesis;
  else if (text == "robust") out = DetectorMethod::kRobust;
  else return false;
  return true;
}

bool parse_deinterlace(const std::string& text, Deinterlace& out) {
  if (text == "none") out = Deinterlace::kNone;
  else if (text == "field") out = Deinterlace::kField;
  else if (text == "blend") out = Deinterlace::kBlend;
  else return false;
  return true;
}

StarDetector::StarDetector(const DetectorSettings& settings, const PointRectifier& rectifier)
    : settings_(settings),
      rectifier_(rectifier),
      shape_test_(settings.inner_ratio, settings.shape),
      kernel_(cv::getStructuringElement(cv::MORPH_RECT,
                                        cv::Size(settings.morphology_kernel_px, settings.morphology_kernel_px))) {
  auto loosest = [](const StarShapeLimits& a, const StarShapeLimits& b) {
    return StarShapeLimits{std::max(a.max_elongation, b.max_elongation), std::max(a.max_profile_rms, b.max_profile_rms),
                           std::min(a.min_fourfold, b.min_fourfold), std::max(a.max_other_harmonic, b.max_other_harmonic),
                           std::min(a.min_solidity, b.min_solidity), std::max(a.max_solidity, b.max_solidity)};
  };
  loosest_shape_ = settings.refine_midpoint ? loosest(settings.shape, settings.retry_shape) : settings.shape;
  if (settings.keep_near_misses) loosest_shape_ = loosest(loosest_shape_, settings.near_miss_shape);
  ideal_hu_log_ = hu_log(cv::moments(ideal_star_contour(settings.inner_ratio)));
}

double StarDetector::hu_distance(const cv::Moments& moments) const {
  // Thesis filter 5: sum of absolute differences of the inverted log Hu invariants (CONTOURS_MATCH_I1).
  const std::array<double, 7> m = hu_log(moments);
  double distance = 0.0;
  for (int i = 0; i < 7; ++i) {
    if (m[i] != 0.0 && ideal_hu_log_[i] != 0.0) distance += std::fabs(1.0 / m[i] - 1.0 / ideal_hu_log_[i]);
  }
  return distance;
}

void StarDetector::threshold(const cv::Mat& gray) {
  // Thesis steps 1–3 (greyscale, invert, threshold): a pixel is star-coloured when it is darker than a
  // fraction of the local floor brightness. The fraction comes from the image (Otsu on the ratio image),
  // so exposure, shadows and lighting gradients need no retune.
  const DetectorSettings& s = settings_;
  const int cell = std::max(1, s.background_cell_px);
  const cv::Size small_size(std::max(1, gray.cols / cell), std::max(1, gray.rows / cell));
  cv::resize(gray, small_, small_size, 0, 0, cv::INTER_AREA);
  const int window = std::max(1, s.background_window_px / cell) | 1;
  cv::dilate(small_, background_, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(window, window)));
  cv::blur(background_, background_, cv::Size(3, 3));
  cv::divide(small_, background_, ratio_, 255.0);
  const double otsu = cv::threshold(ratio_, scratch_, 0.0, 255.0, cv::THRESH_BINARY | cv::THRESH_OTSU) / 255.0;
  threshold_ratio_ = std::clamp(otsu, s.min_threshold_ratio, s.max_threshold_ratio);
  background_.convertTo(threshold_small_, CV_8U, threshold_ratio_);
  cv::resize(threshold_small_, threshold_full_, gray.size(), 0, 0, cv::INTER_LINEAR);
  cv::compare(gray, threshold_full_, binary_, cv::CMP_LT);  // inverted: dark becomes 255
}

const std::vector<cv::Point>* StarDetector::mid_level_outline(const cv::Rect& region) {
  // One opening and one closing of the pixels below the mid-level (refine_binary_), then the largest
  // outline in the region.
  const int k = settings_.morphology_kernel_px;
  erode_rect(refine_binary_, refine_scratch_, k, k);
  dilate_rect(refine_scratch_, refine_binary_, k, k);
  dilate_rect(refine_binary_, refine_scratch_, k, k);
  erode_rect(refine_scratch_, refine_binary_, k, k);
  std::swap(refine_binary_, refine_scratch_);
  cv::findContours(refine_scratch_, refine_contours_, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE, region.tl());
  return largest_contour(refine_contours_);
}

bool StarDetector::midpoint_contour(const cv::Mat& gray, const cv::Rect& roi, const cv::Rect& box,
                                    std::vector<cv::Point>& out) {
  constexpr int kGrow = 4;  // the mid-level edge may lie a little outside the Otsu edge
  const cv::Rect region = cv::Rect(box.x - kGrow, box.y - kGrow, box.width + 2 * kGrow, box.height + 2 * kGrow) & roi;
  const cv::Rect local = region - roi.tl();
  // The star's own grey: the mean of its interior (the binary shape eroded by two more pixels).
  cv::erode(binary_(local), interior_, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
  if (cv::countNonZero(interior_) < 16) return false;
  const double star_grey = cv::mean(gray(region), interior_)[0];
  // Floor grey B = threshold / ratio; mid-level = (B + star) / 2.
  threshold_full_(local).convertTo(midpoint_, CV_8U, 0.5 / threshold_ratio_, 0.5 * star_grey);
  cv::compare(gray(region), midpoint_, refine_binary_, cv::CMP_LT);
  const std::vector<cv::Point>* best = mid_level_outline(region);
  if (best == nullptr) return false;
  // Touching the region's border means the mid-level shape merged with something: keep the original.
  const cv::Rect refined_box = cv::boundingRect(*best);
  if ((refined_box & region) != refined_box || refined_box.x <= region.x || refined_box.y <= region.y ||
      refined_box.br().x >= region.br().x || refined_box.br().y >= region.br().y) {
    return false;
  }
  out = *best;
  return true;
}

void StarDetector::make_view(const cv::Mat& gray, const cv::Rect& roi) {
  const int first = roi.y + (settings_.deinterlace == Deinterlace::kNone ? 0 : (roi.y & 1));  // even frame row
  const int rows = roi.br().y - first;
  switch (settings_.deinterlace) {
    case Deinterlace::kNone:
      view_ = gray(roi);
      view_row_scale_ = 1.0f;
      view_origin_ = cv::Point2f(static_cast<float>(roi.x), static_cast<float>(roi.y));
      break;
    case Deinterlace::kField:  // every other row of the frame, without a copy
      view_ = cv::Mat((rows + 1) / 2, roi.width, CV_8UC1, const_cast<uchar*>(gray.ptr(first) + roi.x), gray.step[0] * 2);
      view_row_scale_ = 2.0f;
      view_origin_ = cv::Point2f(static_cast<float>(roi.x), static_cast<float>(first));
      break;
    case Deinterlace::kBlend:  // the mean of each row pair, centred between the two rows
      cv::resize(gray(cv::Rect(roi.x, first, roi.width, rows & ~1)), blend_, cv::Size(roi.width, rows / 2), 0, 0,
                 cv::INTER_AREA);
      view_ = blend_;
      view_row_scale_ = 2.0f;
      view_origin_ = cv::Point2f(static_cast<float>(roi.x), first + 0.5f);
      break;
  }
}

void StarDetector::to_frame(const std::vector<cv::Point>& view_points, cv::Point2f view_scale,
                            std::vector<cv::Point2f>& frame) const {
  // view_scale maps the points' own grid (the view, or its half-resolution copy) to view pixels, with the
  // pixel centres kept: v = s·p + (s − 1)/2.
  frame.resize(view_points.size());
  const float ox = 0.5f * (view_scale.x - 1.0f), oy = 0.5f * (view_scale.y - 1.0f);
  for (size_t i = 0; i < view_points.size(); ++i) {
    const float vx = view_scale.x * view_points[i].x + ox, vy = view_scale.y * view_points[i].y + oy;
    frame[i] = cv::Point2f(view_origin_.x + vx, view_origin_.y + view_row_scale_ * vy);
  }
}

void StarDetector::rectify(const std::vector<cv::Point>& view_points, cv::Point2f view_scale,
                           std::vector<cv::Point2f>& out) {
  to_frame(view_points, view_scale, frame_points_);
  table_.map(frame_points_, out);
}

bool StarDetector::touches_border(const cv::Rect& box, cv::Size view_size, int margin) const {
  // Image borders: within `margin` pixels (thesis filter 1: a star cut by the edge can look like a better
  // star). ROI borders that are not image borders: touching means possibly cut by the ROI.
  const int m[4] = {roi_border_[0] ? 1 : margin, roi_border_[1] ? 1 : margin, roi_border_[2] ? 1 : margin,
                    roi_border_[3] ? 1 : margin};
  return box.x < m[0] || box.y < m[1] || box.br().x > view_size.width - m[2] || box.br().y > view_size.height - m[3];
}

std::vector<StarCandidate> StarDetector::detect(const cv::Mat& gray, cv::Rect roi, DetectorTimes* times,
                                                double level_ratio) {
  CV_Assert(gray.type() == CV_8UC1);
  const cv::Rect image_rect(0, 0, gray.cols, gray.rows);
  roi = roi.empty() ? image_rect : (roi & image_rect);
  if (roi.width < 8 || roi.height < 8) return {};
  if (table_.image_size() != gray.size()) table_ = RectifyTable(rectifier_, gray.size());
  near_misses_.clear();
  roi_border_[0] = roi.x > 0;  // the searched ROI's edges that are not the image's (touches_border)
  roi_border_[1] = roi.y > 0;
  roi_border_[2] = roi.br().x < gray.cols;
  roi_border_[3] = roi.br().y < gray.rows;
  std::vector<StarCandidate> candidates;
  if (settings_.method == DetectorMethod::kThesis) {
    make_view(gray, roi);
    candidates = detect_thesis(times);
  } else {
    candidates = detect_robust(gray, roi, level_ratio, times);
    prune_near_misses(candidates);
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const StarCandidate& a, const StarCandidate& b) { return a.hu_distance < b.hu_distance; });
  return candidates;
}

std::vector<StarCandidate> StarDetector::detect_thesis(DetectorTimes* times) {
  std::vector<StarCandidate> candidates;
  const cv::Rect view_rect(0, 0, view_.cols, view_.rows);

  // Steps 1–4: threshold, then erode, dilate twice, erode (thesis sec. 8.1) to smooth the edges and
  // remove salt noise.
  const Clock::time_point t0 = Clock::now();
  threshold(view_);
  cv::erode(binary_, scratch_, kernel_);
  cv::dilate(scratch_, binary_, kernel_, cv::Point(-1, -1), 2);
  cv::erode(binary_, scratch_, kernel_);
  std::swap(binary_, scratch_);
  const Clock::time_point t1 = Clock::now();

  // Step 5: outer contours of the white shapes, then the filters.
  cv::findContours(binary_, contours_, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  const DetectorSettings& s = settings_;
  const double row_scale = view_row_scale_;
  std::vector<cv::Point2f> polygon, hull;
  std::vector<cv::Point> refined_contour;
  double rectify_us = 0.0;
  for (std::vector<cv::Point>& contour : contours_) {
    const cv::Rect box = cv::boundingRect(contour);
    if (touches_border(box, view_.size(), s.edge_margin_px)) continue;  // filter 1
    if (!(cv::contourArea(contour) * row_scale > s.raw_area_prefilter * s.min_area_px)) continue;

    StarCandidate c;
    const Clock::time_point r0 = Clock::now();
    rectify(contour, cv::Point2f(1.0f, 1.0f), c.rectified);
    rectify_us += microseconds(r0, Clock::now());
    // Filter 2: area (rectified pixels).
    const cv::Moments moments = cv::moments(c.rectified);
    c.area = std::fabs(moments.m00);
    if (!(c.area > s.min_area_px)) continue;
    // Filter 3: aspect ratio of the bounding box.
    const cv::Rect2f rectified_box = cv::boundingRect(c.rectified);
    const double aspect = rectified_box.height / std::max(rectified_box.width, 1e-3f);
    if (aspect < s.min_aspect || aspect > 1.0 / s.min_aspect) continue;
    // Project filter: solidity.
    cv::convexHull(c.rectified, hull);
    c.solidity = c.area / std::max(cv::contourArea(hull), 1.0);
    if (c.solidity < s.min_solidity || c.solidity > s.max_solidity) continue;
    // Filter 4: vertex count of the simplified polygon.
    cv::approxPolyDP(c.rectified, polygon, s.polygon_epsilon * cv::arcLength(c.rectified, true), true);
    c.vertices = static_cast<int>(polygon.size());
    if (std::abs(c.vertices - s.ideal_vertex_count) > s.vertex_count_tolerance) continue;
    // Filter 5: Hu-moment distance to the ideal star.
    c.hu_distance = hu_distance(moments);
    if (!(c.hu_distance > s.min_hu_distance && c.hu_distance < s.max_hu_distance)) continue;

    // Sub-pixel centroid from the moments of the rectified polygon (input of eq. 8.2–8.4), on the
    // mid-level contour when refinement is on.
    cv::Moments centroid_moments = moments;
    std::vector<cv::Point>* raw = &contour;
    if (s.refine_midpoint && midpoint_contour(view_, view_rect, box, refined_contour)) {
      const Clock::time_point r1 = Clock::now();
      rectify(refined_contour, cv::Point2f(1.0f, 1.0f), c.rectified);
      rectify_us += microseconds(r1, Clock::now());
      centroid_moments = cv::moments(c.rectified);
      raw = &refined_contour;
    }
    c.centroid = cv::Point2d(centroid_moments.m10 / centroid_moments.m00, centroid_moments.m01 / centroid_moments.m00);
    to_frame(*raw, cv::Point2f(1.0f, 1.0f), frame_points_);
    for (const cv::Point2f& p : frame_points_) c.contour.emplace_back(cvRound(p.x), cvRound(p.y));
    c.box = cv::boundingRect(c.contour);
    candidates.push_back(std::move(c));
  }
  if (times != nullptr) {
    times->threshold_morphology_us += microseconds(t0, t1);
    times->contours_filters_us += microseconds(t1, Clock::now()) - rectify_us;
    times->rectify_points_us += rectify_us;
  }
  return candidates;
}

}  // namespace quad::vision
