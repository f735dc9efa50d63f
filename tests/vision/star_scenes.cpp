#include "star_scenes.h"

namespace quad::vision::testing {

std::optional<StarScene> random_star_scene(const StereoRig& rig, cv::RNG& rng, const StarSceneRanges& ranges,
                                           RenderOptions options, const std::vector<FloorShape>& extra_shapes,
                                           int attempts) {
  const std::vector<cv::Point2d> star = star_vertices(ranges.star);
  for (int attempt = 0; attempt < attempts; ++attempt) {
    StarScene scene;
    scene.height = rng.uniform(ranges.min_height, ranges.max_height);
    scene.tilt = rng.uniform(0.0, ranges.max_tilt);
    const double azimuth = rng.uniform(0.0, 2.0 * CV_PI);
    const double yaw = rng.uniform(0.0, CV_PI / 2.0);
    // The star centre on a random ray of the left camera's central field.
    const cv::Point2d ray(rng.uniform(-0.55, 0.55), rng.uniform(-0.4, 0.55));
    scene.left_pose = camera_pose(scene.height, scene.tilt, azimuth, yaw, ray, cv::Point2d(0, 0));
    const Pose right = right_pose(rig, scene.left_pose);
    if (!fully_visible(rig.left, rig.image_size, scene.left_pose, star, ranges.margin_px) ||
        !fully_visible(rig.right, rig.image_size, right, star, ranges.margin_px)) {
      continue;
    }
    std::vector<FloorShape> shapes = extra_shapes;
    shapes.push_back(FloorShape{star, rng.uniform(20.0, 80.0)});
    options.floor_grey = rng.uniform(150.0, 235.0);
    options.gradient = rng.uniform(0.0, ranges.max_gradient);
    options.gradient_angle = rng.uniform(0.0, 2.0 * CV_PI);
    std::optional<cv::Mat> left = render_view(rig.left, rig.image_size, scene.left_pose, shapes, options, rng);
    std::optional<cv::Mat> right_image = render_view(rig.right, rig.image_size, right, shapes, options, rng);
    if (!left || !right_image) continue;
    scene.left = *left;
    scene.right = *right_image;
    scene.truth_left = scene.left_pose.t;  // the floor origin is the star centre
    return scene;
  }
  return std::nullopt;
}

}  // namespace quad::vision::testing
