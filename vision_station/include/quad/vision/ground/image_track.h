// One marker's track in one camera's image (seed 003 sec. 3.3.1): a Kalman filter with the second-order
// (constant-velocity) model on the marker's pixel coordinates, and its Mahalanobis distance to a
// detection, which gates the nearest-neighbour association.
#pragma once

#include <opencv2/core.hpp>

namespace quad::vision::ground {

struct ImageTrackNoise {
  double acceleration_px_s2 = 3000.0;  // white-acceleration process noise (vehicle manoeuvres, perspective)
  double measurement_px = 5.0;         // centroid noise for gating: detection, partial occlusion, shading
};

class ImageTrack {
 public:
  ImageTrack() = default;
  // Starts at a known pixel (seed 003: the initial position of each marker is known).
  void reset(const cv::Point2d& pixel, double sigma_px);
  void predict(double dt_s, const ImageTrackNoise& noise);
  // Squared Mahalanobis distance of a detection from the prediction (innovation covariance P + R).
  double mahalanobis2(const cv::Point2d& pixel, const ImageTrackNoise& noise) const;
  void update(const cv::Point2d& pixel, const ImageTrackNoise& noise);
  cv::Point2d predicted() const { return {x_[0], x_[1]}; }
  double position_sigma_px() const;  // the larger axis of the position covariance, square root

  int missed = 0;  // frames since the last associated detection

 private:
  cv::Vec4d x_;     // u, v, du/dt, dv/dt
  cv::Matx44d P_ = cv::Matx44d::eye();
};

}  // namespace quad::vision::ground
