#include "quad/sim/scenario.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "quad/sim/flight_modes.h"

namespace quad::sim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// A YAML node with its dotted key path, so every error can name the key and the line.
class Field {
 public:
  Field(YAML::Node node, std::string key, const std::string* file) : node_(std::move(node)), key_(std::move(key)), file_(file) {}

  [[noreturn]] void fail(const std::string& what) const {
    std::ostringstream s;
    s << *file_;
    if (node_.IsDefined() && node_.Mark().line >= 0) s << ":" << node_.Mark().line + 1;
    s << ": '" << key_ << "' " << what;
    throw ScenarioError(s.str());
  }

  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }
  bool is_map() const { return node_.IsMap(); }
  const std::string& key() const { return key_; }

  // The name of a mapping key of this node; a key that is not a plain scalar (YAML allows lists and
  // mappings as keys) is refused here rather than escaping as a yaml-cpp conversion error.
  std::string key_name(const YAML::Node& key) const {
    if (!key.IsScalar()) Field(key, key_, file_).fail("has a key that is not a plain name");
    return key.Scalar();
  }

  // A mapping whose keys must all be in `allowed`.
  void expect_map(std::initializer_list<const char*> allowed) const {
    if (!node_.IsMap()) fail("must be a mapping");
    const std::set<std::string> ok(allowed.begin(), allowed.end());
    for (const auto& kv : node_) {
      const std::string k = key_name(kv.first);
      if (!ok.count(k)) {
        std::string list;
        for (const auto& a : ok) list += (list.empty() ? "" : ", ") + a;
        Field(kv.first, key_.empty() ? k : key_ + "." + k, file_).fail("is not a known key (expected one of: " + list + ")");
      }
    }
  }

  // The keys of a mapping, in file order.
  std::vector<std::string> keys() const {
    if (!node_.IsMap()) fail("must be a mapping");
    std::vector<std::string> out;
    for (const auto& kv : node_) out.push_back(key_name(kv.first));
    return out;
  }

  Field operator[](const char* k) const {
    return Field(node_[k], key_.empty() ? std::string(k) : key_ + "." + k, file_);
  }
  Field at(size_t i) const { return Field(node_[i], key_ + "[" + std::to_string(i) + "]", file_); }
  size_t size() const {
    if (!defined() || !node_.IsSequence()) fail("must be a list");
    return node_.size();
  }

  double number() const {
    if (!defined()) fail("is required");
    try {
      const double v = node_.as<double>();
      if (!std::isfinite(v)) fail("must be a finite number");
      return v;
    } catch (const YAML::Exception&) {
      fail("must be a number, not '" + scalar() + "'");
    }
  }
  double number(double lo, double hi) const {
    const double v = number();
    if (v < lo || v > hi) {
      std::ostringstream s;
      s << "must be in [" << lo << ", " << hi << "], not " << v;
      fail(s.str());
    }
    return v;
  }
  int integer(int lo, int hi) const {
    const double v = number(lo, hi);
    if (v != std::floor(v)) fail("must be a whole number");
    return static_cast<int>(v);
  }
  bool boolean() const {
    if (!defined()) fail("is required");
    try {
      return node_.as<bool>();
    } catch (const YAML::Exception&) {
      fail("must be true or false, not '" + scalar() + "'");
    }
  }
  std::string text() const {
    if (!defined()) fail("is required");
    if (!node_.IsScalar()) fail("must be a string");
    return node_.as<std::string>();
  }
  Eigen::Vector3d vec3() const {
    if (!defined()) fail("is required");
    if (!node_.IsSequence() || node_.size() != 3) fail("must be a list of three numbers");
    return {at(0).number(), at(1).number(), at(2).number()};
  }
  Eigen::Vector2d vec2() const {
    if (!defined()) fail("is required");
    if (!node_.IsSequence() || node_.size() != 2) fail("must be a list of two numbers");
    return {at(0).number(), at(1).number()};
  }

  // Optional setters: leave `out` alone when the key is absent.
  void get(double& out) const { if (defined()) out = number(); }
  void get(double& out, double lo, double hi) const { if (defined()) out = number(lo, hi); }
  void get(bool& out) const { if (defined()) out = boolean(); }
  void get(Eigen::Vector3d& out) const { if (defined()) out = vec3(); }

 private:
  std::string scalar() const { return node_.IsScalar() ? node_.Scalar() : std::string("<") + (node_.IsMap() ? "mapping" : "list") + ">"; }

  YAML::Node node_;
  std::string key_;
  const std::string* file_;
};

