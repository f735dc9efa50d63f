#include "quad/vision/star_shape.h"

#include <algorithm>
#include <cmath>
#include <complex>

#include <opencv2/imgproc.hpp>

#include "quad/vision/ideal_star.h"

namespace quad::vision {
namespace {

constexpr int kHarmonics = 8;

// e^(−i·k·a_j) for the bin centres a_j and k = 0..7, computed once.
const std::array<std::array<std::complex<double>, StarShapeTest::kBins>, kHarmonics>& twiddles() {
  static const auto table = [] {
    std::array<std::array<std::complex<double>, StarShapeTest::kBins>, kHarmonics> t{};
    for (int k = 0; k < kHarmonics; ++k) {
      for (int i = 0; i < StarShapeTest::kBins; ++i) {
        t[k][i] = std::polar(1.0, -k * 2.0 * CV_PI * (i + 0.5) / StarShapeTest::kBins);
      }
    }
    return t;
  }();
  return table;
}

std::complex<double> harmonic(const std::array<double, StarShapeTest::kBins>& p, int k) {
  const std::array<std::complex<double>, StarShapeTest::kBins>& w = twiddles()[k];
  std::complex<double> c = 0.0;
  for (int i = 0; i < StarShapeTest::kBins; ++i) c += p[i] * w[i];
  return c * (2.0 / StarShapeTest::kBins);
}

}  // namespace

StarShapeTest::StarShapeTest(double inner_ratio, const StarShapeLimits& limits) : limits_(limits) {
  std::vector<cv::Point2f> star;
  for (const cv::Point2d& p : star_vertices(StarShape{100.0, inner_ratio})) star.emplace_back(p);
  double elongation = 0.0;
  radial_profile(star, ideal_, elongation);
}

bool StarShapeTest::radial_profile(const std::vector<cv::Point2f>& outline, Profile& profile, double& elongation) {
  const cv::Moments m = cv::moments(outline);
  if (std::fabs(m.m00) < 1e-9) return false;
  const double cx = m.m10 / m.m00, cy = m.m01 / m.m00;
  // Whitening W = C^(−1/2) of the area's covariance C (eigen decomposition of a symmetric 2 × 2).
  const double a = m.mu20 / m.m00, b = m.mu11 / m.m00, c = m.mu02 / m.m00;
  const double mean = 0.5 * (a + c), diff = std::sqrt(0.25 * (a - c) * (a - c) + b * b);
  const double l1 = mean + diff, l2 = mean - diff;
  if (!(l2 > 1e-9)) return false;
  elongation = std::sqrt(l1 / l2);
  const double theta = 0.5 * std::atan2(2.0 * b, a - c);
  const double ct = std::cos(theta), st = std::sin(theta);
  const double s1 = 1.0 / std::sqrt(l1), s2 = 1.0 / std::sqrt(l2);
  profile.fill(0.0);
  const size_t n = outline.size();
  for (size_t i = 0; i < n; ++i) {
    // Each edge sampled finely enough to touch every bin it crosses.
    const cv::Point2f p0 = outline[i], p1 = outline[(i + 1) % n];
    const int steps = 1 + static_cast<int>(cv::norm(p1 - p0));
    for (int k = 0; k < steps; ++k) {
      const double x = p0.x + (p1.x - p0.x) * k / steps - cx, y = p0.y + (p1.y - p0.y) * k / steps - cy;
      const double u = s1 * (ct * x + st * y), v = s2 * (-st * x + ct * y);
      const double ang = std::atan2(v, u) + CV_PI;
      const int bin = std::min(kBins - 1, static_cast<int>(ang / (2.0 * CV_PI) * kBins));
      profile[bin] = std::max(profile[bin], std::hypot(u, v));
    }
  }
  for (int i = 0; i < kBins; ++i) {  // empty bins: the mean of the nearest filled neighbours
    if (profile[i] > 0.0) continue;
    int lo = i, hi = i;
    while (profile[(lo + kBins) % kBins] == 0.0 && i - lo < kBins) --lo;
    while (profile[hi % kBins] == 0.0 && hi - i < kBins) ++hi;
    profile[i] = 0.5 * (profile[(lo + kBins) % kBins] + profile[hi % kBins]);
  }
  double sum = 0.0;
  for (double r : profile) sum += r;
  if (!(sum > 0.0)) return false;
  for (double& r : profile) r *= kBins / sum;
  return true;
}

StarShapeScore StarShapeTest::score(const std::vector<cv::Point2f>& outline) const {
  StarShapeScore s;
  Profile p;
  if (outline.size() < 8 || !radial_profile(outline, p, s.elongation)) return s;
  const std::complex<double> c4 = harmonic(p, 4);
  s.fourfold = std::abs(c4);
  for (int k : {1, 2, 3, 5, 6, 7}) s.other_harmonic = std::max(s.other_harmonic, std::abs(harmonic(p, k)));
  s.other_harmonic /= std::max(s.fourfold, 1e-9);
  // Align the ideal profile's tips with the outline's (phase of the 4th harmonic), compare bin by bin.
  const double shift_bins = -(std::arg(c4) - std::arg(harmonic(ideal_, 4))) / 4.0 / (2.0 * CV_PI) * kBins;
  double sq = 0.0;
  for (int i = 0; i < kBins; ++i) {
    const double j = i - shift_bins;
    const double f = std::floor(j);
    const int j0 = ((static_cast<int>(f) % kBins) + kBins) % kBins, j1 = (j0 + 1) % kBins;
    const double ideal = ideal_[j0] * (1.0 - (j - f)) + ideal_[j1] * (j - f);
    sq += (p[i] - ideal) * (p[i] - ideal);
  }
  s.profile_rms = std::sqrt(sq / kBins);
  std::vector<cv::Point2f> hull;
  cv::convexHull(outline, hull);
  s.solidity = std::fabs(cv::contourArea(outline)) / std::max(cv::contourArea(hull), 1e-9);
  s.is_star = within(s, limits_);
  return s;
}

bool StarShapeTest::within(const StarShapeScore& s, const StarShapeLimits& l) {
  return s.elongation <= l.max_elongation && s.profile_rms <= l.max_profile_rms && s.fourfold >= l.min_fourfold &&
         s.other_harmonic <= l.max_other_harmonic && s.solidity >= l.min_solidity && s.solidity <= l.max_solidity;
}

}  // namespace quad::vision
