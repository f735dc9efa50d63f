// The robust method of StarDetector (star_detector.h): segmentation on a half-resolution copy, the
// radial-profile shape test, the mid-level contour at full resolution.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <climits>
#include <cstdint>

#include <opencv2/imgproc.hpp>

#include "quad/vision/coarse_image.h"
#include "quad/vision/star_detector.h"

namespace quad::vision {
namespace {

using Clock = std::chrono::steady_clock;

double microseconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

// One outline found twice (at both levels, or a near miss where a candidate is): centroids within a
// quarter of the smaller outline's size.
bool same_outline(const StarCandidate& a, const StarCandidate& b) {
  return cv::norm(a.centroid - b.centroid) < 0.25 * std::sqrt(std::min(a.area, b.area));
}

}  // namespace

cv::Point2f StarDetector::coarse_scale() const {
  // The half-resolution copy has square pixels of 2 × 2 frame pixels: a field view only halves columns.
  return cv::Point2f(2.0f, view_row_scale_ > 1.0f ? 1.0f : 2.0f);
}

void StarDetector::row_median() { vertical_median_3(coarse_, median_lo_); }

cv::Rect StarDetector::floor_region(const cv::Rect& roi, cv::Size image) const {
  // The floor at a pixel depends on the 1/8-size pixels within two half-windows (the closing), one more
  // for the blur and one for the interpolation: grown by the window and three 8-pixel cells.
  constexpr int kCell = 8;
  const int reach = settings_.robust_window_px + 3 * kCell;
  const int x0 = std::max(0, (roi.x - reach) / kCell * kCell), y0 = std::max(0, (roi.y - reach) / kCell * kCell);
  const int x1 = std::min(image.width, (roi.br().x + reach + kCell - 1) / kCell * kCell);
  const int y1 = std::min(image.height, (roi.br().y + reach + kCell - 1) / kCell * kCell);
  return cv::Rect(cv::Point(x0, y0), cv::Point(x1, y1));
}

void StarDetector::upsample_floor(const cv::Rect& window) {
  // The 1/8-size floor brought to the half-resolution grid over the window only.
  const cv::Size full = coarse_region_.size();
  if (full.width != 4 * background_.cols || full.height != 4 * background_.rows) {
    cv::resize(background_, scratch_, full, 0, 0, cv::INTER_LINEAR);
    scratch_(window).copyTo(coarse_floor_);
    return;
  }
  upsample_linear(background_, 4, 4, window, coarse_floor_);
}

void StarDetector::robust_floor(const cv::Rect& window, double level_ratio) {
  // The floor brightness: the local maximum over a window wider than the star's dark core (the floor is
  // the brightest surface), on a 1/8-size copy, smoothed and brought back to the half-resolution copy.
  // The contrast level ρ comes from the image (Otsu on the image/floor ratio), clamped.
  const DetectorSettings& s = settings_;
  const cv::Point2f scale = coarse_scale();
  half_resolution(view_, scale.y > 1.0f, coarse_region_);
  coarse_ = coarse_region_;
  if (s.robust_row_median) row_median();
  quarter_area(coarse_region_, small_);
  const int floor_window = std::max(1, s.robust_window_px / 8) | 1;
  // A closing (local maximum, then local minimum over the same window): the dilation fills every dark
  // shape narrower than the window with the floor around it, the erosion brings a shadow or a dark floor
  // region wider than the window back to its own level, so the floor follows a shadow's edge.
  dilate_rect(small_, scratch_, floor_window, floor_window);
  if (s.robust_floor_closing) erode_rect(scratch_, background_, floor_window, floor_window);
  else std::swap(scratch_, background_);
  cv::blur(background_, background_, cv::Size(3, 3));
  if (level_ratio > 0.0) {
    threshold_ratio_ = level_ratio;
  } else {
    cv::divide(small_, background_, ratio_, 255.0);
    const double otsu = cv::threshold(ratio_, scratch_, 0.0, 255.0, cv::THRESH_BINARY | cv::THRESH_OTSU) / 255.0;
    threshold_ratio_ = std::clamp(otsu, s.robust_min_ratio, s.robust_max_ratio);
  }
  // The search window on the half-resolution grid (whole coarse pixels), and the view cut to it.
  const int sx = static_cast<int>(scale.x), sy = static_cast<int>(scale.y);
  const cv::Rect coarse_window =
      cv::Rect(cv::Point(window.x / sx, window.y / sy),
               cv::Point((window.br().x + sx - 1) / sx, (window.br().y + sy - 1) / sy)) &
      cv::Rect(0, 0, coarse_region_.cols, coarse_region_.rows);
  upsample_floor(coarse_window);
  coarse_ = coarse_region_(coarse_window);
  view_ = view_(cv::Rect(coarse_window.x * sx, coarse_window.y * sy, coarse_window.width * sx, coarse_window.height * sy) &
                cv::Rect(0, 0, view_.cols, view_.rows));
  view_origin_ += cv::Point2f(static_cast<float>(coarse_window.x * sx), view_row_scale_ * coarse_window.y * sy);
}

void StarDetector::robust_threshold(double ratio) {
  // Star-coloured: darker than ratio × the local floor, in 16-bit fixed point (ρ to 1/256; one pass the
  // compiler vectorises; inverted: dark becomes 255); then an opening against salt, snow and thin texture.
  const uint16_t q = static_cast<uint16_t>(std::clamp(std::lround(ratio * 256.0), 0L, 256L));
  below_level(coarse_, coarse_floor_, q, scratch_);
  open_rect(scratch_, settings_.morphology_kernel_px, binary_, median_hi_);
}

bool StarDetector::mid_level_threshold(const cv::Rect& grown, const cv::Rect& region) {
  // Levels relative to the local floor F (coarse_floor_), so that a star across a shadow edge gets its
  // mid-level on each side: the star's own ratio I/F (the mean of its coarse interior, eroded once more
  // when that leaves enough) and the floor's (the region's ring outside the star, dilated twice; ≈ 1),
  // taken around this star only, so a full-frame and an ROI search measure the same level.
  cv::divide(coarse_(grown), coarse_floor_(grown), refine_ratio_, 128.0);
  const int k = settings_.morphology_kernel_px;
  double star_ratio = 0.0, floor_ratio = 0.0;
  extremum_in(binary_, grown, k, k, true, interior_, refine_scratch_);
  if (masked_mean(refine_ratio_, interior_, star_ratio) < 6) masked_mean(refine_ratio_, binary_(grown), star_ratio);
  star_ratio /= 128.0;
  // Two dilations by k × k are one by (2k − 1) × (2k − 1) (odd k: both centred).
  if (k % 2 == 1) {
    extremum_in(binary_, grown, 2 * k - 1, 2 * k - 1, false, refine_scratch_, refine_floor_);
  } else {
    cv::dilate(binary_(grown), refine_scratch_, kernel_, cv::Point(-1, -1), 2);
  }
  cv::bitwise_not(refine_scratch_, refine_scratch_);
  if (masked_mean(refine_ratio_, refine_scratch_, floor_ratio) < 8) return false;
  floor_ratio /= 128.0;
  // The floor at full resolution over the region (its top-left is the grown box's), scaled to the level.
  const cv::Point2f scale = coarse_scale();
  upsample_linear(coarse_floor_(grown), static_cast<int>(scale.x), static_cast<int>(scale.y),
                  cv::Rect(0, 0, region.width, region.height), refine_floor_);
  refine_floor_.convertTo(refine_level_, CV_8U, 0.5 * (star_ratio + floor_ratio));
  cv::compare(view_(region), refine_level_, refine_binary_, cv::CMP_LT);
  return true;
}

bool StarDetector::robust_refine(const cv::Rect& coarse_box, StarCandidate& c, StarShapeScore& score) {
  const cv::Point2f scale = coarse_scale();
  const int sx = static_cast<int>(scale.x), sy = static_cast<int>(scale.y);
  // The mid-level edge may lie a little outside the coarse edge: grow by 12 frame pixels on every side.
  const int gx = 6, gy = 12 / (sy * static_cast<int>(view_row_scale_));
  const cv::Rect grown = cv::Rect(coarse_box.x - gx, coarse_box.y - gy, coarse_box.width + 2 * gx,
                                  coarse_box.height + 2 * gy) & cv::Rect(0, 0, coarse_.cols, coarse_.rows);
  const cv::Rect region = cv::Rect(grown.x * sx, grown.y * sy, grown.width * sx, grown.height * sy) &
                          cv::Rect(0, 0, view_.cols, view_.rows);
  if (!mid_level_threshold(grown, region)) return false;
  const std::vector<cv::Point>* best = mid_level_outline(region);
  if (best == nullptr) return false;
  // Touching the region's border means the mid-level shape merged with something: keep the coarse one.
  const cv::Rect box = cv::boundingRect(*best);
  if (box.x <= region.x || box.y <= region.y || box.br().x >= region.br().x || box.br().y >= region.br().y) return false;
  std::vector<cv::Point2f> rectified;
  rectify(*best, cv::Point2f(1.0f, 1.0f), rectified);
  const cv::Moments m = cv::moments(rectified);
  // The coarse contour of the low level is thinner than the mid-level one; a merge shows as a failed shape.
  if (!(std::fabs(m.m00) > 0.5 * c.area && std::fabs(m.m00) < 2.5 * c.area)) return false;
  score = shape_test_.score(rectified, m, settings_.shape);
  if (!score.is_star) return false;
  c.rectified.swap(rectified);
  c.area = std::fabs(m.m00);
  c.centroid = cv::Point2d(m.m10 / m.m00, m.m01 / m.m00);
  to_frame(*best, cv::Point2f(1.0f, 1.0f), frame_points_);
  return true;
}

std::vector<StarCandidate> StarDetector::detect_robust(const cv::Mat& gray, const cv::Rect& roi, double level_ratio,
                                                       DetectorTimes* times) {
  // Two contrast levels: the image's own (Otsu) and a low one that only the darkest objects pass, so a
  // star inside a shadow or next to dark texture, merged with it at the first level, separates at the
  // second. A star found at both levels is kept once (the better shape). An ROI search measures the
  // floor (and ρ) over the floor region around it, so it cuts the star as a full-frame search would.
  std::vector<StarCandidate> candidates;
  const Clock::time_point t0 = Clock::now();
  const cv::Rect region = floor_region(roi, gray.size());
  make_view(gray, region);
  const cv::Rect window((roi.x - region.x), static_cast<int>((roi.y - region.y) / view_row_scale_), roi.width,
                        static_cast<int>(std::ceil(roi.height / view_row_scale_)));
  if (settings_.robust_sync_repair) repair_sync_bands();
  robust_floor(window, level_ratio);
  double threshold_us = microseconds(t0, Clock::now()), refine_us = 0.0;
  const double levels[2] = {threshold_ratio_, std::max(settings_.robust_min_ratio, settings_.robust_low_ratio * threshold_ratio_)};
  merged_.clear();
  for (double level : levels) {
    // The low level separates a star that merged with dark texture at the first: not needed when the
    // first found a star-shaped outline (unless robust_low_level_always).
    if (level != levels[0] && !candidates.empty() && !settings_.robust_low_level_always) break;
    const Clock::time_point l0 = Clock::now();
    robust_threshold(level);
    level_ = level;
    threshold_us += microseconds(l0, Clock::now());
    robust_candidates(candidates, refine_us, cv::Rect(0, 0, binary_.cols, binary_.rows),
                      settings_.robust_split_merged && level == levels[0]);
  }
  if (candidates.empty() && settings_.robust_split_merged) split_merged(candidates, refine_us);
  if (times != nullptr) {
    times->threshold_morphology_us += threshold_us;
    times->contours_filters_us += microseconds(t0, Clock::now()) - threshold_us - refine_us;
    times->rectify_points_us += refine_us;
  }
  return candidates;
}

void StarDetector::robust_candidates(std::vector<StarCandidate>& candidates, double& refine_us, const cv::Rect& region,
                                     bool collect_merged) {
  cv::findContours(binary_(region), contours_, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE, region.tl());
  const DetectorSettings& s = settings_;
  const cv::Point2f scale = coarse_scale();
  const double px_area = scale.x * scale.y * view_row_scale_;  // frame pixels² per coarse pixel
  for (std::vector<cv::Point>& contour : contours_) {
    const cv::Rect box = cv::boundingRect(contour);
    if (contour.size() < 8) {
      note(box, ContourFate::kTooFewPoints);
      continue;
    }
    const double raw_area = cv::contourArea(contour);  // coarse pixels²
    if (touches_border(box, binary_.size(), std::max(1, s.edge_margin_px / 2))) {  // cut by the edge
      note(box, ContourFate::kTouchesBorder);
      if (collect_merged && raw_area * px_area > s.min_area_px) merged_.push_back(MergedOutline{raw_area, std::move(contour)});
      continue;
    }
    if (!(raw_area * px_area > s.raw_area_prefilter * s.min_area_px)) {
      note(box, ContourFate::kSmallRawArea);
      continue;
    }
    StarCandidate c;
    rectify(contour, scale, c.rectified);
    const cv::Moments m = cv::moments(c.rectified);
    c.area = std::fabs(m.m00);
    if (!(c.area > s.min_area_px)) {
      note(box, ContourFate::kSmallArea, c.area);
      continue;
    }
    c.centroid = cv::Point2d(m.m10 / m.m00, m.m01 / m.m00);
    const Clock::time_point r0 = Clock::now();
    const size_t accepted = candidates.size();
    robust_accept(contour, box, m, c, candidates);
    refine_us += microseconds(r0, Clock::now());
    if (collect_merged && candidates.size() == accepted && c.area > 2.0 * s.min_area_px) {
      merged_.push_back(MergedOutline{raw_area, std::move(contour)});
    }
  }
}

void StarDetector::split_merged(std::vector<StarCandidate>& candidates, double& refine_us) {
  // The first level's outlines, the largest first: a star merged with a shadow or dark texture makes one
  // of the larger ones. (The low level's, holding less of the neighbour, split a star from a neighbour as
  // dark as itself on noise: a strip of the star's grey gave fixes 4 % of the range off.)
  constexpr size_t kMaxOutlines = 4;
  std::sort(merged_.begin(), merged_.end(), [](const MergedOutline& a, const MergedOutline& b) { return a.area > b.area; });
  const double searched_level = level_;
  cv::Rect written;  // the box of binary_ the last outline's search wrote (empty: binary_ not cleared yet)
  for (size_t n = 0; n < std::min(kMaxOutlines, merged_.size()); ++n) {
    const std::vector<cv::Point>& outline = merged_[n].contour;
    const cv::Rect box = cv::boundingRect(outline) & cv::Rect(0, 0, coarse_.cols, coarse_.rows);
    blob_mask_.create(box.size(), CV_8UC1);
    blob_mask_.setTo(0);
    cv::drawContours(blob_mask_, std::vector<std::vector<cv::Point>>{outline}, 0, cv::Scalar(255), cv::FILLED,
                     cv::LINE_8, cv::noArray(), INT_MAX, -box.tl());
    // The outline's pixels' image/floor ratios (in 1/255) and their Otsu level: the star is the darker
    // class of a star merged with something less dark.
    blob_ratios_.clear();
    for (int y = 0; y < box.height; ++y) {
      const uchar* m = blob_mask_.ptr<uchar>(y);
      const uchar* image = coarse_.ptr<uchar>(box.y + y) + box.x;
      const uchar* floor = coarse_floor_.ptr<uchar>(box.y + y) + box.x;
      for (int x = 0; x < box.width; ++x) {
        if (m[x] != 0) blob_ratios_.push_back(static_cast<uchar>(std::min(255, 255 * image[x] / std::max<int>(1, floor[x]))));
      }
    }
    if (blob_ratios_.size() < 64) continue;
    cv::Mat ratios(1, static_cast<int>(blob_ratios_.size()), CV_8UC1, blob_ratios_.data());
    const double level = cv::threshold(ratios, blob_binary_, 0.0, 255.0, cv::THRESH_BINARY | cv::THRESH_OTSU) / 255.0;
    if (!(level < 0.9 * threshold_ratio_ && level > 0.05)) continue;
    // The outline's pixels below its own level, opened, alone in binary_ (cleared whole once, then only
    // where the outline before wrote).
    const uint16_t q = static_cast<uint16_t>(std::clamp(std::lround(level * 256.0), 0L, 256L));
    below_level(coarse_(box), coarse_floor_(box), q, blob_binary_);
    cv::bitwise_and(blob_binary_, blob_mask_, blob_binary_);
    if (written.empty()) binary_.setTo(0);
    else binary_(written).setTo(0);
    written = box;
    cv::Mat opened = binary_(box);  // open_rect writes into binary_ through this header
    open_rect(blob_binary_, settings_.morphology_kernel_px, opened, median_hi_);
    level_ = level;
    const size_t before = candidates.size();
    splitting_ = true;
    robust_candidates(candidates, refine_us, box, false);
    splitting_ = false;
    for (size_t i = before; i < candidates.size(); ++i) candidates[i].split = true;
  }
  level_ = searched_level;
}

void StarDetector::robust_accept(const std::vector<cv::Point>& contour, const cv::Rect& box, const cv::Moments& m,
                                 StarCandidate& c, std::vector<StarCandidate>& candidates) {
  // The shape test on the coarse outline; a near miss gets a second chance at full resolution, where a
  // small or blurred star keeps its thin tips and inner corners (the coarse copy and its opening round
  // them off). A second-chance candidate must pass the full test on its mid-level outline.
  // The hull is computed only for outlines within the looser of the two limit sets.
  const StarShapeScore score = shape_test_.score(c.rectified, m, loosest_shape_);
  const bool retry = !score.is_star && settings_.refine_midpoint &&
                     StarShapeTest::within(score, settings_.retry_shape);
  if (!score.is_star && !retry) {
    note(box, ContourFate::kShape, c.area, score);
    keep_near_miss(contour, score, c);
    return;
  }
  StarShapeScore refined_score;
  bool refined = false;
  if (retry) {
    refined = robust_refine(box, c, refined_score);
    if (!refined) {
      note(box, ContourFate::kShape, c.area, score);
      keep_near_miss(contour, score, c);
      return;
    }
  }
  const StarShapeScore& used = retry ? refined_score : score;
  c.hu_distance = used.profile_rms;
  c.solidity = used.solidity;
  c.vertices = 8;
  // The same star from the other level: keep the better shape.
  auto same = std::find_if(candidates.begin(), candidates.end(), [&](const StarCandidate& o) { return same_outline(o, c); });
  if (same != candidates.end() && same->hu_distance <= c.hu_distance) {
    note(box, ContourFate::kDuplicate, c.area, used);
    return;
  }
  if (!retry) refined = settings_.refine_midpoint && robust_refine(box, c, refined_score);
  if (!refined && settings_.refine_midpoint && settings_.robust_require_midlevel) {
    // The coarse outline's centroid depends on the threshold level: off by a pixel on a far star, a
    // fix several per cent of the range away. No fix is better than that one.
    note(box, ContourFate::kNoMidLevel, c.area, used);
    return;
  }
  if (!refined) to_frame(contour, coarse_scale(), frame_points_);
  note(box, ContourFate::kAccepted, c.area, used, refined);
  c.refined = refined;
  for (const cv::Point2f& p : frame_points_) c.contour.emplace_back(cvRound(p.x), cvRound(p.y));
  c.box = cv::boundingRect(c.contour);
  if (same != candidates.end()) *same = std::move(c);
  else candidates.push_back(std::move(c));
}

void StarDetector::keep_near_miss(const std::vector<cv::Point>& contour, const StarShapeScore& score, StarCandidate& c) {
  // Not from split_merged: a part of a larger outline near the star's shape is not the star's outline.
  if (!settings_.keep_near_misses || splitting_ || !StarShapeTest::within(score, settings_.near_miss_shape)) return;
  c.hu_distance = score.profile_rms;
  c.solidity = score.solidity;
  c.strict = false;
  to_frame(contour, coarse_scale(), frame_points_);
  for (const cv::Point2f& p : frame_points_) c.contour.emplace_back(cvRound(p.x), cvRound(p.y));
  c.box = cv::boundingRect(c.contour);
  near_misses_.push_back(std::move(c));
}

void StarDetector::prune_near_misses(const std::vector<StarCandidate>& candidates) {
  // The pairing considers the best few of a view; one outline found at both levels counts once.
  constexpr size_t kMaxNearMisses = 3;
  std::sort(near_misses_.begin(), near_misses_.end(),
            [](const StarCandidate& a, const StarCandidate& b) { return a.hu_distance < b.hu_distance; });
  size_t kept = 0;
  for (size_t i = 0; i < near_misses_.size() && kept < kMaxNearMisses; ++i) {
    const StarCandidate& c = near_misses_[i];
    const auto seen = [&](const StarCandidate& o) { return same_outline(o, c); };
    if (std::any_of(candidates.begin(), candidates.end(), seen) ||
        std::any_of(near_misses_.begin(), near_misses_.begin() + kept, seen)) {
      continue;
    }
    if (kept != i) near_misses_[kept] = std::move(near_misses_[i]);
    ++kept;
  }
  near_misses_.resize(kept);
}

void StarDetector::note(const cv::Rect& coarse_box, ContourFate fate, double area, const StarShapeScore& shape,
                        bool refined) {
  if (trace_ == nullptr) return;
  const cv::Point2f scale = coarse_scale();
  std::vector<cv::Point2f> corners;
  to_frame({coarse_box.tl(), coarse_box.br() - cv::Point(1, 1)}, scale, corners);
  TracedContour t;
  t.frame_box = cv::Rect(cv::Point(cvFloor(corners[0].x), cvFloor(corners[0].y)),
                         cv::Point(cvCeil(corners[1].x) + 1, cvCeil(corners[1].y) + 1));
  t.level = level_;
  t.fate = fate;
  t.area = area;
  t.shape = shape;
  t.refined = refined;
  trace_->push_back(t);
}

}  // namespace quad::vision