int parse_mode(const Field& f) {
  const std::string s = f.text();
  std::string upper = s;
  std::transform(upper.begin(), upper.end(), upper.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  std::string names;
  // The names and numbers are the firmware's own (quad/link/dialect.h).
  for (int m = 0; m < kFlightModeCount; ++m) {
    const std::string name = flight_mode_name(m);
    if (upper == name) return m;
    names += (names.empty() ? "" : ", ") + name;
  }
  f.fail("is not a flight mode (expected one of: " + names + ")");
}

void parse_axis(const Field& f, ImuAxisParams& a) {
  f.expect_map({"noise_density", "bias_random_walk", "turn_on_bias", "vibration_at_full_speed"});
  f["noise_density"].get(a.noise_density, 0.0, 1.0);
  f["bias_random_walk"].get(a.bias_random_walk, 0.0, 1.0);
  f["turn_on_bias"].get(a.turn_on_bias, 0.0, 10.0);
  f["vibration_at_full_speed"].get(a.vibration_at_full_speed, 0.0, 100.0);
}

std::string resolve(const std::string& base_dir, const std::string& p) {
  if (p.empty() || p[0] == '/') return p;
  return base_dir.empty() ? p : base_dir + "/" + p;
}

void parse_lens(const Field& f, LensParams& l) {
  f.expect_map({"fx", "fy", "cx", "cy", "distortion"});
  f["fx"].get(l.fx, 10.0, 1e5);
  f["fy"].get(l.fy, 10.0, 1e5);
  f["cx"].get(l.cx, -1e4, 1e4);
  f["cy"].get(l.cy, -1e4, 1e4);
  if (const Field d = f["distortion"]; d.defined()) {
    if (d.size() != 5) d.fail("must be a list of five numbers (k1, k2, p1, p2, k3)");
    double* k[] = {&l.k1, &l.k2, &l.p1, &l.p2, &l.k3};
    for (size_t i = 0; i < 5; ++i) *k[i] = d.at(i).number(-10.0, 10.0);
  }
}

void parse_camera(const Field& f, const std::string& base_dir, CameraParams& c) {
  f.expect_map({"enabled", "image_size", "left", "right", "star_tip_to_tip_m", "star_inner_ratio", "distractors",
                "floor_grey", "floor_texture", "floor_texture_m", "floor_texture_contrast", "star_grey", "noise_grey",
                "exposure_variation", "vignetting", "exposure_s", "interlaced", "jpeg_quality", "frame_loss",
                "calibration_focal_error", "mount_error_deg"});
  f["enabled"].get(c.enabled);
  if (const Field size = f["image_size"]; size.defined()) {
    if (size.size() != 2) size.fail("must be [width, height] in pixels");
    c.image_width = size.at(0).integer(16, 8192);
    c.image_height = size.at(1).integer(16, 8192);
  }
  if (f["left"].defined()) parse_lens(f["left"], c.left);
  if (f["right"].defined()) parse_lens(f["right"], c.right);
  f["star_tip_to_tip_m"].get(c.star_tip_to_tip_m, 0.05, 5.0);
  f["star_inner_ratio"].get(c.star_inner_ratio, 0.1, 0.9);
  if (f["distractors"].defined()) c.distractors = f["distractors"].integer(0, 50);
  f["floor_grey"].get(c.floor_grey, 1.0, 255.0);
  if (f["floor_texture"].defined()) c.floor_texture = resolve(base_dir, f["floor_texture"].text());
  f["floor_texture_m"].get(c.floor_texture_m, 0.05, 100.0);
  f["floor_texture_contrast"].get(c.floor_texture_contrast, 0.0, 1.0);
  f["star_grey"].get(c.star_grey, 0.0, 255.0);
  f["noise_grey"].get(c.noise_grey, 0.0, 40.0);
  f["exposure_variation"].get(c.exposure_variation, 0.0, 0.5);
  f["vignetting"].get(c.vignetting, 0.0, 0.9);
  f["exposure_s"].get(c.exposure_s, 0.0, 0.0165);  // within one field period
  f["interlaced"].get(c.interlaced);
  if (f["jpeg_quality"].defined()) c.jpeg_quality = f["jpeg_quality"].integer(0, 100);
  f["frame_loss"].get(c.frame_loss, 0.0, 1.0);
  f["calibration_focal_error"].get(c.calibration_focal_error, -0.5, 0.5);
  if (const Field e = f["mount_error_deg"]; e.defined()) {
    if (e.size() != 3) e.fail("must be [roll, pitch, yaw] in degrees");
    for (size_t i = 0; i < 3; ++i) c.mount_error_rad(static_cast<Eigen::Index>(i)) = e.at(i).number(-10.0, 10.0) * M_PI / 180.0;
    if (!c.enabled) e.fail("needs the rendered cameras (camera.enabled: true): the simulated fix has no rig");
  }
}

// The room cameras (quad/sim/ground_camera_params.h; docs/simulator.md "Ground cameras").
void parse_ground_cameras(const Field& f, GroundCameraParams& g) {
  f.expect_map({"enabled", "count", "image_size", "hfov_deg", "rate_hz", "height_m", "distance_m", "aim_height_m",
                "first_azimuth_deg", "spacing_deg", "centre_ne_m", "distortion", "trigger", "phase_s", "latency_s",
                "frame_loss", "marker_radius_m", "markers_frd_m", "light", "noise_grey", "message"});
  f["enabled"].get(g.enabled);
  if (f["count"].defined()) g.count = f["count"].integer(2, 8);
  if (const Field size = f["image_size"]; size.defined()) {
    if (size.size() != 2) size.fail("must be [width, height] in pixels");
    g.image_width = size.at(0).integer(64, 4096);
    g.image_height = size.at(1).integer(64, 4096);
  }
  f["hfov_deg"].get(g.hfov_deg, 10.0, 120.0);
  f["rate_hz"].get(g.rate_hz, 1.0, 240.0);
  f["height_m"].get(g.height_m, 0.1, 20.0);
  f["distance_m"].get(g.distance_m, 0.5, 50.0);
  f["aim_height_m"].get(g.aim_height_m, -5.0, 20.0);
  f["first_azimuth_deg"].get(g.first_azimuth_deg, -360.0, 360.0);
  f["spacing_deg"].get(g.spacing_deg, 10.0, 180.0);
  if (f["centre_ne_m"].defined()) g.centre_ne = f["centre_ne_m"].vec2();
  if (const Field d = f["distortion"]; d.defined()) {
    if (d.size() != 5) d.fail("must be a list of five numbers (k1, k2, p1, p2, k3)");
    for (size_t i = 0; i < 5; ++i) g.distortion[i] = d.at(i).number(-2.0, 2.0);
  }
  if (const Field t = f["trigger"]; t.defined()) {
    const std::string mode = t.text();
    if (mode != "together" && mode != "free") t.fail("must be together or free, not '" + mode + "'");
    g.triggered = mode == "together";
  }
  if (const Field ph = f["phase_s"]; ph.defined()) {
    g.phase_s.clear();
    for (size_t i = 0; i < ph.size(); ++i) g.phase_s.push_back(ph.at(i).number(0.0, 1.0 / g.rate_hz - 1e-6));
    if (g.triggered) ph.fail("needs trigger: free (triggered cameras capture together)");
    if (static_cast<int>(g.phase_s.size()) != g.count) ph.fail("must give one phase per camera (" + std::to_string(g.count) + ")");
  }
  f["latency_s"].get(g.latency_s, 0.0, 1.0);
  f["frame_loss"].get(g.frame_loss, 0.0, 1.0);
  f["marker_radius_m"].get(g.marker_radius_m, 0.003, 0.2);
  if (const Field m = f["markers_frd_m"]; m.defined()) {
    m.expect_map({"red", "green", "blue", "yellow"});
    const char* names[] = {"red", "green", "blue", "yellow"};
    for (size_t k = 0; k < 4; ++k)
      if (m[names[k]].defined()) g.markers_frd[k] = m[names[k]].vec3();
  }
  if (const Field l = f["light"]; l.defined()) {
    l.expect_map({"min", "max", "ramp", "white_balance"});
    l["min"].get(g.light_min, 0.05, 3.0);
    l["max"].get(g.light_max, 0.05, 3.0);
    l["ramp"].get(g.light_ramp, 0.0, 0.9);
    l["white_balance"].get(g.white_balance, 0.0, 0.5);
    if (g.light_max < g.light_min) l["max"].fail("must not be below light.min");
  }
  f["noise_grey"].get(g.noise_grey, 0.0, 40.0);
  if (const Field m = f["message"]; m.defined()) {
    const std::string word = m.text();
    if (word != ground_fix_message_name(GroundFixMessage::kVisionPositionEstimate))
      m.fail("must be vision_position_estimate (the external-position message the firmware accepts), not '" + word + "'");
    g.message = GroundFixMessage::kVisionPositionEstimate;
  }
}

void parse_radio(const Field& f, RadioConditions& r) {
  f["latency_s"].get(r.latency_s, 0.0, 10.0);
  f["jitter_s"].get(r.jitter_s, 0.0, 10.0);
  f["loss"].get(r.loss, 0.0, 1.0);
  f["bit_error_rate"].get(r.bit_error_rate, 0.0, 0.5);
}

Fault parse_fault(const Field& f, double duration) {
  static const std::pair<const char*, FaultType> kTypes[] = {
      {"vision_dropout", FaultType::kVisionDropout}, {"radio_loss", FaultType::kRadioLoss},
      {"bit_error_rate", FaultType::kBitErrorRate},  {"radio_latency", FaultType::kRadioLatency},
      {"mag_disturbance", FaultType::kMagDisturbance}, {"gyro_bias_step", FaultType::kGyroBiasStep},
      {"motor_efficiency", FaultType::kMotorEfficiency}, {"rc_loss", FaultType::kRcLoss},
      {"vision_latency", FaultType::kVisionLatency}, {"vision_scale", FaultType::kVisionScale},
      {"vision_decoy", FaultType::kVisionDecoy}, {"imu_saturation", FaultType::kImuSaturation},
      {"imu_non_finite", FaultType::kImuNonFinite},
  };
  f.expect_map({"type", "start_s", "end_s", "loss", "rate", "latency_s", "field_ned_gauss", "bias_rad_s", "motor",
                "efficiency", "scale_frd", "star_ned_m"});
  Fault fault;
  const std::string type = f["type"].text();
  std::string names;
  bool found = false;
  for (const auto& [name, t] : kTypes) {
    names += (names.empty() ? "" : ", ") + std::string(name);
    if (type == name) {
      fault.type = t;
      found = true;
    }
  }
  if (!found) f["type"].fail("is not a fault type (expected one of: " + names + ")");
  fault.start_s = f["start_s"].number(0.0, duration);
  fault.end_s = f["end_s"].defined() ? f["end_s"].number(fault.start_s, 1e9) : duration;
  auto required = [&](const char* k) {
    if (!f[k].defined()) f[k].fail("is required for a " + type + " fault");
    return f[k];
  };
  switch (fault.type) {
    case FaultType::kRadioLoss: fault.value = f["loss"].defined() ? f["loss"].number(0.0, 1.0) : 1.0; break;
    case FaultType::kBitErrorRate: fault.value = required("rate").number(0.0, 0.5); break;
    case FaultType::kRadioLatency:
    case FaultType::kVisionLatency: fault.value = required("latency_s").number(0.0, 10.0); break;
    case FaultType::kVisionScale: {
      const Field k = required("scale_frd");
      fault.vector = k.vec3();
      if ((fault.vector.array() <= 0.0).any()) k.fail("must be positive scale factors");
      break;
    }
    case FaultType::kVisionDecoy: fault.vector = required("star_ned_m").vec3(); break;
    case FaultType::kMagDisturbance: fault.vector = required("field_ned_gauss").vec3(); break;
    case FaultType::kGyroBiasStep: fault.vector = required("bias_rad_s").vec3(); break;
    case FaultType::kMotorEfficiency:
      fault.motor = required("motor").integer(0, 3);
      fault.value = required("efficiency").number(0.0, 1.0);
      break;
    case FaultType::kVisionDropout:
    case FaultType::kRcLoss:
    case FaultType::kImuSaturation:
    case FaultType::kImuNonFinite: break;
  }
  return fault;
}

// Replaces the node at o.key in `root` by o.value (parsed as YAML), creating missing map keys.
void apply_override(YAML::Node& root, const ScenarioOverride& o, const std::string& file) {
  const std::string where = file + ": --set " + o.key + "=" + o.value + ": ";
  YAML::Node value;
  try {
    value = YAML::Load(o.value);
  } catch (const YAML::ParserException& e) {
    throw ScenarioError(where + "the value is not YAML (" + e.msg + ")");
  }
  YAML::Node node = root;
  std::string path;
  std::istringstream parts(o.key);
  for (std::string part; std::getline(parts, part, '.');) {
    if (part.empty()) throw ScenarioError(where + "the key has an empty part");
    path += (path.empty() ? "" : ".") + part;
    YAML::Node next;
    if (node.IsSequence()) {
      const bool digits = std::all_of(part.begin(), part.end(), [](unsigned char c) { return std::isdigit(c); });
      if (!digits || std::stoul(part) >= node.size())
        throw ScenarioError(where + "'" + path + "': the list has " + std::to_string(node.size()) + " items");
      next.reset(node[std::stoul(part)]);
    } else if (node.IsMap() || !node.IsDefined() || node.IsNull()) {
      next.reset(node[part]);
    } else {
      throw ScenarioError(where + "'" + path + "' is inside a value that is neither a mapping nor a list");
    }
    node.reset(next);
  }
  node = value;  // assigns through the reference into the document
}

}  // namespace

