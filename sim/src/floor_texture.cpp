#include "quad/sim/floor_texture.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace quad::sim {

FloorTexture::FloorTexture(const std::string& path, double side_m, double mean_grey, double contrast) : mean_(mean_grey) {
  const cv::Mat grey = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (grey.empty()) throw std::runtime_error(path + ": camera.floor_texture is not a readable image");
  cv::Mat g;
  grey.convertTo(g, CV_32F);
  cv::Scalar mean, sigma;
  cv::meanStdDev(g, mean, sigma);
  // Albedo = floor_grey · (1 + contrast · (g − mean) / σ): the photograph's pattern at a chosen strength.
  const double scale = sigma[0] > 0.0 ? mean_grey * contrast / sigma[0] : 0.0;
  g = (g - mean[0]) * scale + mean_grey;
  // Mirrored copies make the tile seamless when it repeats.
  cv::Mat flipped_x, flipped_y, flipped_xy, top, bottom, tile;
  cv::flip(g, flipped_x, 1);
  cv::flip(g, flipped_y, 0);
  cv::flip(g, flipped_xy, -1);
  cv::hconcat(g, flipped_x, top);
  cv::hconcat(flipped_y, flipped_xy, bottom);
  cv::vconcat(top, bottom, tile);
  texel_m_ = side_m / std::max(grey.cols, grey.rows);
  // 8-bit levels (OpenCV's fixed-point bilinear remap is several times faster than the float one),
  // each with one wrapped column and row appended so that coordinates wrapped into [0, size) never need
  // a border mode.
  cv::Mat level = tile;
  for (int k = 0; k < 8 && level.cols >= 16 && level.rows >= 16; ++k) {
    cv::Mat bytes, padded;
    level.convertTo(bytes, CV_8U);
    cv::copyMakeBorder(bytes, padded, 0, 1, 0, 1, cv::BORDER_WRAP);
    levels_.push_back(padded);
    sizes_.push_back(level.size());
    cv::Mat down;
    cv::pyrDown(level, down);
    level = down;
  }
}

void FloorTexture::fill(const cv::Mat& rays, const CameraPose& pose, double focal_px, int first_row, int row_step, cv::Mat& albedo) {
  const Eigen::Matrix3d Rt = pose.R.transpose();
  const Eigen::Vector3d c = -Rt * pose.t;  // camera centre, NED
  const double height = std::max(-c.z(), 1e-3);
  // A pixel covers about height / focal metres of floor near the optical axis.
  const double footprint = height / focal_px;
  const int level = std::clamp(static_cast<int>(std::floor(std::log2(std::max(footprint / texel_m_, 1.0)))), 0,
                               static_cast<int>(levels_.size()) - 1);
  const cv::Mat& tex = levels_[static_cast<size_t>(level)];
  const cv::Size tile = sizes_[static_cast<size_t>(level)];
  const double texel = texel_m_ * std::ldexp(1.0, level);
  const float cols = static_cast<float>(tile.width), rows = static_cast<float>(tile.height);
  const int out_rows = (rays.rows - first_row + row_step - 1) / row_step;
  map_x_.create(out_rows, rays.cols, CV_32F);
  map_y_.create(out_rows, rays.cols, CV_32F);
  const float r00 = static_cast<float>(Rt(0, 0)), r01 = static_cast<float>(Rt(0, 1)), r02 = static_cast<float>(Rt(0, 2));
  const float r10 = static_cast<float>(Rt(1, 0)), r11 = static_cast<float>(Rt(1, 1)), r12 = static_cast<float>(Rt(1, 2));
  const float r20 = static_cast<float>(Rt(2, 0)), r21 = static_cast<float>(Rt(2, 1)), r22 = static_cast<float>(Rt(2, 2));
  const float cx = static_cast<float>(c.x() / texel), cy = static_cast<float>(c.y() / texel), cz = static_cast<float>(-c.z());
  for (int i = 0; i < out_rows; ++i) {
    const cv::Vec2f* ray = rays.ptr<cv::Vec2f>(first_row + i * row_step);
    float* mx = map_x_.ptr<float>(i);
    float* my = map_y_.ptr<float>(i);
    for (int u = 0; u < rays.cols; ++u) {
      const float x = ray[u][0], y = ray[u][1];
      const float dz = r20 * x + r21 * y + r22;
      if (!(dz > 1e-6f)) {  // NaN ray or looking above the horizon: the mean grey below
        mx[u] = my[u] = -1.0f;
        continue;
      }
      const float s = cz / (dz * static_cast<float>(texel));
      // Image column along east, row along north, wrapped into the tile.
      const float east = cy + s * (r10 * x + r11 * y + r12);
      const float north = cx + s * (r00 * x + r01 * y + r02);
      mx[u] = east - cols * std::floor(east / cols);
      my[u] = north - rows * std::floor(north / rows);
    }
  }
  cv::remap(tex, sampled_, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(mean_));
  albedo.create(rays.size(), CV_32F);
  for (int i = 0; i < out_rows; ++i) {
    const uint8_t* in = sampled_.ptr<uint8_t>(i);
    const float* mx = map_x_.ptr<float>(i);
    float* a = albedo.ptr<float>(first_row + i * row_step);
    for (int u = 0; u < rays.cols; ++u) a[u] = mx[u] < 0.0f ? static_cast<float>(mean_) : static_cast<float>(in[u]);
  }
}

}  // namespace quad::sim
