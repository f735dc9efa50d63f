#include "quad/vision/coarse_image.h"

#include <algorithm>
#include <vector>

#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

namespace quad::vision {

void half_resolution(const cv::Mat& view, bool rows_too, cv::Mat& out) {
  // cv::resize takes a general path for the column-only case and costs several times more.
  const int cols = std::max(1, view.cols / 2), rows = std::max(1, rows_too ? view.rows / 2 : view.rows);
  out.create(rows, cols, CV_8UC1);
  for (int r = 0; r < rows; ++r) {
    uchar* o = out.ptr<uchar>(r);
    const uchar* a = view.ptr<uchar>(rows_too ? 2 * r : r);
    if (rows_too) {
      const uchar* b = view.ptr<uchar>(std::min(2 * r + 1, view.rows - 1));
      for (int x = 0; x < cols; ++x) o[x] = static_cast<uchar>((a[2 * x] + a[2 * x + 1] + b[2 * x] + b[2 * x + 1] + 2) >> 2);
    } else {
      for (int x = 0; x < cols; ++x) o[x] = static_cast<uchar>((a[2 * x] + a[2 * x + 1] + 1) >> 1);
    }
  }
}

void quarter_area(const cv::Mat& src, cv::Mat& dst) {
  CV_Assert(src.type() == CV_8UC1);
  if (src.cols % 4 != 0 || src.rows % 4 != 0 || src.empty()) {
    cv::resize(src, dst, cv::Size(std::max(1, src.cols / 4), std::max(1, src.rows / 4)), 0, 0, cv::INTER_AREA);
    return;
  }
  dst.create(src.rows / 4, src.cols / 4, CV_8UC1);
  const int cols = dst.cols;  // locals: a uchar store may alias a Mat's members, which stops vectorising
  for (int r = 0; r < dst.rows; ++r) {
    const uchar* s[4] = {src.ptr<uchar>(4 * r), src.ptr<uchar>(4 * r + 1), src.ptr<uchar>(4 * r + 2), src.ptr<uchar>(4 * r + 3)};
    uchar* o = dst.ptr<uchar>(r);
    for (int x = 0; x < cols; ++x) {
      const unsigned sum = s[0][4 * x] + s[0][4 * x + 1] + s[0][4 * x + 2] + s[0][4 * x + 3] + s[1][4 * x] +
                           s[1][4 * x + 1] + s[1][4 * x + 2] + s[1][4 * x + 3] + s[2][4 * x] + s[2][4 * x + 1] +
                           s[2][4 * x + 2] + s[2][4 * x + 3] + s[3][4 * x] + s[3][4 * x + 1] + s[3][4 * x + 2] +
                           s[3][4 * x + 3];
      // OpenCV's sum · (1/16) rounded to nearest, ties to even.
      const unsigned q = sum >> 4, rest = sum & 15u;
      o[x] = static_cast<uchar>(q + ((rest > 8u || (rest == 8u && (q & 1u))) ? 1u : 0u));
    }
  }
}

namespace {

// Output pixel i of an f-fold enlargement of n pixels reads source pixels i0 and i1 with weights
// (2f − w1) and w1 in units of 1/(2f): its source coordinate is (2i + 1 − f)/(2f).
struct LinearTap {
  int i0, i1;
  uint16_t w0, w1;
};

LinearTap linear_tap(int i, int f, int n) {
  const int units = 2 * i + 1 - f, step = 2 * f;
  const int i0 = units >= 0 ? units / step : -((-units + step - 1) / step);  // floor
  LinearTap tap{i0, i0 + 1, 0, static_cast<uint16_t>(units - i0 * step)};
  if (tap.i0 < 0) tap = LinearTap{0, 0, 0, 0};
  if (tap.i1 > n - 1) tap = LinearTap{n - 1, n - 1, 0, 0};
  tap.w0 = static_cast<uint16_t>(step - tap.w1);
  return tap;
}

// Row s (n pixels) enlarged F = 2 or 4 times along x, in units of 1/(2F), at enlarged columns
// [x_begin, x_end) of `a`: between source pixels k and k + 1 lie outputs F k + F/2 + j (j < F) with weight
// 2j + 1 on k + 1. The interior eight source pixels at a time, the F outputs of each interleaved; the
// F/2 edge columns each side (replicated) by their taps. Outputs next to the range may be written as
// well (within 0 … F n − 1).
template <int F>
void enlarge_row(const uchar* s, int n, int x_begin, int x_end, uint16_t* a) {
  static_assert(F == 2 || F == 4, "two or four times");
  const int inner_begin = std::max(x_begin, F / 2), inner_end = std::min(x_end, F * n - F / 2);
  int k = 0, k_end = 0;
  if (inner_end > inner_begin) {
    k = (inner_begin - F / 2) / F;
    k_end = (inner_end - F / 2 + F - 1) / F;
  }
#if CV_SIMD128
  if (k_end - k >= 8) {
    auto weighted = [](const cv::v_uint16x8& left, const cv::v_uint16x8& right, int j) {
      return cv::v_mul_wrap(left, cv::v_setall_u16(static_cast<uint16_t>(2 * F - 1 - 2 * j))) +
             cv::v_mul_wrap(right, cv::v_setall_u16(static_cast<uint16_t>(2 * j + 1)));
    };
    for (const int k0 = k;; k += 8) {
      k = std::max(k0, std::min(k, k_end - 8));
      const cv::v_uint16x8 left = cv::v_load_expand(s + k), right = cv::v_load_expand(s + k + 1);
      if (F == 4) {
        cv::v_store_interleave(a + F * k + F / 2, weighted(left, right, 0), weighted(left, right, 1),
                               weighted(left, right, 2), weighted(left, right, 3));
      } else {
        cv::v_store_interleave(a + F * k + F / 2, weighted(left, right, 0), weighted(left, right, 1));
      }
      if (k + 8 >= k_end) break;
    }
    k = k_end;
  }
#endif
  for (; k < k_end; ++k) {
    for (int j = 0; j < F; ++j) {
      a[F * k + F / 2 + j] = static_cast<uint16_t>((2 * F - 1 - 2 * j) * s[k] + (2 * j + 1) * s[k + 1]);
    }
  }
  auto edge = [&](int x) {
    const LinearTap tap = linear_tap(x, F, n);
    a[x] = static_cast<uint16_t>(tap.w0 * s[tap.i0] + tap.w1 * s[tap.i1]);
  };
  for (int x = x_begin; x < std::min(x_end, F / 2); ++x) edge(x);
  for (int x = std::max(x_begin, F * n - F / 2); x < x_end; ++x) edge(x);
}

}  // namespace

void upsample_linear(const cv::Mat& src, int fx, int fy, const cv::Rect& out_region, cv::Mat& out) {
  CV_Assert(src.type() == CV_8UC1 && !src.empty());
  CV_Assert((fx == 1 || fx == 2 || fx == 4) && (fy == 1 || fy == 2 || fy == 4));
  CV_Assert((out_region & cv::Rect(0, 0, fx * src.cols, fy * src.rows)) == out_region);
  out.create(out_region.size(), CV_8UC1);
  const int width = out_region.width;
  // Rows interpolated along x (in units of 1/(2 fx)) over the enlarged row's whole width, kept for the two
  // source rows the last output row read: consecutive output rows share them.
  cv::Mat_<uint16_t> across(2, fx * src.cols);
  int held[2] = {-1, -1};
  auto row_across = [&](int source_row) -> const uint16_t* {
    for (int k = 0; k < 2; ++k) {
      if (held[k] == source_row) return across[k] + out_region.x;
    }
    const int k = held[0] == -1 || (held[1] != -1 && held[0] < held[1]) ? 0 : 1;
    const uchar* __restrict s = src.ptr<uchar>(source_row);
    uint16_t* __restrict a = across[k];
    if (fx == 4) enlarge_row<4>(s, src.cols, out_region.x, out_region.x + width, a);
    else if (fx == 2) enlarge_row<2>(s, src.cols, out_region.x, out_region.x + width, a);
    else std::transform(s + out_region.x, s + out_region.x + width, a + out_region.x, [](uchar v) { return static_cast<uint16_t>(2 * v); });
    held[k] = source_row;
    return a + out_region.x;
  };
  // Both weights' units: 4 fx fy, a power of two; the sums stay below 2¹⁶ (16 · 255 · 4).
  const int shift = (fx == 4 ? 3 : fx == 2 ? 2 : 1) + (fy == 4 ? 3 : fy == 2 ? 2 : 1);
  const uint16_t half = static_cast<uint16_t>(1u << (shift - 1));
  for (int y = 0; y < out_region.height; ++y) {
    const LinearTap row = linear_tap(out_region.y + y, fy, src.rows);
    const uint16_t* a0 = row_across(row.i0);
    const uint16_t* a1 = row_across(row.i1);
    const uint16_t w0 = row.w0, w1 = row.w1;
    uchar* o = out.ptr<uchar>(y);
    int x = 0;
#if CV_SIMD128
    // 16 pixels at a time, the last block overlapping the one before it (as extremum_of_n).
    if (width >= 16) {
      const cv::v_uint16x8 vw0 = cv::v_setall_u16(w0), vw1 = cv::v_setall_u16(w1), vhalf = cv::v_setall_u16(half);
      for (;; x += 16) {
        x = std::min(x, width - 16);
        const cv::v_uint16x8 lo = cv::v_mul_wrap(cv::v_load(a0 + x), vw0) + cv::v_mul_wrap(cv::v_load(a1 + x), vw1) + vhalf;
        const cv::v_uint16x8 hi = cv::v_mul_wrap(cv::v_load(a0 + x + 8), vw0) + cv::v_mul_wrap(cv::v_load(a1 + x + 8), vw1) + vhalf;
        cv::v_store(o + x, cv::v_pack(lo >> shift, hi >> shift));
        if (x + 16 >= width) break;
      }
      continue;
    }
#endif
    for (; x < width; ++x) o[x] = static_cast<uchar>((w0 * a0[x] + w1 * a1[x] + half) >> shift);
  }
}

namespace {

// dst[x] = the minimum (kMin) or maximum of sources[0][x] … sources[count − 1][x] for x < n, dst apart
// from the sources; kCount > 0 fixes count at compile time (the loop over the sources then unrolls). 16
// pixels at a time with OpenCV's universal intrinsics, accumulated in a register; the last block overlaps
// the one before it instead of a scalar tail (on rows of a few dozen pixels the tail costs as much as the
// rest), which only writes the same values again.
template <bool kMin, int kCount>
void extremum_of_n(const uchar* const* sources, int count, uchar* dst, int n) {
  const int m = kCount > 0 ? kCount : count;
  int x = 0;
#if CV_SIMD128
  if (n >= 16) {
    for (;; x += 16) {
      x = std::min(x, n - 16);
      cv::v_uint8x16 acc = cv::v_load(sources[0] + x);
      for (int k = 1; k < m; ++k) {
        const cv::v_uint8x16 v = cv::v_load(sources[k] + x);
        acc = kMin ? cv::v_min(acc, v) : cv::v_max(acc, v);
      }
      cv::v_store(dst + x, acc);
      if (x + 16 >= n) return;
    }
  }
#endif
  for (; x < n; ++x) {
    uchar acc = sources[0][x];
    for (int k = 1; k < m; ++k) acc = kMin ? std::min(acc, sources[k][x]) : std::max(acc, sources[k][x]);
    dst[x] = acc;
  }
}

template <bool kMin>
void extremum_of(const uchar* const* sources, int count, uchar* dst, int n) {
  // Three sources: the 3 × 3 opening, most of the detector's morphology.
  if (count == 3) extremum_of_n<kMin, 3>(sources, count, dst, n);
  else extremum_of_n<kMin, 0>(sources, count, dst, n);
}

// The minimum (erosion) or maximum (dilation) over a width × height rectangle centred on each pixel, of
// the pixels inside the image only: OpenCV's default morphology border (255 outside for the erosion, 0
// for the dilation) changes no extremum. Separable: down the rows first, then along each row (padded by
// its end values, which leaves the extremum unchanged too).
template <bool kMin>
void extremum_rect(const cv::Mat& src, cv::Mat& dst, int width, int height) {
  CV_Assert(src.type() == CV_8UC1 && src.data != dst.data && !src.empty() && width > 0 && height > 0);
  // OpenCV's default anchor: the window spans [x − w/2, x + w − 1 − w/2].
  const int rows = src.rows, cols = src.cols, rx = width / 2, rx_after = width - 1 - rx;
  const int ry = height / 2, ry_after = height - 1 - ry;
  dst.create(rows, cols, CV_8UC1);
  std::vector<uchar> padded(static_cast<size_t>(cols + rx + rx_after));
  uchar* c = padded.data() + rx;
  std::vector<const uchar*> window_rows(static_cast<size_t>(height)), shifted(static_cast<size_t>(width));
  for (int k = 0; k < width; ++k) shifted[k] = c - rx + k;
  for (int r = 0; r < rows; ++r) {
    const int first = std::max(r - ry, 0), last = std::min(r + ry_after, rows - 1);
    for (int k = first; k <= last; ++k) window_rows[k - first] = src.ptr<uchar>(k);
    extremum_of<kMin>(window_rows.data(), last - first + 1, c, cols);
    std::fill(c - rx, c, c[0]);
    std::fill(c + cols, c + cols + rx_after, c[cols - 1]);
    extremum_of<kMin>(shifted.data(), width, dst.ptr<uchar>(r), cols);
  }
}

}  // namespace

void erode_rect(const cv::Mat& src, cv::Mat& dst, int width, int height) { extremum_rect<true>(src, dst, width, height); }

void dilate_rect(const cv::Mat& src, cv::Mat& dst, int width, int height) { extremum_rect<false>(src, dst, width, height); }

void open_rect(const cv::Mat& src, int k, cv::Mat& dst, cv::Mat& scratch) {
  erode_rect(src, scratch, k, k);
  dilate_rect(scratch, dst, k, k);
}

void extremum_in(const cv::Mat& image, const cv::Rect& roi, int width, int height, bool minimum, cv::Mat& out,
                 cv::Mat& scratch) {
  // Grown by the window on every side (within the image): inside that, the window of every pixel of `roi`
  // holds the same pixels as in the whole image; at the grown region's edges the clamped window drops
  // only pixels no `roi` pixel reaches.
  const int rx = width / 2, ry = height / 2;
  const cv::Rect grown = cv::Rect(roi.x - rx, roi.y - ry, roi.width + width - 1, roi.height + height - 1) &
                         cv::Rect(0, 0, image.cols, image.rows);
  if (minimum) erode_rect(image(grown), scratch, width, height);
  else dilate_rect(image(grown), scratch, width, height);
  scratch(roi - grown.tl()).copyTo(out);
}

int masked_mean(const cv::Mat& values, const cv::Mat& mask, double& mean) {
  CV_Assert(values.type() == CV_8UC1 && mask.type() == CV_8UC1 && values.size() == mask.size());
  uint64_t sum = 0;
  int count = 0;
  const int cols = values.cols;
  for (int r = 0; r < values.rows; ++r) {
    const uchar* v = values.ptr<uchar>(r);
    const uchar* m = mask.ptr<uchar>(r);
    for (int x = 0; x < cols; ++x) {
      const bool in = m[x] != 0;
      sum += in ? v[x] : 0u;
      count += in ? 1 : 0;
    }
  }
  mean = static_cast<double>(sum) * (count != 0 ? 1.0 / count : 0.0);  // OpenCV's s · (1/n)
  return count;
}

void vertical_median_3(cv::Mat& image, cv::Mat& scratch) {
  // median(a, b, c) = max(min(a, b), min(max(a, b), c)), on the original rows: each output row is kept
  // in `scratch` until the row below it no longer needs the original.
  if (image.rows < 3) return;
  scratch.create(2, image.cols, CV_8UC1);
  const int cols = image.cols;
  uchar* previous = scratch.ptr<uchar>(0);  // original row r − 1
  uchar* current = scratch.ptr<uchar>(1);
  std::copy(image.ptr<uchar>(0), image.ptr<uchar>(0) + cols, previous);
  for (int r = 1; r + 1 < image.rows; ++r) {
    uchar* b = image.ptr<uchar>(r);
    const uchar* c = image.ptr<uchar>(r + 1);
    std::copy(b, b + cols, current);
    for (int x = 0; x < cols; ++x) {
      const uchar lo = std::min(previous[x], current[x]), hi = std::max(previous[x], current[x]);
      b[x] = std::max(lo, std::min(hi, c[x]));
    }
    std::swap(previous, current);
  }
}

void below_level(const cv::Mat& image, const cv::Mat& floor, uint16_t q, cv::Mat& out) {
  // image · 256 < floor · q  ⇔  image < ⌈floor · q / 256⌉ for an integer image: one 16-bit multiply.
  CV_Assert(image.size() == floor.size() && q <= 256);
  out.create(image.size(), CV_8UC1);
  const int cols = image.cols;
  for (int r = 0; r < image.rows; ++r) {
    const uchar* im = image.ptr<uchar>(r);
    const uchar* fl = floor.ptr<uchar>(r);
    uchar* o = out.ptr<uchar>(r);
    int x = 0;
#if CV_SIMD128
    // The same arithmetic 16 pixels at a time (the compiler widens the comparison to 32 bits and takes
    // three times as long): the level fits a byte, so image < level ⇔ (level − image, saturated) ≠ 0.
    const cv::v_uint16x8 vq = cv::v_setall_u16(q), round_up = cv::v_setall_u16(255);
    for (; x + 16 <= cols; x += 16) {
      cv::v_uint16x8 lo, hi;
      cv::v_expand(cv::v_load(fl + x), lo, hi);
      const cv::v_uint8x16 level = cv::v_pack(cv::v_shr<8>(cv::v_mul_wrap(lo, vq) + round_up),
                                              cv::v_shr<8>(cv::v_mul_wrap(hi, vq) + round_up));
      cv::v_store(o + x, (level - cv::v_load(im + x)) != cv::v_setzero_u8());
    }
#endif
    for (; x < cols; ++x) {
      const uint16_t level = static_cast<uint16_t>(static_cast<uint16_t>(fl[x] * q + 255u) >> 8);
      o[x] = static_cast<uint16_t>(im[x]) < level ? 255 : 0;
    }
  }
}

}  // namespace quad::vision
