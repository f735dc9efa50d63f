// Several vehicles wearing the same four colour markers, tracked from fixed room cameras (seed 003
// sec. 3.2, 3.3 and fig. 3.6): per camera, colour-marker detection in regions of interest around the
// tracks (the full image when a track is lost), nearest-neighbour association of detections to
// per-camera Kalman tracks gated on the Mahalanobis distance, the epipolar constraint where two
// same-colour markers fall into one gate, linear triangulation of each vehicle's markers and the rigid fit
// of its marker layout: the vehicle's position and attitude with their covariances.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/ground/colour_markers.h"
#include "quad/vision/ground/image_track.h"
#include "quad/vision/ground/marker_geometry.h"
#include "quad/vision/ground/room_camera.h"

namespace quad::vision::ground {

struct VehicleStart {
  int id = 0;
  cv::Vec3d ned;        // body origin, metres
  double yaw_rad = 0.0;
  std::array<cv::Vec3d, kMarkerColours> marker_frd;  // this vehicle's layout (body FRD, metres)
};

// The vehicles, each with its marker layout (body FRD, metres, one marker per colour); marker_frd is
// the file's common layout, the one a vehicle without its own wears.
struct TrackerConfig {
  std::array<cv::Vec3d, kMarkerColours> marker_frd;
  std::vector<VehicleStart> vehicles;
};

// OpenCV YAML: marker_red, marker_green, marker_blue, marker_yellow ([x, y, z] FRD) and vehicles, a
// list of {id, ned: [n, e, d], yaw_deg}, each optionally with its own marker_red ... marker_yellow.
// Errors name the file and key.
TrackerConfig load_tracker_config(const std::string& path);

struct GroundTrackerSettings {
  ColourThresholds colours;
  ImageTrackNoise noise;
  double gate_chi2 = 9.21;            // seed 003 sec. 6.2: 99 % of a 2-D Gaussian
  bool use_epipolar = true;           // false: nearest neighbour alone (seed 003 fig. 6.6)
  double epipolar_sigma_px = 2.0;     // distance of a true match from its epipolar line (calibration error)
  double pixel_sigma_px = 0.5;        // centroid noise propagated into the triangulation covariance
  double max_reprojection_px = 4.0;   // a marker whose views disagree more is dropped (wrong match)
  bool use_roi = true;                // seed 003 sec. 3.2: search around the tracks while all are held
  int roi_min_half_px = 32;
  int reseed_after_missed = 2;        // a track lost this long restarts from the vehicle's last pose
  double pose_check_px = 3.0;         // a detection not this much nearer its marker than another vehicle's is disowned
};

struct AssociationStats {
  int detections = 0;
  int assigned = 0;
  int ambiguous_gates = 0;         // gate groups with two tracks or two detections of one colour
  int epipolar_resolutions = 0;    // of those, settled with the epipolar constraint
  int nn_disagreements = 0;        // ... where nearest neighbour alone would have chosen differently
  int roi_searches = 0;            // camera images searched in regions of interest
  int full_searches = 0;           // ... and in full
  void add(const AssociationStats& o);
};

struct VehicleFix {
  int id = 0;
  int64_t time_us = 0;
  std::optional<RigidPose> pose;
  int markers = 0;  // triangulated markers used by the pose
  // Associated detection per colour and camera (distorted pixels), for inspection and evaluation.
  std::array<std::vector<std::optional<cv::Point2d>>, kMarkerColours> pixels;
  int ambiguous_gates = 0;
  int epipolar_resolutions = 0;
  int disowned = 0;  // detections dropped as another vehicle's or unconfirmed (track restarted)
};

struct FrameSetResult {
  std::vector<VehicleFix> vehicles;
  AssociationStats stats;
  double processing_ms = 0.0;  // wall clock of process()
  double cpu_ms = 0.0;         // CPU time of the calling thread in process() (machine load excluded)
};

class GroundTracker {
 public:
  GroundTracker(RoomRig rig, TrackerConfig config, GroundTrackerSettings settings = {});
  // One frame set: images[i] from camera i, all taken at time_us (triggered together).
  FrameSetResult process(const std::vector<cv::Mat>& images, int64_t time_us);
  const AssociationStats& totals() const { return totals_; }

 private:
  struct Gate;  // one camera's, one colour's group of tracks and detections that share gates
  std::vector<MarkerBlob> search(int camera, const cv::Mat& image, AssociationStats& stats);
  void predict_tracks(double dt);
  void associate(const std::vector<std::vector<MarkerBlob>>& blobs, FrameSetResult& result);
  void resolve(const Gate& gate, const std::vector<std::vector<MarkerBlob>>& blobs, FrameSetResult& result);
  void estimate_poses(const std::vector<std::vector<MarkerBlob>>& blobs, int64_t time_us, FrameSetResult& result);
  std::optional<RigidPose> fit_pose(size_t vehicle, VehicleFix& fix, bool trusted_only) const;
  void remember_pose(size_t vehicle, const RigidPose& pose, int64_t time_us);
  RigidPose pose_moved_on(size_t vehicle, int64_t time_us) const;
  // Every vehicle's poses its neighbours' detections are checked against (docs/vision_station.md,
  // "Checked against the poses").
  struct NeighbourPoses {
    const std::vector<std::optional<RigidPose>>& this_set;  // fitted in this frame set
    const std::vector<std::optional<RigidPose>>& moved_on;  // the last pose carried on to this frame set
  };
  void disown_stray_detections(size_t vehicle, const RigidPose& pose, const NeighbourPoses& neighbours,
                               const std::vector<std::vector<MarkerBlob>>& blobs, VehicleFix& fix);

  RoomRig rig_;
  TrackerConfig config_;
  GroundTrackerSettings settings_;
  std::vector<cv::Matx34d> projection_;
  std::vector<std::vector<cv::Matx33d>> fundamental_;  // [from][to]
  // tracks_[camera][vehicle][colour] and the detection each got this frame (index into the blobs, or -1)
  std::vector<std::vector<std::array<ImageTrack, kMarkerColours>>> tracks_;
  std::vector<std::vector<std::array<int, kMarkerColours>>> assigned_;
  std::vector<std::vector<std::array<bool, kMarkerColours>>> shared_;  // [camera][vehicle][colour]: from a shared gate or re-acquired
  std::vector<std::optional<RigidPose>> last_pose_;
  std::vector<int64_t> last_pose_time_us_;
  std::vector<cv::Vec3d> last_velocity_ned_;  // between the last two poses, zero when they lie far apart in time
  std::optional<int64_t> last_time_us_;
  AssociationStats totals_;
};

}  // namespace quad::vision::ground
