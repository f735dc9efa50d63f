#include "quad/vision/ground/image_track.h"

#include <algorithm>
#include <cmath>

namespace quad::vision::ground {

void ImageTrack::reset(const cv::Point2d& pixel, double sigma_px) {
  x_ = cv::Vec4d(pixel.x, pixel.y, 0.0, 0.0);
  P_ = cv::Matx44d::diag(cv::Vec4d(sigma_px * sigma_px, sigma_px * sigma_px, 300.0 * 300.0, 300.0 * 300.0));
  missed = 0;
}

void ImageTrack::predict(double dt, const ImageTrackNoise& noise) {
  cv::Matx44d F = cv::Matx44d::eye();
  F(0, 2) = dt;
  F(1, 3) = dt;
  // Discrete white-noise acceleration (Bar-Shalom): per axis q·[dt⁴/4, dt³/2; dt³/2, dt²].
  const double q = noise.acceleration_px_s2 * noise.acceleration_px_s2;
  cv::Matx44d Q = cv::Matx44d::zeros();
  for (int a = 0; a < 2; ++a) {
    Q(a, a) = q * dt * dt * dt * dt / 4.0;
    Q(a, a + 2) = Q(a + 2, a) = q * dt * dt * dt / 2.0;
    Q(a + 2, a + 2) = q * dt * dt;
  }
  x_ = F * x_;
  P_ = F * P_ * F.t() + Q;
}

double ImageTrack::mahalanobis2(const cv::Point2d& pixel, const ImageTrackNoise& noise) const {
  const double r = noise.measurement_px * noise.measurement_px;
  const cv::Matx22d S(P_(0, 0) + r, P_(0, 1), P_(1, 0), P_(1, 1) + r);
  const cv::Vec2d y(pixel.x - x_[0], pixel.y - x_[1]);
  return (y.t() * S.inv() * y)(0);
}

void ImageTrack::update(const cv::Point2d& pixel, const ImageTrackNoise& noise) {
  const double r = noise.measurement_px * noise.measurement_px;
  cv::Matx<double, 2, 4> H = cv::Matx<double, 2, 4>::zeros();
  H(0, 0) = H(1, 1) = 1.0;
  const cv::Matx22d S = H * P_ * H.t() + cv::Matx22d(r, 0, 0, r);
  const cv::Matx<double, 4, 2> K = P_ * H.t() * S.inv();
  const cv::Vec2d y(pixel.x - x_[0], pixel.y - x_[1]);
  x_ += K * y;
  P_ = (cv::Matx44d::eye() - K * H) * P_;
  missed = 0;
}

double ImageTrack::position_sigma_px() const {
  const double a = P_(0, 0), b = P_(0, 1), d = P_(1, 1);
  const double largest = 0.5 * (a + d) + std::sqrt(0.25 * (a - d) * (a - d) + b * b);
  return std::sqrt(std::max(largest, 0.0));
}

}  // namespace quad::vision::ground
