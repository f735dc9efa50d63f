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
  levels_.push_back(tile);
  while (levels_.size() < 8 && levels_.back().cols >= 16 && levels_.back().rows >= 16) {
    cv::Mat down;
    cv::pyrDown(levels_.back(), down);
    levels_.push_back(down);
  }
}

void FloorTexture::fill(const cv::Mat& rays, const CameraPose& pose, double focal_px, cv::Mat& albedo) {
  const Eigen::Matrix3d Rt = pose.R.transpose();
  const Eigen::Vector3d c = -Rt * pose.t;  // camera centre, NED
  const double height = std::max(-c.z(), 1e-3);
  // A pixel covers about height / focal metres of floor near the optical axis.
  const double footprint = height / focal_px;
  const int level = std::clamp(static_cast<int>(std::floor(std::log2(std::max(footprint / texel_m_, 1.0)))), 0,
                               static_cast<int>(levels_.size()) - 1);
  const cv::Mat& tex = levels_[static_cast<size_t>(level)];
  const double texel = texel_m_ * std::ldexp(1.0, level);
  const float cols = static_cast<float>(tex.cols), rows = static_cast<float>(tex.rows);
  map_x_.create(rays.size(), CV_32F);
  map_y_.create(rays.size(), CV_32F);
  const Eigen::Matrix3f Rf = Rt.cast<float>();
  const Eigen::Vector3f cf = c.cast<float>();
  for (int v = 0; v < rays.rows; ++v) {
    const cv::Vec2f* ray = rays.ptr<cv::Vec2f>(v);
    float* mx = map_x_.ptr<float>(v);
    float* my = map_y_.ptr<float>(v);
    for (int u = 0; u < rays.cols; ++u) {
      const Eigen::Vector3f d = Rf * Eigen::Vector3f(ray[u][0], ray[u][1], 1.0f);
      if (!(d.z() > 1e-6f)) {  // NaN ray or looking above the horizon
        mx[u] = my[u] = -1e6f;
        continue;
      }
      const float s = -cf.z() / d.z();
      // Image column along east, row along north, wrapped into the tile.
      const float east = static_cast<float>((cf.y() + s * d.y()) / texel);
      const float north = static_cast<float>((cf.x() + s * d.x()) / texel);
      mx[u] = east - cols * std::floor(east / cols);
      my[u] = north - rows * std::floor(north / rows);
    }
  }
  cv::remap(tex, albedo, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_WRAP);
  // Rays off the floor (the wrap would have sampled somewhere): the mean grey.
  for (int v = 0; v < rays.rows; ++v) {
    const float* mx = map_x_.ptr<float>(v);
    float* a = albedo.ptr<float>(v);
    for (int u = 0; u < rays.cols; ++u)
      if (mx[u] < -1e5f) a[u] = static_cast<float>(mean_);
  }
}

}  // namespace quad::sim
