// A HIL flight scenario, loaded from YAML (sim/scenarios/*.yaml; the keys are documented in
// docs/simulator.md). Loading checks every key: an unknown key, a wrong type or a missing value is a
// ScenarioError that names the file, the line and the key.
#pragma once

#include <array>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "quad/sim/ground_camera_params.h"
#include "quad/sim/imu.h"
#include "quad/sim/log_download.h"
#include "quad/sim/magnetometer.h"
#include "quad/sim/motor.h"
#include "quad/sim/serial_line.h"

namespace quad::sim {

class ScenarioError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One ground-station command at a time; exactly one of the optionals is set.
struct GcsCommand {
  double at_s = 0.0;
  std::optional<bool> arm;                 // COMMAND_LONG 400
  std::optional<int> mode;                 // COMMAND_LONG 176, custom mode (quad/link/dialect.h)
  std::optional<Eigen::Vector3d> setpoint_ned_m;  // SET_POSITION_TARGET_LOCAL_NED
  double yaw_rad = 0.0;                    // with the setpoint
  bool land = false;                       // COMMAND_LONG 21
  bool param_list = false;                 // PARAM_REQUEST_LIST: the vehicle streams every parameter
  std::optional<LogDownloadRequest> log_download;  // the log protocol over the radio (log_download.h)
};

// RC sticks from at_s on (MANUAL_CONTROL units: -1000..1000, throttle 0..1000).
struct RcSticks {
  double at_s = 0.0;
  int roll = 0, pitch = 0, yaw = 0, throttle = 0;
};

struct Gust {
  double start_s = 0.0, end_s = 0.0;
  Eigen::Vector3d velocity_ned_m_s = Eigen::Vector3d::Zero();  // added to the mean wind
};

enum class FaultType {
  kVisionDropout,
  kRadioLoss,
  kBitErrorRate,
  kRadioLatency,
  kMagDisturbance,
  kGyroBiasStep,
  kMotorEfficiency,
  kRcLoss,
  kVisionLatency,   // the fix arrives later (value: extra latency, s)
  kVisionScale,     // a mis-calibrated camera (vector: scale of the fix per body FRD axis)
  kVisionDecoy,     // a second star-like shape taken for the star (vector: its NED position, m)
  kImuSaturation,   // HIL_SENSOR carries accelerometer and gyro readings pinned at full scale
  kImuNonFinite,    // HIL_SENSOR carries NaN and infinite accelerometer and gyro readings
};

struct Fault {
  FaultType type = FaultType::kVisionDropout;
  double start_s = 0.0, end_s = 0.0;
  double value = 0.0;                           // loss, bit error rate, latency_s or efficiency
  Eigen::Vector3d vector = Eigen::Vector3d::Zero();  // mag field offset (gauss, NED), gyro bias (rad/s),
                                                     // fix scale (FRD) or decoy position (NED, m)
  int motor = 0;
  bool active(double t) const { return t >= start_s && t < end_s; }
};

struct VisionParams {
  double rate_hz = 30.0;
  double latency_s = 0.022;  // capture to the radio (station processing); with the radio: ~40 ms in all
  double noise_m = 0.005;    // per axis, NED
  bool enabled = true;
  // No fix while the vehicle's centre is lower than this above the star (its floor, NED z = 0): the
  // rendered cameras close to the floor see only a patch of the star (LAND_VIS_HGT, docs/estimation.md).
  double min_height_m = 0.0;
  // When set (>= 0), the fix carries the star's attitude in body FRD (LANDING_TARGET q, as the station's
  // pose does) with this standard deviation per axis; otherwise q is 1 0 0 0 (no attitude).
  double attitude_sigma_deg = -1.0;
};

// A motion-capture feed (`external_pose:`; quad/sim/external_pose_feed.h): the truth plus noise as one of
// the field's external-pose messages, on the radio.
enum class ExternalPoseMessage { kAttPosMocap, kVisionPositionEstimate, kTargeted };
struct ExternalPoseParams {
  bool enabled = false;  // true when the scenario has the key
  ExternalPoseMessage message = ExternalPoseMessage::kAttPosMocap;
  double rate_hz = 50.0;
  double latency_s = 0.01;           // capture to the radio
  double noise_m = 0.001;            // per axis, NED
  double attitude_noise_deg = 0.1;   // per body axis
  int target_system = 1;             // EXTERNAL_POSE_TARGETED's
  // Added to the capture time in the stamp: 0, the simulator's clock (the vehicle's, in HIL); else the
  // mocap computer's own clock, which the firmware maps with EXT_POSE_DELAY.
  double clock_offset_s = 0.0;
};

// One camera's lens in OpenCV's pinhole model: focal lengths and principal point (px), distortion
// (k1, k2, p1, p2, k3) applied to normalised undistorted coordinates (quad/sim/camera_model.h).
struct LensParams {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;
};

// The rendered stereo cameras (`camera:`; quad/sim/stereo_camera.h, quad/sim/camera_model.h). The
// mounts come from the MJCF's cam_left / cam_right; lenses and image size from here. Defaults: the
// thesis' table 7.1 cameras (fx = s·f with the cell aspect s = 1.059 of eq. 7.26a, fy = f).
struct CameraParams {
  bool enabled = false;               // true: rendered cameras and the vision station replace the simulated fix
  int image_width = 728, image_height = 488;
  LensParams left{483.3276, 456.4, 331.4, 211.4, -0.5176, 0.3257, 0.0, 0.0, -0.1186};
  LensParams right{488.7285, 461.5, 341.6, 244.4, -0.4976, 0.2730, 0.0, 0.0, -0.0791};
  double star_tip_to_tip_m = 0.40;    // the marker: a four-pointed star ...
  double star_inner_ratio = 0.4;      // ... whose inner vertices lie at this fraction of the tip radius
  int distractors = 8;                // dark squares, discs and triangles scattered around the star
  double floor_grey = 205.0;          // albedo of the floor (0..255 at nominal exposure)
  std::string floor_texture;          // a photograph laid on the floor (empty: a plain floor)
  double floor_texture_m = 1.5;       // side of the photograph on the floor (tiled, mirrored)
  double floor_texture_contrast = 0.15;  // the photograph's grey sigma as a fraction of floor_grey
  double star_grey = 40.0;            // albedo of the star
  double noise_grey = 3.0;            // Gaussian sensor noise, grey levels (sigma)
  double exposure_variation = 0.10;   // frame-to-frame exposure wander (relative sigma of a slow random walk)
  double vignetting = 0.25;           // brightness lost at the image corners
  double exposure_s = 0.0;            // shutter time per field: motion blur (0: instantaneous)
  bool interlaced = false;            // even rows exposed 1/60 s before odd rows (analog video fields)
  int jpeg_quality = 0;               // JPEG-compress each image at this quality (0: uncompressed)
  double frame_loss = 0.0;            // fraction of captured pairs that never reach the station
  double calibration_focal_error = 0.0;  // the station's focal lengths are (1 + this) x the calibrated ones
  // The rig's mount error E (ZYX roll, pitch, yaw, rad; scenario key mount_error_deg in degrees): the
  // rendered rig is turned by E about the body origin (R_BC = E R_BC_model, t_BC = E t_BC_model) while
  // the station is told the model's mount. The firmware's EST_CAM_* equal to these angles undo it.
  Eigen::Vector3d mount_error_rad = Eigen::Vector3d::Zero();
};

// A vehicle's position fix in a multi-vehicle scenario (quad/sim/fix_source.h): the simulated onboard-star
// fix (vision_fix.h), the rendered onboard cameras with a vision station per vehicle, or the fixed
// ground cameras seeing every vehicle's colour markers (seed 003).
enum class FixSourceKind { kSynthetic, kOnboardStar, kGroundCameras };
const char* fix_source_name(FixSourceKind kind);

// One colour marker on the airframe (seed 003 sec. 3.2: red, green, blue and yellow balls at known
// places on the vehicle): its centre in body FRD and its radius.
struct Marker {
  std::string colour;  // red, green, blue or yellow
  Eigen::Vector3d position_frd_m = Eigen::Vector3d::Zero();
  double radius_m = 0.02;
};
// The default layout: three on the arms, one on a mast, not coplanar, so four markers fix the attitude
// without the sign ambiguity of a symmetric set (seed 003 sec. 2).
std::vector<Marker> default_marker_layout();

// One vehicle of a multi-vehicle scenario (`vehicles:`). Each runs its own firmware process on its own
// HIL link and radio; the scenario's other keys (links, sensors, motors, vision, metrics) are shared.
struct FleetVehicle {
  std::string name;
  int system_id = 1;  // the id the ground side gives this vehicle (docs/simulator.md, "Several vehicles")
  Eigen::Vector2d initial_north_east_m = Eigen::Vector2d::Zero();
  double initial_height_m = 0.0;
  double initial_yaw_rad = 0.0;
  FixSourceKind fix_source = FixSourceKind::kSynthetic;
  std::vector<Marker> markers = default_marker_layout();
  // The scenario's firmware parameters with this vehicle's own on top.
  std::vector<std::pair<std::string, double>> firmware_params;
  // The scenario's commands (setpoints offset by this vehicle's start) and its own, sorted by time.
  std::vector<GcsCommand> commands;
};

struct Scenario {
  std::string path;  // where it was loaded from
  std::string name;
  double duration_s = 0.0;
  uint64_t seed = 1;
  std::string model_path;
  Eigen::Vector2d initial_north_east_m = Eigen::Vector2d::Zero();
  double initial_height_m = 0.0;
  double initial_yaw_rad = 0.0;

