// Random stereo pairs for one evaluation condition: the camera pose over the floor, the star (fully in
// view of both cameras, cut by an image edge, or absent), the decoys, the floor photograph, the lighting
// and the degradations; and the chessboard views for calibration.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "eval_camera.h"

namespace vision_eval {

// Which effects a condition switches on (each drawn at random per pair within its range).
struct Condition {
  std::string name;
  bool photo_floor = true;
  double max_blur_px = 0.0;
  bool interlaced = false;
  bool jpeg = false;            // quality 50–90
  bool harsh_lighting = false;  // strong gradient, lamp spot, shadow edge across the star
  bool analog_faults = false;   // RF snow, lost sync lines, frozen frames, rolling-shutter skew
};

std::vector<Condition> all_conditions();

// The truth and the parameters of one generated pair (one line of truth.csv).
struct PairTruth {
  bool star_in_view = false;      // whole star inside both images: a fix is expected
  bool star_cut = false;          // a four-pointed star cut by an image edge is in the pair
  cv::Vec3d star_left{0, 0, 0};   // star centre in the left camera frame (OpenCV axes), metres
  cv::Vec3d star_normal{0, 0, 0}; // the floor's normal into the floor, left camera frame (unit)
  double range_m = 0.0, height_m = 0.0, tilt_deg = 0.0;
  std::string floor;              // "plain" or the photograph's file name
  double blur_px = 0.0, field_shift_px = 0.0, skew_px = 0.0, snow = 0.0;
  int jpeg_quality = 0, sync_bands = 0, decoys = 0;
  bool interlaced = false, frozen = false;
};

struct StereoImages {
  cv::Mat left, right;  // CV_8UC1
  PairTruth truth;
};

class PairGenerator {
 public:
  PairGenerator(const EvalRig& rig, const std::vector<std::string>& photo_paths);
  void reseed(uint64_t seed);  // a fresh random sequence (and no frame to repeat)
  // One pair; `want_star` asks for the star in full view of both cameras.
  StereoImages make(const Condition& condition, bool want_star);

 private:
  struct Layout;
  CameraPose random_pose(double height);
  bool place_star(const CameraPose& left, Layout& layout);
  bool place_cut_star(const CameraPose& left, Layout& layout);
  void place_decoys(const CameraPose& left, Layout& layout);
  // Blur, interlacing, skew, noise, snow, sync loss into out.left/out.right (8-bit), recorded in out.truth.
  void degrade(const Condition& condition, const Layout& layout, cv::Mat views[2], StereoImages& out);
  bool ray_to_floor(const CameraPose& pose, cv::Point2d pixel, cv::Point2d& floor) const;
  // Fraction of the (densified) outline that projects inside the image with a margin.
  double outline_inside(const EvalCamera& camera, const CameraPose& pose, const std::vector<cv::Point2d>& outline,
                        double margin_px) const;

  EvalRig rig_;
  RayGrid left_grid_, right_grid_;
  std::vector<cv::Mat> photos_;
  std::vector<std::string> photo_names_;
  cv::RNG rng_;
  StereoImages previous_;
};

// Chessboard pairs (`cols` × `rows` inner corners of `square` metres) at 0.4–0.9 m, tilted up to 40°,
// placed over the whole image; every corner inside both images.
std::vector<StereoImages> chessboard_views(const EvalRig& rig, int count, int cols, int rows, double square,
                                           uint64_t seed);

}  // namespace vision_eval
