// The robust detector's whole-image loops (coarse_image.h) against the OpenCV calls they stand for, on
// random, smooth and binary images of the sizes the detector sees and of odd sizes.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "quad/vision/coarse_image.h"

namespace quad::vision {
namespace {

cv::Mat random_image(cv::RNG& rng, cv::Size size, int kind) {
  cv::Mat image(size, CV_8UC1);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  if (kind == 1) cv::GaussianBlur(image, image, cv::Size(9, 9), 3.0);
  if (kind == 2) cv::threshold(image, image, 150, 255, cv::THRESH_BINARY);  // binary, salt everywhere
  return image;
}

int differing(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return -1;
  return cv::countNonZero(a != b);
}

const cv::Size kSizes[] = {{360, 240}, {360, 120}, {90, 60}, {37, 11}, {3, 3}, {1, 5}};

TEST(VisionCoarseImage, QuarterAreaIsOpenCvsAreaResize) {
  cv::RNG rng(3);
  for (const cv::Size size : {cv::Size(360, 240), cv::Size(360, 120), cv::Size(8, 4), cv::Size(38, 13)}) {
    for (int kind = 0; kind < 2; ++kind) {
      const cv::Mat image = random_image(rng, size, kind);
      cv::Mat expected, got;
      cv::resize(image, expected, cv::Size(std::max(1, size.width / 4), std::max(1, size.height / 4)), 0, 0, cv::INTER_AREA);
      quarter_area(image, got);
      EXPECT_EQ(differing(expected, got), 0) << size << " kind " << kind;
    }
  }
}

// The exact interpolation, rounded half up, of a source pixel pair per axis (double precision).
double exact_linear(const cv::Mat& src, int fx, int fy, int x, int y) {
  auto tap = [](int i, int f, int n, int& i0, int& i1, double& w1) {
    const double u = (i + 0.5) / f - 0.5;
    i0 = static_cast<int>(std::floor(u));
    w1 = u - i0;
    i1 = i0 + 1;
    if (i0 < 0) i0 = i1 = 0, w1 = 0.0;
    if (i1 > n - 1) i0 = i1 = n - 1, w1 = 0.0;
  };
  int x0, x1, y0, y1;
  double wx, wy;
  tap(x, fx, src.cols, x0, x1, wx);
  tap(y, fy, src.rows, y0, y1, wy);
  auto at = [&](int r, int c) { return static_cast<double>(src.at<uchar>(r, c)); };
  return (1 - wy) * ((1 - wx) * at(y0, x0) + wx * at(y0, x1)) + wy * ((1 - wx) * at(y1, x0) + wx * at(y1, x1));
}

TEST(VisionCoarseImage, LinearUpsamplingIsTheExactInterpolationWithinOneOfOpenCvs) {
  cv::RNG rng(11);
  int pixels = 0, off_by_one = 0;
  for (const cv::Size size : {cv::Size(45, 30), cv::Size(90, 60), cv::Size(37, 11), cv::Size(1, 5), cv::Size(3, 3)}) {
    for (const cv::Point2i factor : {cv::Point2i(4, 4), cv::Point2i(2, 2), cv::Point2i(2, 1), cv::Point2i(1, 1)}) {
      for (int kind = 0; kind < 2; ++kind) {
        const cv::Mat image = random_image(rng, size, kind);
        const cv::Size big(factor.x * size.width, factor.y * size.height);
        cv::Mat expected, got;
        cv::resize(image, expected, big, 0, 0, cv::INTER_LINEAR);
        upsample_linear(image, factor.x, factor.y, cv::Rect(cv::Point(0, 0), big), got);
        ASSERT_EQ(got.size(), big);
        for (int y = 0; y < big.height; ++y) {
          for (int x = 0; x < big.width; ++x) {
            const int mine = got.at<uchar>(y, x);
            ASSERT_EQ(mine, static_cast<int>(std::floor(exact_linear(image, factor.x, factor.y, x, y) + 0.5)))
                << size << " × " << factor << " at " << x << "," << y;
            ASSERT_LE(std::abs(mine - expected.at<uchar>(y, x)), 1) << size << " × " << factor << " at " << x << "," << y;
            off_by_one += mine != expected.at<uchar>(y, x);
            ++pixels;
          }
        }
        // A window is the same pixels as the whole enlargement cut to it.
        const cv::Rect window = cv::Rect(big.width / 3, big.height / 4, big.width / 2 + 1, big.height / 2 + 1) &
                                cv::Rect(cv::Point(0, 0), big);
        cv::Mat part;
        upsample_linear(image, factor.x, factor.y, window, part);
        EXPECT_EQ(differing(got(window), part), 0) << size << " × " << factor << " window " << window;
      }
    }
  }
  std::printf("upsample_linear: %d of %d pixels one grey level from cv::resize\n", off_by_one, pixels);
  EXPECT_GT(pixels, 100000);
}

TEST(VisionCoarseImage, RectangleMorphologyIsOpenCvs) {
  cv::RNG rng(4);
  for (const cv::Size window : {cv::Size(3, 3), cv::Size(2, 2), cv::Size(4, 3), cv::Size(21, 21), cv::Size(1, 5)}) {
    const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, window);
    for (const cv::Size size : kSizes) {
      for (int kind = 0; kind < 3; ++kind) {
        const cv::Mat image = random_image(rng, size, kind);
        cv::Mat eroded, dilated, opened, got, scratch;
        cv::erode(image, eroded, kernel);
        cv::dilate(image, dilated, kernel);
        erode_rect(image, got, window.width, window.height);
        EXPECT_EQ(differing(eroded, got), 0) << "erode " << window << " " << size << " kind " << kind;
        dilate_rect(image, got, window.width, window.height);
        EXPECT_EQ(differing(dilated, got), 0) << "dilate " << window << " " << size << " kind " << kind;
        if (window.width != window.height) continue;
        cv::dilate(eroded, opened, kernel);
        open_rect(image, window.width, got, scratch);
        EXPECT_EQ(differing(opened, got), 0) << "open " << window << " " << size << " kind " << kind;
      }
    }
  }
}

TEST(VisionCoarseImage, RegionMorphologyReadsAroundTheRegionLikeOpenCv) {
  cv::RNG rng(7);
  const cv::Mat image = random_image(rng, cv::Size(90, 60), 2);
  for (const cv::Rect roi : {cv::Rect(10, 10, 20, 15), cv::Rect(0, 0, 12, 9), cv::Rect(70, 45, 20, 15), cv::Rect(1, 50, 88, 10)}) {
    for (const int k : {3, 5}) {
      const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3));
      cv::Mat expected, got, scratch;
      if (k == 3) cv::erode(image(roi), expected, kernel);
      else cv::dilate(image(roi), expected, kernel, cv::Point(-1, -1), 2);  // two 3 × 3 are one 5 × 5
      extremum_in(image, roi, k, k, k == 3, got, scratch);
      EXPECT_EQ(differing(expected, got), 0) << roi << " k " << k;
    }
  }
}