  double control_rate_hz = 100.0;  // one HIL_SENSOR / HIL_ACTUATOR_CONTROLS exchange per period
  int uart0_baud = 921600;
  int radio_baud = 57600;
  RadioConditions radio{0.004, 0.002, 0.0, 0.0};
  bool gcs_over_radio = false;  // ground-station commands on UART2 instead of UART0
  double rc_rate_hz = 50.0;

  VisionParams vision;
  ExternalPoseParams external_pose;
  CameraParams camera;
  GroundCameraParams ground_cameras;  // fixed room cameras and the ground-camera station (`ground_cameras:`)
  // Extra keys for the vision station's settings file (name -> number or word), written beside the
  // camera mount the simulator puts there (quad/sim/station_loop.h).
  std::vector<std::pair<std::string, std::string>> station_settings;
  MotorParams motor;
  ImuParams imu;
  MagParams mag;
  Eigen::Vector3d field_ned_gauss{0.20, -0.02, 0.45};
  double drag_linear = 0.15, drag_quadratic = 0.06;

  Eigen::Vector3d wind_mean_ned_m_s = Eigen::Vector3d::Zero();
  std::vector<Gust> gusts;
  std::vector<GcsCommand> commands;  // sorted by time
  std::vector<RcSticks> rc;          // sorted by time
  std::vector<Fault> faults;

