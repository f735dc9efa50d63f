// Random stereo scenes of the star on the floor (heights, tilts, exposure, lighting drawn at random),
// rendered through the thesis rig; the truth is the star centre in the left camera frame.
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/ideal_star.h"
#include "scene_renderer.h"

namespace quad::vision::testing {

struct StarSceneRanges {
  double min_height = 0.5, max_height = 2.6;  // metres, camera above the floor plane
  double max_tilt = 20.0 * CV_PI / 180.0;
  StarShape star;
  double margin_px = 4.0;                    // the whole star this far inside both images
  double max_gradient = 0.35;                // uneven lighting
};

// The default ranges with the camera's height between min_height and max_height.
inline StarSceneRanges heights_between(double min_height, double max_height) {
  StarSceneRanges ranges;
  ranges.min_height = min_height;
  ranges.max_height = max_height;
  return ranges;
}

struct StarScene {
  cv::Mat left, right;
  cv::Vec3d truth_left;  // star centre, left camera frame, metres
  double height = 0.0;
  double tilt = 0.0;
  Pose left_pose;
};

// Draws poses until the whole star is inside both views (at most `attempts` tries), then renders.
// `extra_shapes` are added to the floor (distractors), `options` supplies noise and shadows; exposure
// and lighting gradient are drawn at random on top of it.
std::optional<StarScene> random_star_scene(const StereoRig& rig, cv::RNG& rng, const StarSceneRanges& ranges,
                                           RenderOptions options = {},
                                           const std::vector<FloorShape>& extra_shapes = {}, int attempts = 200);

}  // namespace quad::vision::testing
