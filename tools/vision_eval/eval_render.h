// One camera view of the floor plane: a real photograph as the floor texture (or a plain floor), the
// outlines' coverage on top, lighting that varies over the floor (gradient, spot, a soft-edged shadow),
// lens vignetting; rendered supersampled and box-averaged to the sensor's pixels.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "eval_camera.h"
#include "eval_shapes.h"

namespace vision_eval {

struct FloorLook {
  cv::Mat texture;               // CV_32F in [0, 1] (a grey photograph, stretched); empty: plain floor
  cv::Matx23d plane_to_texture;  // metres → texture pixels (scale, rotation, offset); mirrored tiling
  double contrast = 0.0;         // floor albedo = 1 − contrast·(1 − texture)
  double shape_albedo = 0.15;    // albedo of everything drawn in the coverage canvas
  double background_albedo = 1.0;  // where the plane is not hit (never for the floor scenes)
};

struct Lighting {
  double level = 200.0;               // grey level of albedo 1 under unit light
  cv::Vec2d gradient{0.0, 0.0};       // relative change per metre over the plane
  cv::Point2d spot_centre;            // a lamp's bright spot: + spot_gain·exp(−d²/2σ²)
  double spot_gain = 0.0, spot_sigma = 1.0;
  bool shadow = false;                // a soft-edged shadow over the half-plane n·p > offset
  cv::Vec2d shadow_normal{1.0, 0.0};
  double shadow_offset = 0.0, shadow_softness = 0.02, shadow_depth = 0.4;
  double vignetting = 0.0;            // image-space fall-off 1 − v·r² (r = 1 at the image corner)
};

// The view in grey levels (CV_32F, sensor resolution).
// Each canvas is looked up only inside the image region where the plane hits fall on it.
cv::Mat render_view(const RayGrid& grid, int factor, const CameraPose& pose, const FloorLook& floor,
                    const std::vector<CoverageCanvas>& canvases, const Lighting& light);

}  // namespace vision_eval
