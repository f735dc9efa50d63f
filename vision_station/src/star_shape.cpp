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

// atan2 in (−π, π] by an odd minimax polynomial on [0, 1] (|error| < 1e-5 rad) and the octant.
double fast_atan2(double y, double x) {
  const double ax = std::fabs(x), ay = std::fabs(y);
  const double hi = std::max(ax, ay);
  if (hi == 0.0) return 0.0;
  const double a = std::min(ax, ay) / hi, a2 = a * a;
  double r = a * (0.99997726 + a2 * (-0.33262347 + a2 * (0.19354346 + a2 * (-0.11643287 + a2 * (0.05265332 + a2 * -0.01172120)))));
  if (ay > ax) r = 0.5 * CV_PI - r;
  if (x < 0.0) r = CV_PI - r;
  return y < 0.0 ? -r : r;
}

}  // namespace

StarShapeTest::StarShapeTest(double inner_ratio, const StarShapeLimits& limits) : limits_(limits) {
  std::vector<cv::Point2f> star;
  for (const cv::Point2d& p : star_vertices(StarShape{100.0, inner_ratio})) star.emplace_back(p);
  double elongation = 0.0;
  radial_profile(star, cv::moments(star), ideal_, elongation);
}

bool StarShapeTest::radial_profile(const std::vector<cv::Point2f>& outline, const cv::Moments& m, Profile& profile,
                                   double& elongation) {
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
  // The largest squared radius per bin first (one square root per bin at the end); the bin from a
  // polynomial arctangent (error below 1e-5 rad, a ten-thousandth of a bin).
  profile.fill(0.0);
  const size_t n = outline.size();
  const double bins_per_rad = kBins / (2.0 * CV_PI);
  // Consecutive samples mostly fall in the same bin: their maximum is kept in a register and written
  // when the bin changes, not read back from memory after every sample.
  int bin_now = 0;
  double max_now = 0.0;
  for (size_t i = 0; i < n; ++i) {
    // Each edge sampled finely enough to touch every bin it crosses.
    const cv::Point2f p0 = outline[i], p1 = outline[(i + 1) % n];
    const double ex = p1.x - p0.x, ey = p1.y - p0.y;
    const int steps = 1 + static_cast<int>(std::sqrt(ex * ex + ey * ey));
    const double x0 = p0.x - cx, y0 = p0.y - cy;
    const double u0 = s1 * (ct * x0 + st * y0), v0 = s2 * (-st * x0 + ct * y0);
    const double du = s1 * (ct * ex + st * ey) / steps, dv = s2 * (-st * ex + ct * ey) / steps;
    for (int k = 0; k < steps; ++k) {
      const double u = u0 + du * k, v = v0 + dv * k;
      const int bin = std::min(kBins - 1, static_cast<int>((fast_atan2(v, u) + CV_PI) * bins_per_rad));
      if (bin != bin_now) {
        profile[bin_now] = std::max(profile[bin_now], max_now);
        bin_now = bin;
        max_now = profile[bin];
      }
      max_now = std::max(max_now, u * u + v * v);
    }
  }
  profile[bin_now] = std::max(profile[bin_now], max_now);
  for (double& r : profile) r = std::sqrt(r);
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

StarShapeScore StarShapeTest::score(const std::vector<cv::Point2f>& outline) const { return score(outline, limits_); }

StarShapeScore StarShapeTest::score(const std::vector<cv::Point2f>& outline, const StarShapeLimits& gate) const {
  return score(outline, cv::moments(outline), gate);
}

StarShapeScore StarShapeTest::score(const std::vector<cv::Point2f>& outline, const cv::Moments& moments,
                                    const StarShapeLimits& gate) const {
  StarShapeScore s;
  Profile p;
  if (outline.size() < 8 || !radial_profile(outline, moments, p, s.elongation)) return s;
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
  if (!(s.elongation <= gate.max_elongation && s.profile_rms <= gate.max_profile_rms && s.fourfold >= gate.min_fourfold &&
        s.other_harmonic <= gate.max_other_harmonic)) {
    return s;  // solidity 0: fails any limits
  }
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