const char* fix_source_name(FixSourceKind kind) {
  switch (kind) {
    case FixSourceKind::kSynthetic: return "synthetic";
    case FixSourceKind::kOnboardStar: return "onboard_star";
    case FixSourceKind::kGroundCameras: return "ground_cameras";
  }
  return "?";
}

std::vector<Marker> default_marker_layout() {
  // Body FRD, metres: red on the front arm, green on the right arm, blue on the back arm, yellow on a
  // mast above the hub; each 6 cm above the arm (FRD z up is negative), 2 cm balls.
  return {{"red", {0.20, 0.0, -0.06}, 0.02},
          {"green", {0.0, 0.20, -0.06}, 0.02},
          {"blue", {-0.20, 0.0, -0.06}, 0.02},
          {"yellow", {0.0, 0.0, -0.16}, 0.02}};
}

Eigen::Vector3d Scenario::wind_at(double t) const {
  Eigen::Vector3d w = wind_mean_ned_m_s;
  for (const Gust& g : gusts)
    if (t >= g.start_s && t < g.end_s) w += g.velocity_ned_m_s;
  return w;
}

ScenarioOverride parse_override(const std::string& key_equals_value) {
  const size_t eq = key_equals_value.find('=');
  if (eq == std::string::npos || eq == 0)
    throw ScenarioError("--set '" + key_equals_value + "': expected KEY=VALUE, e.g. radio.latency_s=0.01");
  return {key_equals_value.substr(0, eq), key_equals_value.substr(eq + 1)};
}

