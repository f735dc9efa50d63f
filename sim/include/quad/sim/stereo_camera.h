// The vehicle's two downward cameras, rendered: the floor plane (plain grey or a photograph) with the
// four-pointed star at the NED origin and distractor shapes, seen through the simulator's own camera
// model (quad/sim/camera_model.h: lenses from the scenario, mounts from the MJCF).
//
// The cameras see only the floor (they look straight down between the landing gear), so each view is
// rendered exactly rather than rasterised by OpenGL: every floor shape's outline is projected through
// the distorting lens and filled with its exact coverage along each of 16 lines per pixel row
// (anti-aliased edges at true sub-pixel positions, unbiased in every direction); a floor photograph is
// sampled through the inverse lens per pixel. Then the analog camera and its capture chain: interlaced
// fields exposed 1/60 s apart (each at the vehicle's pose of its own time), motion blur over the shutter time, lighting fall-off, the frame's exposure, Gaussian sensor
// noise and JPEG compression. A plain 728 × 488 pair costs about 1.7 ms of CPU, with the floor
// photograph and interlacing about 14 ms (bench_sim BM_RenderStereoPair/0, /1).
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "quad/sim/camera_model.h"
#include "quad/sim/floor_texture.h"
#include "quad/sim/rng.h"
#include "quad/sim/scenario.h"

namespace quad::sim {

// A dark shape on a plane: outline in metres (on the floor: NED north, east with down = 0), and its albedo.
struct FloorShape {
  std::vector<Eigen::Vector2d> outline;
  double grey = 40.0;
};

// The landing star: four tips at `tip_to_tip / 2` along ±north and ±east, inner vertices at
// `inner_ratio` of that radius half-way between them, counter-clockwise from north.
std::vector<Eigen::Vector2d> landing_star_outline(double tip_to_tip, double inner_ratio);

// The star at the origin (shapes[0]) and `distractors` shapes 0.5 to 2.5 m away that do not overlap it
// or each other, placed by `rng`.
std::vector<FloorShape> make_floor_scene(const CameraParams& params, Rng rng);

// Paints `shapes[first..]` seen from `pose` (plane to camera) through `lens` onto `albedo` (CV_32F),
// each blended by its exact pixel coverage along x, sampled on 16 lines per row along y. `crossings` and
// `coverage` are work buffers.
void paint_shapes(const LensParams& lens, double valid_radius, const CameraPose& pose, const std::vector<FloorShape>& shapes,
                  size_t first, cv::Mat& albedo, std::vector<double>& crossings, cv::Mat& coverage);

struct VehiclePose {
  Eigen::Vector3d p_ned;
  Eigen::Quaterniond q_ib;
};
// The vehicle's pose at a (past) simulated time.
using PoseAtTime = std::function<VehiclePose(double t)>;

class StereoCameraRenderer {
 public:
  StereoCameraRenderer(const CameraParams& params, const SimStereoRig& rig, std::vector<FloorShape> scene, Rng rng);

  // Renders both views (CV_8UC1, the rig's image size) of a frame completed at time `t`: the last (or
  // only) field is exposed up to `t`, an interlaced frame's first field (even rows) up to t − 1/60 s.
  // With `hide_star` the marker is not drawn (a star covered or out of sight: the vision_dropout fault).
  void render(const PoseAtTime& pose_at, double t, bool hide_star, cv::Mat& left, cv::Mat& right);
  // A vehicle holding still at p_ned / q_ib.
  void render(const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool hide_star, cv::Mat& left,
              cv::Mat& right);

  // Both views of a flat target (e.g. a chessboard: `shapes` in the target's plane over a `background`
  // grey) whose plane-to-left-camera pose is `target_in_left`, with the same lenses, lighting, noise and
  // compression as the flight images, at nominal exposure.
  void render_target(const CameraPose& target_in_left, const std::vector<FloorShape>& shapes, double background,
                     cv::Mat& left, cv::Mat& right);

  // A second star-like shape, the star's copy centred at `north_east` (m), drawn from now on; nullopt
  // removes it (fault campaign: a decoy entering the view).
  void set_decoy(const std::optional<Eigen::Vector2d>& north_east);

  const SimStereoRig& rig() const { return rig_; }
  const std::vector<FloorShape>& scene() const { return scene_; }
  // Sub-exposures of the last view rendered (motion blur: 1 when still or with no shutter time).
  int last_blur_samples() const { return last_blur_samples_; }

 private:
  struct View {
    LensParams lens;
    CameraMountModel mount;
    double valid_radius = 0.0;
    cv::Mat lighting;  // CV_32F vignetting, per pixel
    cv::Mat rays;      // CV_32FC2 normalised undistorted (x, y) per pixel, NaN beyond the lens' fold
  };
  View make_view(const LensParams& lens, const CameraMountModel& mount) const;
  // The floor's rows first_row, first_row + row_step, ... (the shapes are painted whole).
  void floor_albedo(const View& view, const VehiclePose& pose, bool hide_star, int first_row, int row_step, cv::Mat& albedo);
  int blur_samples(const View& view, const VehiclePose& start, const VehiclePose& end) const;
  void render_view(const View& view, const PoseAtTime& pose_at, double t, bool hide_star, double exposure, cv::Mat& out);
  void expose(const View& view, const cv::Mat& albedo, double exposure, cv::Mat& out);

  CameraParams p_;
  SimStereoRig rig_;
  std::vector<FloorShape> scene_;
  size_t scene_shapes_;  // the scene without the decoy
  Rng rng_;
  View left_, right_;
  std::optional<FloorTexture> texture_;
  std::vector<int8_t> noise_;  // a table of Gaussian samples, read from a random offset per view
  double exposure_walk_ = 0.0;
  int last_blur_samples_ = 1;
  cv::Mat albedo_, sum_, coverage_;  // work buffers
  std::vector<double> crossings_;
};

}  // namespace quad::sim
