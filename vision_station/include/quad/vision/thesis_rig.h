// The thesis' stereo rig (sec. 7.4, table 7.1, eq. 7.22, eq. 7.34) expressed in OpenCV's camera model.
//
// Mapping of the thesis' intrinsics onto OpenCV's pinhole model (documented in docs/vision_station.md):
//  - eq. 7.26a scales only the horizontal coordinate by the cell aspect s, so fx = s·f and fy = f.
//    Check: cv::stereoRectify (default alpha) of this rig gives the rectified focal length 458.9 px of
//    table 7.2 exactly (tests/vision/test_geometry.cpp).
//  - eq. 7.24/7.25 write the radial polynomial as "detected · D = ideal", but the κ values were produced
//    by OpenCV's calibrateCamera (sec. 7.4.1), whose model is the forward one: distorted = ideal · D(r_ideal)
//    in normalised coordinates. The κ are used as OpenCV's k1, k2, k3 with zero tangential terms.
//  - The thesis gives no stereo baseline; the project uses 0.114 m (cameras at ±0.057 m, matching the
//    lateral offset of eq. 7.22). The relative rotation comes from the rectifying rotations of eq. 7.34:
//    both rotate their camera into the common rectified frame, so R (left to right) = R_rᵀ R_l.
#pragma once

#include <opencv2/core.hpp>

namespace quad::vision {

// One camera's intrinsics in OpenCV form.
struct CameraIntrinsics {
  cv::Matx33d K;
  cv::Vec<double, 5> D;  // k1, k2, p1, p2, k3
};

// A calibrated stereo rig: x_right = R·x_left + T (metres), OpenCV camera axes.
struct StereoRig {
  cv::Size image_size;
  CameraIntrinsics left;
  CameraIntrinsics right;
  cv::Matx33d R;
  cv::Vec3d T;
};

// The camera mount on the vehicle: p_B = R_BC·p_C + t_BC (thesis eq. 7.22; t_BC is the left camera's
// position in the body frame, FRD).
struct CameraMount {
  cv::Matx33d R_BC;
  cv::Vec3d t_BC;
};

inline constexpr double kThesisBaseline = 0.114;  // metres (project choice, see above)

// Table 7.1 (left/right intrinsics), eq. 7.34 (relative rotation), 728 × 488 images.
StereoRig thesis_stereo_rig();

// Eq. 7.22: camera x (image right) along body y (right), camera y (image down) along body −x, camera z
// (optical axis, looking down) along body z.
CameraMount thesis_camera_mount();

}  // namespace quad::vision