TEST(VisionCoarseImage, MaskedMeanIsOpenCvsMean) {
  cv::RNG rng(8);
  for (const cv::Size size : kSizes) {
    const cv::Mat values = random_image(rng, size, 0), mask = random_image(rng, size, 2);
    double mean = -1.0;
    EXPECT_EQ(masked_mean(values, mask, mean), cv::countNonZero(mask));
    EXPECT_EQ(mean, cv::mean(values, mask)[0]) << size;  // bit for bit
  }
  double mean = -1.0;
  EXPECT_EQ(masked_mean(cv::Mat::ones(4, 4, CV_8UC1), cv::Mat::zeros(4, 4, CV_8UC1), mean), 0);
  EXPECT_EQ(mean, 0.0);
}

TEST(VisionCoarseImage, VerticalMedianIsMinMaxOnRowBlocks) {
  cv::RNG rng(5);
  for (const cv::Size size : kSizes) {
    const cv::Mat image = random_image(rng, size, 0);
    cv::Mat expected = image.clone();
    if (image.rows >= 3) {  // the formula the detector used with OpenCV's per-element min and max
      const int n = image.rows - 2;
      cv::Mat lo, hi;
      cv::min(image.rowRange(0, n), image.rowRange(1, n + 1), lo);
      cv::max(image.rowRange(0, n), image.rowRange(1, n + 1), hi);
      cv::min(hi, image.rowRange(2, n + 2), hi);
      cv::max(lo, hi, lo);
      lo.copyTo(expected.rowRange(1, n + 1));
    }
    cv::Mat got = image.clone(), scratch;
    vertical_median_3(got, scratch);
    EXPECT_EQ(differing(expected, got), 0) << size;
  }
}

TEST(VisionCoarseImage, BelowLevelIsTheRatioTestInDoubles) {
  cv::RNG rng(6);
  const cv::Mat image = random_image(rng, cv::Size(360, 240), 0), floor = random_image(rng, cv::Size(360, 240), 0);
  for (const int q : {0, 1, 64, 141, 205, 255, 256}) {
    cv::Mat expected(image.size(), CV_8UC1), got;
    for (int r = 0; r < image.rows; ++r) {
      for (int x = 0; x < image.cols; ++x) {
        expected.at<uchar>(r, x) = image.at<uchar>(r, x) < floor.at<uchar>(r, x) * (q / 256.0) ? 255 : 0;
      }
    }
    below_level(image, floor, static_cast<uint16_t>(q), got);
    EXPECT_EQ(differing(expected, got), 0) << "q " << q;
  }
}

}  // namespace
}  // namespace quad::vision
