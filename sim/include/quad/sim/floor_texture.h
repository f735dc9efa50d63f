// A photograph laid on the floor (carpet, rug, printed pattern): the image in grey, mirrored into a
// seamless 2 × 2 tile repeated over the whole plane, its grey levels mapped to albedo around the
// scenario's floor_grey with the scenario's contrast. Sampled per pixel through the camera's inverse
// lens, from a mipmap level whose texel matches the pixel's footprint (no aliasing from high up).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/sim/camera_model.h"

namespace quad::sim {

class FloorTexture {
 public:
  // Throws std::runtime_error naming `path` when it is not a readable image.
  FloorTexture(const std::string& path, double side_m, double mean_grey, double contrast);

  // Fills rows first_row, first_row + row_step, ... of `albedo` (CV_32F, the size of `rays`) with the
  // floor seen along each pixel's ray (`rays`: CV_32FC2 normalised undistorted x, y; NaN: not on the
  // floor) from a camera at `pose` (NED floor to camera). `focal_px` sets the mipmap level. Rays that
  // miss the floor get the mean grey.
  void fill(const cv::Mat& rays, const CameraPose& pose, double focal_px, int first_row, int row_step, cv::Mat& albedo);

 private:
  std::vector<cv::Mat> levels_;  // CV_8U albedo plus a wrapped last row and column; level k: 2^k larger texels
  std::vector<cv::Size> sizes_;  // each level's tile without the wrapped row and column
  double texel_m_;               // texel side at level 0
  double mean_;
  cv::Mat map_x_, map_y_, sampled_;  // work buffers
};

}  // namespace quad::sim
