// The scenario's fixed room cameras (`ground_cameras:`; docs/simulator.md "Ground cameras"): where they
// stand, their lenses, trigger, light and noise, the vehicles' colour markers and the station's latency.
// Defaults: seed 003 table 6.1 (two cameras, 1024 × 768, 56.1° horizontal field of view, 30 Hz, 1.40 m
// high, 2.20 m from the flight area, triggered together).
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace quad::sim {

// What the station sends the vehicle for each fix. VISION_POSITION_ESTIMATE (position, capture time) is
// what the firmware accepts; the switch is where ATT_POS_MOCAP (full pose) goes when the firmware takes it.
enum class GroundFixMessage { kVisionPositionEstimate };
const char* ground_fix_message_name(GroundFixMessage message);  // the station's --message word

struct GroundCameraParams {
  bool enabled = false;               // true: the room cameras and `vision_station track` give the fixes
  int count = 2;
  int image_width = 1024, image_height = 768;
  double hfov_deg = 56.1;
  double rate_hz = 30.0;
  double height_m = 1.40;             // above the floor
  double distance_m = 2.20;           // horizontal distance from the flight area's centre
  double aim_height_m = 0.80;         // the optical axes pass over the centre at this height
  double first_azimuth_deg = 180.0;   // camera 0's bearing from the centre (180: south of it, looking north)
  double spacing_deg = 90.0;          // camera k stands at first_azimuth + k · spacing
  Eigen::Vector2d centre_ne = Eigen::Vector2d::Zero();
  std::array<double, 5> distortion{-0.08, 0.05, 0.0, 0.0, 0.0};  // k1, k2, p1, p2, k3 (mild barrel)
  // Trigger: together (one capture time for all cameras) or free-running, camera k capturing at
  // phase_s[k] + n / rate_hz (an absent trigger line); each frame carries its own capture time.
  bool triggered = true;
  std::vector<double> phase_s;        // free-running: per camera; missing entries: k / (count · rate_hz)
  double latency_s = 0.030;           // capture of a frame set to the station's fixes entering the radio
  double frame_loss = 0.0;            // fraction of frame sets that never reach the station
  // The markers: balls of this radius at body FRD positions, red, green, blue, yellow.
  double marker_radius_m = 0.02;
  std::array<Eigen::Vector3d, 4> markers_frd{Eigen::Vector3d(0.20, 0.0, -0.05), Eigen::Vector3d(0.0, 0.20, -0.05),
                                             Eigen::Vector3d(-0.20, 0.0, -0.05), Eigen::Vector3d(0.0, -0.20, -0.10)};
  // Light and sensor: illumination gain wandering between light_min and light_max (a slow random walk),
  // brightness falling by light_ramp across each image, a colour cast of up to ±white_balance per camera
  // and channel, Gaussian noise of noise_grey levels per channel.
  double light_min = 0.65, light_max = 1.15;
  double light_ramp = 0.20;
  double white_balance = 0.05;
  double noise_grey = 2.0;
  GroundFixMessage message = GroundFixMessage::kVisionPositionEstimate;
};

}  // namespace quad::sim