namespace {

void parse_wind(const Field& f, Scenario& s);

// The vehicle and its environment: the airframe's start, the links, sensors, motors, field, drag, wind.
void parse_vehicle(const Field& top, const std::string& base_dir, Scenario& s) {
  // The model: relative to the scenario file when given, else the shipped Quad-C.
  s.model_path = top["model"].defined() ? resolve(base_dir, top["model"].text()) : std::string(QUAD_SIM_SOURCE_DIR "/models/quad_c.xml");
  if (const Field f = top["initial"]; f.defined()) {
    f.expect_map({"north_east_m", "height_m", "yaw_deg"});
    if (f["north_east_m"].defined()) s.initial_north_east_m = f["north_east_m"].vec2();
    f["height_m"].get(s.initial_height_m, 0.0, 1000.0);
    if (f["yaw_deg"].defined()) s.initial_yaw_rad = f["yaw_deg"].number(-360.0, 360.0) * kDeg;
  }
  if (const Field f = top["motors"]; f.defined()) {
    f.expect_map({"tau_up_s", "tau_down_s", "thrust_curve", "idle_command", "max_thrust_n"});
    f["tau_up_s"].get(s.motor.tau_up_s, 1e-4, 10.0);
    f["tau_down_s"].get(s.motor.tau_down_s, 1e-4, 10.0);
    f["thrust_curve"].get(s.motor.thrust_curve, 0.0, 1.0);
    f["idle_command"].get(s.motor.idle_command, 0.0, 0.5);
    f["max_thrust_n"].get(s.motor.max_thrust_n, 0.1, 1000.0);
  }
  if (const Field f = top["imu"]; f.defined()) {
    f.expect_map({"dlpf_cutoff_hz", "gyro", "accel"});
    f["dlpf_cutoff_hz"].get(s.imu.dlpf_cutoff_hz, 0.0, 500.0);
    if (f["gyro"].defined()) parse_axis(f["gyro"], s.imu.gyro);
    if (f["accel"].defined()) parse_axis(f["accel"], s.imu.accel);
  }
  if (const Field f = top["magnetometer"]; f.defined()) {
    f.expect_map({"present", "noise_gauss", "scale", "misalignment_rad", "hard_iron_gauss"});
    f["present"].get(s.mag.present);
    f["noise_gauss"].get(s.mag.noise_gauss, 0.0, 1.0);
    f["scale"].get(s.mag.scale);
    f["misalignment_rad"].get(s.mag.misalignment_rad);
    f["hard_iron_gauss"].get(s.mag.hard_iron_gauss);
  }
  top["magnetic_field_ned_gauss"].get(s.field_ned_gauss);
  if (const Field f = top["drag"]; f.defined()) {
    f.expect_map({"linear_n_per_m_s", "quadratic_n_per_m2_s2"});
    f["linear_n_per_m_s"].get(s.drag_linear, 0.0, 100.0);
    f["quadratic_n_per_m2_s2"].get(s.drag_quadratic, 0.0, 100.0);
  }
  if (const Field f = top["wind"]; f.defined()) parse_wind(f, s);
}

void parse_wind(const Field& f, Scenario& s) {
  f.expect_map({"mean_ned_m_s", "gusts"});
  f["mean_ned_m_s"].get(s.wind_mean_ned_m_s);
  if (const Field g = f["gusts"]; g.defined()) {
    for (size_t i = 0; i < g.size(); ++i) {
      const Field e = g.at(i);
      e.expect_map({"start_s", "end_s", "velocity_ned_m_s"});
      Gust gust;
      gust.start_s = e["start_s"].number(0.0, s.duration_s);
      gust.end_s = e["end_s"].number(gust.start_s, 1e9);
      gust.velocity_ned_m_s = e["velocity_ned_m_s"].vec3();
      s.gusts.push_back(gust);
    }
  }
}

// The links: the HIL link, the radio and where the ground station sits on it, the RC frame rate.
void parse_links(const Field& top, Scenario& s) {
  if (const Field f = top["hil"]; f.defined()) {
    f.expect_map({"rate_hz", "uart0_baud"});
    f["rate_hz"].get(s.control_rate_hz, 10.0, 1000.0);
    if (f["uart0_baud"].defined()) s.uart0_baud = f["uart0_baud"].integer(9600, 921600);
  }
  if (const Field f = top["radio"]; f.defined()) {
    f.expect_map({"baud", "latency_s", "jitter_s", "loss", "bit_error_rate"});
    if (f["baud"].defined()) s.radio_baud = f["baud"].integer(9600, 921600);
    parse_radio(f, s.radio);
  }
  if (const Field f = top["gcs"]; f.defined()) {
    f.expect_map({"port"});
    const std::string port = f["port"].text();
    if (port != "uart0" && port != "radio") f["port"].fail("must be uart0 or radio");
    s.gcs_over_radio = port == "radio";
  }
  top["rc_rate_hz"].get(s.rc_rate_hz, 1.0, 500.0);
}

// The vision fix: simulated, or the rendered cameras with the station, and the station's settings.
void parse_vision(const Field& top, const std::string& base_dir, Scenario& s) {
  if (const Field f = top["vision"]; f.defined()) {
    f.expect_map({"enabled", "rate_hz", "latency_s", "noise_m", "min_height_m", "attitude_sigma_deg"});
    f["attitude_sigma_deg"].get(s.vision.attitude_sigma_deg, 0.0, 90.0);
    f["enabled"].get(s.vision.enabled);
    f["min_height_m"].get(s.vision.min_height_m, 0.0, 100.0);
    f["rate_hz"].get(s.vision.rate_hz, 0.1, 1000.0);
    f["latency_s"].get(s.vision.latency_s, 0.0, 10.0);
    f["noise_m"].get(s.vision.noise_m, 0.0, 10.0);
  }
  if (const Field f = top["external_pose"]; f.defined()) {
    f.expect_map({"message", "rate_hz", "latency_s", "noise_m", "attitude_noise_deg", "target_system", "clock_offset_s"});
    s.external_pose.enabled = true;
    if (f["message"].defined()) {
      const std::string m = f["message"].text();
      if (m == "att_pos_mocap") s.external_pose.message = ExternalPoseMessage::kAttPosMocap;
      else if (m == "vision_position_estimate") s.external_pose.message = ExternalPoseMessage::kVisionPositionEstimate;
      else if (m == "external_pose_targeted") s.external_pose.message = ExternalPoseMessage::kTargeted;
      else f["message"].fail("must be att_pos_mocap, vision_position_estimate or external_pose_targeted");
    }
    f["rate_hz"].get(s.external_pose.rate_hz, 0.1, 1000.0);
    f["latency_s"].get(s.external_pose.latency_s, 0.0, 10.0);
    f["noise_m"].get(s.external_pose.noise_m, 0.0, 10.0);
    f["attitude_noise_deg"].get(s.external_pose.attitude_noise_deg, 0.0, 90.0);
    if (f["target_system"].defined()) s.external_pose.target_system = f["target_system"].integer(1, 255);
    f["clock_offset_s"].get(s.external_pose.clock_offset_s, 0.0, 1e10);
  }
  if (const Field f = top["camera"]; f.defined()) parse_camera(f, base_dir, s.camera);
  if (const Field f = top["ground_cameras"]; f.defined()) {
    parse_ground_cameras(f, s.ground_cameras);
    if (s.ground_cameras.enabled && s.camera.enabled)
      f["enabled"].fail("and camera.enabled exclude each other: one station at a time sends the vehicle's fixes");
  }
  if (const Field f = top["station_settings"]; f.defined()) {
    for (const std::string& k : f.keys()) {
      const Field v = f[k.c_str()];
      const std::string value = v.text();
      const bool word = std::all_of(value.begin(), value.end(), [](unsigned char ch) { return std::isalnum(ch) || ch == '_'; });
      bool numeric = true;
      try {
        (void)v.number();
      } catch (const ScenarioError&) {
        numeric = false;
      }
      if (!numeric && !word) v.fail("must be a number or a single word");
      s.station_settings.emplace_back(k, value);
    }
  }
}

GcsCommand parse_command(const Field& e, double duration_s) {
  e.expect_map({"at_s", "arm", "mode", "setpoint_ned_m", "yaw_deg", "land", "param_list", "log_download"});
  GcsCommand c;
  c.at_s = e["at_s"].number(0.0, duration_s);
  int actions = 0;
  if (e["arm"].defined()) c.arm = e["arm"].boolean(), ++actions;
  if (e["mode"].defined()) c.mode = parse_mode(e["mode"]), ++actions;
  if (e["setpoint_ned_m"].defined()) c.setpoint_ned_m = e["setpoint_ned_m"].vec3(), ++actions;
  if (e["yaw_deg"].defined()) {
    if (!c.setpoint_ned_m) e["yaw_deg"].fail("goes with setpoint_ned_m");
    c.yaw_rad = e["yaw_deg"].number(-360.0, 360.0) * kDeg;
  }
  if (e["land"].defined()) {
    if (!e["land"].boolean()) e["land"].fail("can only be true");
    c.land = true, ++actions;
  }
  if (e["param_list"].defined()) {
    if (!e["param_list"].boolean()) e["param_list"].fail("can only be true");
    c.param_list = true, ++actions;
  }
  if (const Field d = e["log_download"]; d.defined()) {
    LogDownloadRequest r;
    if (d.is_map()) {
      d.expect_map({"id", "max_bytes"});
      if (d["id"].defined()) r.id = static_cast<uint16_t>(d["id"].integer(1, 65535));
      if (d["max_bytes"].defined()) r.max_bytes = static_cast<uint32_t>(d["max_bytes"].number(1.0, 4294967295.0));
    } else if (!d.boolean()) {
      d.fail("must be true or a mapping of id and max_bytes");
    }
    c.log_download = r, ++actions;
  }
  if (actions != 1) e.fail("must hold exactly one of arm, mode, setpoint_ned_m, land, param_list, log_download");
  return c;
}

RcSticks parse_rc(const Field& e, double duration_s) {
  e.expect_map({"at_s", "roll", "pitch", "yaw", "throttle"});
  RcSticks r;
  r.at_s = e["at_s"].number(0.0, duration_s);
  if (e["roll"].defined()) r.roll = e["roll"].integer(-1000, 1000);
  if (e["pitch"].defined()) r.pitch = e["pitch"].integer(-1000, 1000);
  if (e["yaw"].defined()) r.yaw = e["yaw"].integer(-1000, 1000);
  if (e["throttle"].defined()) r.throttle = e["throttle"].integer(0, 1000);
  return r;
}

// What happens in the flight: ground-station commands, RC sticks and faults, in time order; the
// firmware's parameters; the window the metrics cover.
void parse_flight(const YAML::Node& root, const Field& top, Scenario& s) {
  if (const Field f = top["commands"]; f.defined())
    for (size_t i = 0; i < f.size(); ++i) s.commands.push_back(parse_command(f.at(i), s.duration_s));
  if (const Field f = top["rc"]; f.defined())
    for (size_t i = 0; i < f.size(); ++i) s.rc.push_back(parse_rc(f.at(i), s.duration_s));
  if (const Field f = top["faults"]; f.defined())
    for (size_t i = 0; i < f.size(); ++i) s.faults.push_back(parse_fault(f.at(i), s.duration_s));
  if (const Field f = top["firmware_params"]; f.defined()) {
    if (!root["firmware_params"].IsMap()) f.fail("must be a mapping of parameter names to values");
    for (const auto& kv : root["firmware_params"]) {
      const std::string k = f.key_name(kv.first);
      s.firmware_params.emplace_back(k, f[k.c_str()].number());  // names are checked by the firmware
    }
  }
  if (const Field f = top["metrics"]; f.defined()) {
    f.expect_map({"hold_start_s", "hold_end_s", "settle_band_m", "holds"});
    s.hold_start_s = f["hold_start_s"].number(0.0, s.duration_s);
    s.hold_end_s = f["hold_end_s"].number(s.hold_start_s, s.duration_s);
    f["settle_band_m"].get(s.settle_band_m, 0.001, 10.0);
    if (const Field h = f["holds"]; h.defined()) {
      for (size_t i = 0; i < h.size(); ++i) {
        const Field w = h.at(i);
        w.expect_map({"start_s", "end_s"});
        const double start = w["start_s"].number(0.0, s.duration_s);
        s.extra_holds.emplace_back(start, w["end_s"].number(start, s.duration_s));
      }
    }
  }
  auto by_time = [](const auto& a, const auto& b) { return a.at_s < b.at_s; };
  std::stable_sort(s.commands.begin(), s.commands.end(), by_time);
  std::stable_sort(s.rc.begin(), s.rc.end(), by_time);
}

std::vector<Marker> parse_markers(const Field& f) {
  static const char* const kColours[] = {"red", "green", "blue", "yellow"};
  std::vector<Marker> out;
  for (size_t i = 0; i < f.size(); ++i) {
    const Field m = f.at(i);
    m.expect_map({"colour", "position_frd_m", "radius_m"});
    Marker marker;
    marker.colour = m["colour"].text();
    if (std::find_if(std::begin(kColours), std::end(kColours), [&](const char* c) { return marker.colour == c; }) ==
        std::end(kColours))
      m["colour"].fail("must be red, green, blue or yellow");
    marker.position_frd_m = m["position_frd_m"].vec3();
    if (marker.position_frd_m.norm() > 1.0) m["position_frd_m"].fail("must lie within 1 m of the centre of mass");
    m["radius_m"].get(marker.radius_m, 0.002, 0.2);
    out.push_back(marker);
  }
  return out;
}

FixSourceKind parse_fix_source(const Field& f) {
  const std::string name = f.text();
  for (FixSourceKind k : {FixSourceKind::kSynthetic, FixSourceKind::kOnboardStar, FixSourceKind::kGroundCameras})
    if (name == fix_source_name(k)) return k;
  f.fail("is not a fix source (expected one of: synthetic, onboard_star, ground_cameras)");
}

// The room cameras' station tracks one ball of each colour per vehicle, all of one size.
void check_ground_markers(const Field& v, const std::vector<Marker>& markers) {
  const Field where = v["markers"].defined() ? v["markers"] : v;
  for (const char* colour : {"red", "green", "blue", "yellow"}) {
    const auto n = std::count_if(markers.begin(), markers.end(), [&](const Marker& m) { return m.colour == colour; });
    if (n != 1)
      where.fail(std::string("must hold exactly one ") + colour + " marker for the ground cameras (seed 003: one ball of each colour)");
  }
  for (const Marker& m : markers)
    if (m.radius_m != markers.front().radius_m) where.fail("must give the four markers one radius for the ground cameras");
}

// One item of `vehicles:`; `shared` holds the scenario's commands and firmware parameters.
FleetVehicle parse_fleet_vehicle(const Field& v, const YAML::Node& node, const Scenario& shared, size_t index) {
  v.expect_map({"name", "system_id", "initial", "fix_source", "markers", "firmware_params", "commands"});
  FleetVehicle out;
  out.name = v["name"].defined() ? v["name"].text() : "v" + std::to_string(index + 1);
  const bool word = !out.name.empty() && std::all_of(out.name.begin(), out.name.end(), [](unsigned char c) {
    return std::isalnum(c) || c == '_' || c == '-';
  });
  if (!word) v["name"].fail("must be a word of letters, digits, '_' or '-' (it names the vehicle's run folder)");
  out.system_id = v["system_id"].defined() ? v["system_id"].integer(1, 254) : static_cast<int>(index) + 1;
  if (const Field f = v["initial"]; f.defined()) {
    f.expect_map({"north_east_m", "height_m", "yaw_deg"});
    if (f["north_east_m"].defined()) out.initial_north_east_m = f["north_east_m"].vec2();
    f["height_m"].get(out.initial_height_m, 0.0, 1000.0);
    if (f["yaw_deg"].defined()) out.initial_yaw_rad = f["yaw_deg"].number(-360.0, 360.0) * kDeg;
  }
  if (shared.ground_cameras.enabled) out.fix_source = FixSourceKind::kGroundCameras;  // the fleet's default
  if (v["fix_source"].defined()) out.fix_source = parse_fix_source(v["fix_source"]);
  if (v["markers"].defined()) out.markers = parse_markers(v["markers"]);
  if (shared.ground_cameras.enabled || out.fix_source == FixSourceKind::kGroundCameras) check_ground_markers(v, out.markers);
  out.firmware_params = shared.firmware_params;
  if (const Field f = v["firmware_params"]; f.defined()) {
    if (!node["firmware_params"].IsMap()) f.fail("must be a mapping of parameter names to values");
    for (const auto& kv : node["firmware_params"]) {
      const std::string k = f.key_name(kv.first);
      const double value = f[k.c_str()].number();
      auto same = std::find_if(out.firmware_params.begin(), out.firmware_params.end(), [&](const auto& p) { return p.first == k; });
      if (same != out.firmware_params.end()) same->second = value;
      else out.firmware_params.emplace_back(k, value);
    }
  }
  // The scenario's commands go to every vehicle, their setpoints relative to the vehicle's start.
  for (GcsCommand c : shared.commands) {
    if (c.setpoint_ned_m) c.setpoint_ned_m->head<2>() += out.initial_north_east_m;
    out.commands.push_back(c);
  }
  if (const Field f = v["commands"]; f.defined())
    for (size_t i = 0; i < f.size(); ++i) out.commands.push_back(parse_command(f.at(i), shared.duration_s));
  for (const GcsCommand& c : out.commands)
    if (c.log_download || c.param_list)
      v.fail("has a log_download or param_list command: a multi-vehicle run sends arm, mode, setpoint and land only");
  std::stable_sort(out.commands.begin(), out.commands.end(), [](const auto& a, const auto& b) { return a.at_s < b.at_s; });
  return out;
}

// `vehicles:` several vehicles in one world. The single-vehicle keys that a fleet does not share are
// refused here, so a scenario never silently loses one.
void parse_fleet(const YAML::Node& root, const Field& top, Scenario& s) {
  const Field list = top["vehicles"];
  if (list.size() < 1 || list.size() > 32) list.fail("must list 1 to 32 vehicles");
  for (const char* k : {"initial", "rc", "faults"})
    if (top[k].defined()) top[k].fail("is per vehicle in a scenario with vehicles: (not supported at the top)");
  if (s.camera.enabled) top["camera"]["enabled"].fail("is a fix source in a scenario with vehicles: (vehicles[i].fix_source)");
  if (top["ground_cameras"].defined() && top["ground_cameras"]["markers_frd_m"].defined())
    top["ground_cameras"]["markers_frd_m"].fail("is per vehicle in a scenario with vehicles: (vehicles[i].markers)");
  for (size_t i = 0; i < list.size(); ++i) {
    FleetVehicle v = parse_fleet_vehicle(list.at(i), root["vehicles"][i], s, i);
    for (const FleetVehicle& other : s.vehicles) {
      if (other.name == v.name) list.at(i)["name"].fail("repeats the name of another vehicle");
      if (other.system_id == v.system_id) list.at(i)["system_id"].fail("repeats the system id of another vehicle");
    }
    s.vehicles.push_back(std::move(v));
  }
}

Scenario scenario_from(const YAML::Node& root, const std::string& name, const std::string& base_dir) {
  Scenario s;
  s.path = name;
  const Field top(root, "", &name);
  top.expect_map({"name", "description", "duration_s", "seed", "model", "initial", "hil", "radio", "gcs", "rc_rate_hz",
                  "vision", "external_pose", "camera", "ground_cameras", "station_settings", "motors", "imu", "magnetometer", "magnetic_field_ned_gauss", "drag", "wind", "commands",
                  "rc", "faults", "metrics", "firmware_params", "vehicles"});
  s.name = top["name"].text();
  s.duration_s = top["duration_s"].number(0.01, 86400.0);
  if (top["seed"].defined()) s.seed = static_cast<uint64_t>(top["seed"].integer(0, 2147483647));
  parse_vehicle(top, base_dir, s);
  parse_links(top, s);
  parse_vision(top, base_dir, s);
  parse_flight(root, top, s);
  if (top["vehicles"].defined()) parse_fleet(root, top, s);
  return s;
}

}  // namespace

Scenario parse_scenario(const std::string& yaml_text, const std::string& name, const std::string& base_dir,
                        const std::vector<ScenarioOverride>& overrides) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw ScenarioError(name + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax: " + e.msg);
  }
  if (overrides.empty()) return scenario_from(root, name, base_dir);
  std::string keys;
  for (const ScenarioOverride& o : overrides) {
    apply_override(root, o, name);
    keys += (keys.empty() ? "" : ", ") + o.key;
  }
  try {
    return scenario_from(root, name, base_dir);
  } catch (const ScenarioError& e) {  // a line number may then be the --set value's own
    throw ScenarioError(std::string(e.what()) + " (with --set " + keys + ")");
  }
}

Scenario load_scenario(const std::string& path, const std::vector<ScenarioOverride>& overrides) {
  std::ifstream in(path);
  if (!in) throw ScenarioError(path + ": cannot open the scenario file");
  std::stringstream text;
  text << in.rdbuf();
  const size_t slash = path.find_last_of('/');
  return parse_scenario(text.str(), path, slash == std::string::npos ? std::string(".") : path.substr(0, slash),
                        overrides);
}

}  // namespace quad::sim