  // Firmware parameters for this run (NAME value), written to the run folder and passed as --params.
  std::vector<std::pair<std::string, double>> firmware_params;

  // Metrics window (the hold) and the settling band; further hold windows (metrics.holds: a second
  // flight's hover), reported apart in summary.json's "holds".
  double hold_start_s = 0.0, hold_end_s = 0.0;
  std::vector<std::pair<double, double>> extra_holds;
  double settle_band_m = 0.05;

  // Several vehicles in one world (empty: the single vehicle of the keys above, `initial` etc.).
  std::vector<FleetVehicle> vehicles;

  Eigen::Vector3d wind_at(double t) const;
};

// One scenario key replaced before the scenario is checked (quad_sim --set KEY=VALUE): `key` is a dotted
// path, list items by index (`radio.latency_s`, `firmware_params.POS_KP_XY`, `commands.3.at_s`), `value`
// a YAML value (`0.01`, `[1, 0, 0]`, `{at_s: 40, land: true}`). A missing map key is created.
struct ScenarioOverride {
  std::string key;
  std::string value;
};
// "KEY=VALUE" to an override; throws ScenarioError when there is no '=' or no key.
ScenarioOverride parse_override(const std::string& key_equals_value);

Scenario load_scenario(const std::string& path, const std::vector<ScenarioOverride>& overrides = {});
// Parses YAML text; `name` stands for the file in error messages and `base_dir` resolves relative paths.
Scenario parse_scenario(const std::string& yaml_text, const std::string& name, const std::string& base_dir,
                        const std::vector<ScenarioOverride>& overrides = {});

}  // namespace quad::sim
