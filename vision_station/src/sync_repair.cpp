// Rows of an analog frame that lost the line sync: the receiver draws a few lines shifted sideways, or
// blank, across whatever they cross (a star cut by such a band is two shapes). StarDetector repairs them
// before its search (star_detector.h, robust method).
#include <algorithm>
#include <cmath>
#include <cstdlib>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <opencv2/core.hpp>

#include "quad/vision/star_detector.h"

namespace quad::vision {
namespace {

// Mean absolute difference of two rows of an 8-bit image: SSE2's sum of absolute differences 16 pixels
// at a time where the compiler targets it (it does not find that instruction in the plain loop), the
// plain loop elsewhere and for the row's tail. Integer sums: both give the same value.
double row_difference(const cv::Mat& image, int a, int b) {
  const uchar* pa = image.ptr<uchar>(a);
  const uchar* pb = image.ptr<uchar>(b);
  const int cols = image.cols;
  unsigned sum = 0;
  int x = 0;
#if defined(__SSE2__)
  __m128i total = _mm_setzero_si128();
  for (; x + 16 <= cols; x += 16) {
    const __m128i va = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pa + x));
    const __m128i vb = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pb + x));
    total = _mm_add_epi64(total, _mm_sad_epu8(va, vb));
  }
  sum = static_cast<unsigned>(_mm_cvtsi128_si32(total)) + static_cast<unsigned>(_mm_cvtsi128_si32(_mm_srli_si128(total, 8)));
#endif
  for (; x < cols; ++x) sum += static_cast<unsigned>(std::abs(pa[x] - pb[x]));
  return static_cast<double>(sum) / cols;
}

// A line the receiver blanked: one grey level across the whole row (noise aside).
bool blank_row(const cv::Mat& image, int r) {
  constexpr double kFlatRange = 12.0;
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(image.row(r), &lo, &hi);
  return hi - lo <= kFlatRange;
}

}  // namespace

// The mean over the row of max(0, min(|r_a − r_a−1|, |r_b − r_b−1|) − |r_b − r_a−1|): how much both edges
// of the band [a, b) jump beyond what the rows around it differ by (a slanted edge moving across the band
// explains its own jump; a shifted band does not).
double StarDetector::unexplained_jump(const cv::Mat& image, int a, int b) {
  cv::absdiff(image.row(a), image.row(a - 1), band_top_);
  cv::absdiff(image.row(b), image.row(b - 1), band_bottom_);
  cv::min(band_top_, band_bottom_, band_top_);
  cv::absdiff(image.row(b), image.row(a - 1), band_bottom_);
  cv::subtract(band_top_, band_bottom_, band_top_);  // saturates at 0
  return cv::mean(band_top_)[0];
}

bool StarDetector::find_sync_bands(const cv::Mat& view, int max_band, std::vector<cv::Vec2i>& bands) {
  // A band [a, b): both its edges (rows a−1|a and b−1|b) jump, pixel by pixel, more than the rows just
  // outside it (a−1 and b) differ from each other, and the rows inside agree with each other (a band is
  // shifted or blanked as a whole). Natural edges fail the first test (the rows beyond an edge differ as
  // much as the edge itself), texture the second. A thin horizontal line also passes: interpolating it
  // away is harmless, the star has none.
  constexpr double kEdgeFloor = 2.0;
  const int rows = view.rows;
  bands.clear();
  if (rows < 2 * max_band + 2) return false;
  row_jump_.assign(rows, 0.0);
  for (int r = 1; r < rows; ++r) row_jump_[r] = row_difference(view, r, r - 1);
  sorted_jump_.assign(row_jump_.begin() + 1, row_jump_.end());
  std::nth_element(sorted_jump_.begin(), sorted_jump_.begin() + sorted_jump_.size() / 2, sorted_jump_.end());
  const double median_jump = sorted_jump_[sorted_jump_.size() / 2];
  const double spike = 2.0 * median_jump + kEdgeFloor;
  for (int a = 1; a + 1 < rows; ++a) {
    if (row_jump_[a] < spike) continue;
    if (blank_row(view, a)) {
      // Blanked lines (each one flat grey, black or white): the run of them is the band.
      int b = a + 1;
      while (b + 1 < rows && b - a < 2 * max_band && blank_row(view, b)) ++b;
      bands.emplace_back(a, b);
      a = b;
      continue;
    }
    for (int b = a + 1; b < rows && b - a <= max_band; ++b) {
      const double edge = std::min(row_jump_[a], row_jump_[b]);
      bool inside_agrees = true;
      for (int r = a + 1; r < b; ++r) inside_agrees = inside_agrees && row_jump_[r] < 0.5 * edge;
      if (!inside_agrees || edge < spike) continue;
      if (unexplained_jump(view, a, b) > median_jump + 1.0) {
        bands.emplace_back(a, b);
        a = b;
        break;
      }
    }
  }
  return !bands.empty();
}

void StarDetector::repair_sync_bands() {
  const int max_band = view_row_scale_ > 1.0f ? 4 : 8;  // up to 8 frame lines
  if (!find_sync_bands(view_, max_band, sync_bands_)) return;
  // The band's rows interpolated between the rows just outside it, in a copy of the view.
  view_.copyTo(repaired_);
  for (const cv::Vec2i& band : sync_bands_) {
    const int above = band[0] - 1, below = band[1];
    for (int r = band[0]; r < below; ++r) {
      const double t = static_cast<double>(r - above) / (below - above);
      cv::addWeighted(repaired_.row(above), 1.0 - t, repaired_.row(below), t, 0.0, repaired_.row(r));
    }
  }
  view_ = repaired_;
}

}  // namespace quad::vision
