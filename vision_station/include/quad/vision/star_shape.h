// Shape test of the robust detector: is a closed outline (rectified pixels) the four-pointed star?
//
// The outline is first normalised for any affine view of it (centred on its centroid and whitened by its
// second moments: the star is 4-fold symmetric, so its own second moments are isotropic and whitening
// undoes the stretch of a tilted or off-axis view). Its radius as a function of angle is then compared
// with the ideal star's: four tips 90° apart with four inner corners at inner_ratio between them. Blur
// rounds the tips and fills the inner corners but keeps this profile's phase and harmonics; a five-pointed
// star (5-fold), a square (shallow 4-fold), a circle (flat) and a cross (parallel-sided arms: a flat-
// topped, steep-sided profile) do not have it.
#pragma once

#include <array>
#include <vector>

#include <opencv2/core.hpp>

namespace quad::vision {

struct StarShapeLimits {
  double max_elongation = 2.6;     // sqrt of the second-moment eigenvalue ratio (a view up to ~67° off normal)
  double max_profile_rms = 0.13;   // RMS difference to the ideal profile, relative to the mean radius
  double min_fourfold = 0.16;      // |4th harmonic| / mean radius (ideal star 0.32, square 0.06)
  double max_other_harmonic = 0.6; // largest of harmonics 1, 2, 3, 5, 6, 7 relative to the 4th
  double min_solidity = 0.42;      // area / convex-hull area (ideal star 0.566, cross ≤ 0.53 unless fat)
  double max_solidity = 0.80;
};

struct StarShapeScore {
  bool is_star = false;
  double elongation = 0.0, profile_rms = 0.0, fourfold = 0.0, other_harmonic = 0.0, solidity = 0.0;
};

class StarShapeTest {
 public:
  StarShapeTest(double inner_ratio, const StarShapeLimits& limits);
  StarShapeScore score(const std::vector<cv::Point2f>& outline) const;
  // The same, but an outline whose profile already fails `gate` (looser limits) gets no convex hull:
  // solidity 0 and not a star. The hull is the test's largest cost on a textured floor's many outlines.
  StarShapeScore score(const std::vector<cv::Point2f>& outline, const StarShapeLimits& gate) const;
  // The same with the outline's cv::moments, when the caller has them already.
  StarShapeScore score(const std::vector<cv::Point2f>& outline, const cv::Moments& moments,
                       const StarShapeLimits& gate) const;
  // The measured score within other limits (score() applies the test's own).
  static bool within(const StarShapeScore& s, const StarShapeLimits& limits);

  static constexpr int kBins = 64;

 private:
  using Profile = std::array<double, kBins>;
  // Largest whitened radius per angle bin (gaps filled from their neighbours), divided by its mean.
  static bool radial_profile(const std::vector<cv::Point2f>& outline, const cv::Moments& m, Profile& profile,
                             double& elongation);

  StarShapeLimits limits_;
  Profile ideal_{};
};

}  // namespace quad::vision
