// estimation_replay: replays a CSV sensor log through the flight core's estimators (see README.md).
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>
#include <string>

#include "firmware_replay.h"
#include "replay.h"
#include "truth.h"
#include "ulog_input.h"

namespace {

using quad::replay::AttitudeFilter;
using quad::replay::ReplayOptions;

const char* kUsage = R"(usage: estimation_replay [options] LOG.csv|LOG.ulg   (LOG "-" reads CSV from standard input)

Input: CSV with a header row; columns t gx gy gz ax ay az mx my mz, optionally vis_t vis_x vis_y vis_z.
Or the firmware's flight log (ULog): sensor_combined, sensor_mag, vision_fix and its parameters.
Output: CSV t,qw,qx,qy,qz,roll,pitch,yaw,bgx,bgy,bgz,px,py,pz,vx,vy,vz.

  -o FILE                 write the estimates to FILE (default: standard output)
  --filter NAME           conditioned (default, thesis eq. 4.9), unconditioned (eq. 4.4), mahony, linear;
                          ekf: seed 004's error-state EKF (attitude and position, fixes as the star seen
                          from the body); firmware (ULog only): the firmware's StateEstimator with the
                          logged parameters
  --star N,E,D            the star's NED position for --filter ekf (default: a ULog's VIS_STAR_N/E/D, else 0)
  --truth FILE            print the error figures against a simulated flight's truth (the run folder's
                          log.csv: t, true_n, true_e, true_d, true_roll, true_pitch, true_yaw)
  --from S --to S         the time window of the error figures (default: the whole log)
  --calibrate S           the boot calibration (thesis eq. 7.2, 7.4) over the log's first S seconds (the
                          vehicle still and level): its gyro and accelerometer biases off every sample,
                          as the firmware takes them off (a ULog's samples are the raw ones)
  --compare               (with --truth) every filter over the same log, one line of figures each:
                          conditioned + Kalman (the thesis pair), unconditioned, mahony, linear, ekf
  --check-attitude TOL    (with --filter firmware) exit 1 unless every replayed attitude is within TOL of
                          the logged vehicle_attitude.q (per component)
  --propagator NAME       second-order (default) or exact (thesis eq. 4.14)
  --k1 --k2 --k3 --k4 --kb --delta X   conditioned observer gains (thesis table 8.1 by default)
  --ki X                  integral gain of the unconditioned observer
  --kp X, --mahony-ki X   Mahony gains (1, 0.03)
  --tau X                 linear complementary filter time constant, s (1)
  --accel-tolerance X     use the accelerometer only while | |a|/g - 1 | < X (0.2)
  --mag-ref N,E,D         Earth field in NED in the magnetometer's units (default: learned from the
                          first sample, heading relative to magnetic north)
  --noise-model NAME      thesis (default, eq. 8.12) or white (white acceleration)
  --q-pos X --q-vel X     thesis process noise spectral densities (1, 1: table 8.1)
  --q-accel X             white-acceleration spectral density (1)
  --fix-sigma-xy X --fix-sigma-z X   vision fix standard deviations, m (0.05)
  --gate X                innovation gate in standard deviations (5)
  --z-bias                estimate an accelerometer bias along NED z
  --fuse-on-arrival       stamp each fix with its row time instead of vis_t (for comparison)
  -h, --help              this text
)";

[[noreturn]] void usage_error(const std::string& what) {
  std::cerr << "estimation_replay: " << what << "\n(run with --help for the options)\n";
  std::exit(2);
}

float number(const std::string& option, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v)) usage_error(option + ": not a number: '" + text + "'");
  return static_cast<float>(v);
}

quad::Vec3 triple(const std::string& option, const std::string& text) {
  std::stringstream ss(text);
  std::string a, b, c, extra;
  if (!std::getline(ss, a, ',') || !std::getline(ss, b, ',') || !std::getline(ss, c, ',') || std::getline(ss, extra)) {
    usage_error(option + ": expected three comma-separated numbers, got '" + text + "'");
  }
  return {number(option, a), number(option, b), number(option, c)};
}

// The firmware's estimator over a flight log; with tolerance >= 0, exit status 1 unless it reproduces
// the logged attitude.
int replay_firmware(const quad::ulog::File& log, double tolerance, std::ostream& out) {
  const auto s = quad::replay::replay_firmware(log, tolerance < 0.0 ? 0.0 : tolerance, out);
  out.flush();
  if (!out) {
    std::cerr << "estimation_replay: write error\n";
    return 1;
  }
  std::cerr << "estimation_replay: firmware estimator, " << s.iterations << " iterations, " << s.fixes
            << " vision fixes; " << s.compared << " logged attitudes compared, largest difference "
            << s.max_q_difference << "\n";
  if (!s.hovering_logged) {
    std::cerr << "estimation_replay: warning: sensor_combined has no 'hovering' field: the in-flight "
                 "accelerometer bias (EST_ABIAS_TAU) is replayed as never learning\n";
  }
  if (!s.calibrated) {
    std::cerr << "estimation_replay: the boot calibration did not finish over the log's samples (a log that "
                 "starts at arming lacks them: log from boot)\n";
  }
  if (tolerance < 0.0) return 0;
  if (s.compared == 0) {
    std::cerr << "estimation_replay: no logged vehicle_attitude shares a timestamp with a sensor_combined "
                 "record: nothing to check (the IMU logged below the loop rate?)\n";
    return 1;
  }
  if (!(s.max_q_difference <= tolerance)) {
    std::cerr << "estimation_replay: the replayed attitude differs from the logged one by " << s.max_q_difference
              << " > " << tolerance << ", first at t = " << s.first_difference_t << " s\n";
    return 1;
  }
  return 0;
}

// The stationary calibration over the rows of the first `seconds`, taken off every row; false (said) when
// the window is refused.
bool calibrate(std::vector<quad::replay::LogRow>& rows, double seconds) {
  quad::est::StationaryCalibrator cal;
  for (const auto& r : rows) {
    if (r.t > rows.front().t + seconds) break;
    cal.add(quad::Vec3{static_cast<float>(r.gyro[0]), static_cast<float>(r.gyro[1]), static_cast<float>(r.gyro[2])},
            quad::Vec3{static_cast<float>(r.accel[0]), static_cast<float>(r.accel[1]), static_cast<float>(r.accel[2])});
  }
  quad::est::ImuBias bias;
  const quad::est::CalibrationStatus status = cal.result(bias);
  if (status != quad::est::CalibrationStatus::kOk) {
    std::cerr << "estimation_replay: --calibrate: the first " << seconds << " s are refused as a calibration window ("
              << static_cast<int>(status) << ": too few samples, moved, turning or not level; calibration.h)\n";
    return false;
  }
  for (auto& r : rows) {
    for (int i = 0; i < 3; ++i) {
      r.gyro[i] -= bias.gyro[i];
      r.accel[i] -= bias.accel[i];
    }
  }
  std::cerr << "estimation_replay: calibrated over " << seconds << " s: gyro bias " << bias.gyro.x << " "
            << bias.gyro.y << " " << bias.gyro.z << " rad/s, accelerometer bias " << bias.accel.x << " "
            << bias.accel.y << " " << bias.accel.z << " m/s^2\n";
  return true;
}

void print_figures(const std::string& name, const quad::replay::ErrorFigures& f) {
  char line[256];
  std::snprintf(line, sizeof line,
                "%-13s tilt RMS %.3f deg, yaw RMS %.3f deg (%d rows); horizontal RMS %.1f mm, vertical RMS %.1f mm "
                "(%d rows)\n",
                name.c_str(), f.tilt_rms_deg, f.yaw_rms_deg, f.attitude_rows, 1e3 * f.horizontal_rms_m,
                1e3 * f.vertical_rms_m, f.position_rows);
  std::cerr << line;
}

}  // namespace

int main(int argc, char** argv) {
  ReplayOptions o;
  std::string input, output;
  bool mag_ref_given = false;
  quad::Vec3 mag_ref;
  bool firmware = false;
  double check_tolerance = -1.0;
  bool star_given = false, compare = false;
  std::string truth_path;
  double from = -1e300, to = 1e300;
  double calibrate_s = 0.0;

  using Setter = std::function<void(const std::string&, const std::string&)>;
  const std::map<std::string, Setter> with_value = {
      {"-o", [&](auto&, auto& v) { output = v; }},
      {"--check-attitude", [&](auto& k, auto& v) { check_tolerance = number(k, v); }},
      {"--filter",
       [&](auto& k, auto& v) {
         firmware = v == "firmware";
         if (firmware) return;
         static const std::map<std::string, AttitudeFilter> names = {{"conditioned", AttitudeFilter::kConditioned},
                                                                     {"unconditioned", AttitudeFilter::kUnconditioned},
                                                                     {"mahony", AttitudeFilter::kMahony},
                                                                     {"linear", AttitudeFilter::kLinear},
                                                                     {"ekf", AttitudeFilter::kEkf}};
         const auto it = names.find(v);
         if (it == names.end()) usage_error(k + ": unknown filter '" + v + "'");
         o.filter = it->second;
       }},
      {"--propagator",
       [&](auto& k, auto& v) {
         if (v == "exact") o.observer.propagator = quad::est::Propagator::kExact;
         else if (v == "second-order") o.observer.propagator = quad::est::Propagator::kSecondOrder;
         else usage_error(k + ": unknown propagator '" + v + "'");
       }},
      {"--k1", [&](auto& k, auto& v) { o.observer.k1 = number(k, v); }},
      {"--k2", [&](auto& k, auto& v) { o.observer.k2 = number(k, v); }},
      {"--k3", [&](auto& k, auto& v) { o.observer.k3 = number(k, v); }},
      {"--k4", [&](auto& k, auto& v) { o.observer.k4 = number(k, v); }},
      {"--kb", [&](auto& k, auto& v) { o.observer.kb = number(k, v); }},
      {"--delta", [&](auto& k, auto& v) { o.observer.delta = number(k, v); }},
      {"--ki", [&](auto& k, auto& v) { o.observer.k_i = number(k, v); }},
      {"--kp", [&](auto& k, auto& v) { o.mahony.kp = number(k, v); }},
      {"--mahony-ki", [&](auto& k, auto& v) { o.mahony.ki = number(k, v); }},
      {"--tau", [&](auto& k, auto& v) { o.linear.tau = number(k, v); }},
      {"--accel-tolerance",
       [&](auto& k, auto& v) {
         const float x = number(k, v);
         o.observer.accel_norm_tolerance = o.mahony.accel_norm_tolerance = o.linear.accel_norm_tolerance = x;
       }},
      {"--mag-ref",
       [&](auto& k, auto& v) {
         mag_ref = triple(k, v);
         mag_ref_given = true;
       }},
      {"--noise-model",
       [&](auto& k, auto& v) {
         if (v == "thesis") o.position.process_noise = quad::est::ProcessNoise::kThesisDiagonal;
         else if (v == "white") o.position.process_noise = quad::est::ProcessNoise::kWhiteAcceleration;
         else usage_error(k + ": unknown noise model '" + v + "'");
       }},
      {"--q-pos", [&](auto& k, auto& v) { o.position.q_pos = number(k, v); }},
      {"--q-vel", [&](auto& k, auto& v) { o.position.q_vel = number(k, v); }},
      {"--q-accel", [&](auto& k, auto& v) { o.position.q_accel = number(k, v); }},
      {"--fix-sigma-xy", [&](auto& k, auto& v) { o.position.fix_sigma_xy = number(k, v); }},
      {"--fix-sigma-z", [&](auto& k, auto& v) { o.position.fix_sigma_z = number(k, v); }},
      {"--gate", [&](auto& k, auto& v) { o.position.gate_sigma = number(k, v); }},
      {"--star",
       [&](auto& k, auto& v) {
         o.star_ned = triple(k, v);
         star_given = true;
       }},
      {"--truth", [&](auto&, auto& v) { truth_path = v; }},
      {"--from", [&](auto& k, auto& v) { from = number(k, v); }},
      {"--to", [&](auto& k, auto& v) { to = number(k, v); }},
      {"--calibrate", [&](auto& k, auto& v) { calibrate_s = number(k, v); }},
  };

  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i], value;
    if (arg == "-h" || arg == "--help") {
      std::cout << kUsage;
      return 0;
    }
    if (arg == "--z-bias") {
      o.position.z_accel_bias = true;
      continue;
    }
    if (arg == "--fuse-on-arrival") {
      o.fuse_on_arrival = true;
      continue;
    }
    if (arg == "--compare") {
      compare = true;
      continue;
    }
    const auto eq = arg.find('=');
    const bool inline_value = arg.rfind("--", 0) == 0 && eq != std::string::npos;
    if (inline_value) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
    }
    const auto it = with_value.find(arg);
    if (it != with_value.end()) {
      if (!inline_value) {
        if (i + 1 >= argc) usage_error(arg + " needs a value");
        value = argv[++i];
      }
      it->second(arg, value);
    } else if (arg.size() > 1 && arg[0] == '-') {
      usage_error("unknown option '" + arg + "'");
    } else if (input.empty()) {
      input = arg;
    } else {
      usage_error("more than one input file ('" + input + "', '" + arg + "')");
    }
  }
  if (input.empty()) usage_error("no input log");
  if (mag_ref_given) {
    o.observer.mag_ref_ned = o.mahony.mag_ref_ned = o.linear.mag_ref_ned = mag_ref;
    o.observer.mag_ref_from_init = o.mahony.mag_ref_from_init = false;
  } else {
    o.linear.mag_ref_ned = quad::Vec3{1.0f, 0.0f, 0.0f};  // no declination: heading from magnetic north
  }

  const bool ulog_input = input != "-" && quad::replay::is_ulog(input);
  if (firmware && !ulog_input) usage_error("--filter firmware needs a ULog flight log");
  if (check_tolerance >= 0.0 && !firmware) usage_error("--check-attitude needs --filter firmware");
  if (compare && truth_path.empty()) usage_error("--compare needs --truth");
  if (firmware && !truth_path.empty()) usage_error("--truth works with the estimation layer's filters, not firmware");
  std::ofstream file;
  if (!output.empty()) {
    file.open(output);
    if (!file) {
      std::cerr << "estimation_replay: cannot write '" << output << "'\n";
      return 1;
    }
  }
  std::ostream& out = output.empty() ? std::cout : file;

  std::vector<quad::replay::LogRow> rows;
  try {
    if (ulog_input) {
      const quad::ulog::File log(input);
      if (firmware) return replay_firmware(log, check_tolerance, out);
      rows = quad::replay::rows_from_ulog(log);
      if (!star_given) {
        const auto params = log.initial_params();
        const char* star[3] = {"VIS_STAR_N", "VIS_STAR_E", "VIS_STAR_D"};
        for (int i = 0; i < 3; ++i) {
          const auto it = params.find(star[i]);
          if (it != params.end()) o.star_ned[i] = static_cast<float>(it->second);
        }
      }
    } else if (input == "-") {
      rows = quad::replay::read_log(std::cin, "<stdin>");
    } else {
      std::ifstream in(input);
      if (!in) {
        std::cerr << "estimation_replay: cannot open '" << input << "'\n";
        return 1;
      }
      rows = quad::replay::read_log(in, input);
    }
  } catch (const quad::replay::LogError& e) {
    std::cerr << "estimation_replay: " << e.what() << "\n";
    return 1;
  } catch (const quad::ulog::Error& e) {
    std::cerr << "estimation_replay: " << e.what() << "\n";
    return 1;
  }

  if (calibrate_s > 0.0 && !calibrate(rows, calibrate_s)) return 1;
  std::vector<quad::replay::TruthRow> truth;
  if (!truth_path.empty()) {
    try {
      truth = quad::replay::read_truth(truth_path);
    } catch (const quad::replay::LogError& e) {
      std::cerr << "estimation_replay: " << e.what() << "\n";
      return 1;
    }
  }
  std::vector<quad::replay::Estimate> track;
  const auto s = quad::replay::replay(rows, o, out, truth.empty() ? nullptr : &track);
  out.flush();
  if (!out) {
    std::cerr << "estimation_replay: write error\n";
    return 1;
  }
  if (o.filter == AttitudeFilter::kEkf) {
    std::cerr << "estimation_replay: " << s.rows << " rows, " << s.fixes << " vision fixes; EKF: " << s.ekf.positions_fused
              << " fused, " << s.ekf.positions_rejected << " outliers, " << s.ekf.fixes_too_old << " too old, "
              << s.ekf.fixes_refused << " refused, " << s.ekf.resets << " position resets, " << s.ekf.headings_fused
              << " magnetometer headings fused";
  } else {
    std::cerr << "estimation_replay: " << s.rows << " rows, " << s.fixes << " vision fixes: " << s.position.fused
              << " fused, " << s.position.rejected_gate << " outliers, " << s.position.rejected_too_old << " too old, "
              << s.position.rejected_out_of_order << " out of order, " << s.position.resets << " resets";
  }
  if (o.filter == AttitudeFilter::kConditioned || o.filter == AttitudeFilter::kUnconditioned) {
    std::cerr << "; observer: " << s.observer.skipped << " samples skipped, " << s.observer.accel_rejected
              << " accelerometer and " << s.observer.mag_rejected << " magnetometer samples not used";
  }
  std::cerr << "\n";
  if (truth.empty()) return 0;
  std::cerr << "errors against " << truth_path << ":\n";
  if (!compare) {
    print_figures("this filter", quad::replay::error_figures(track, truth, from, to));
    return 0;
  }
  const std::pair<const char*, AttitudeFilter> filters[] = {{"thesis pair", AttitudeFilter::kConditioned},
                                                           {"unconditioned", AttitudeFilter::kUnconditioned},
                                                           {"mahony", AttitudeFilter::kMahony},
                                                           {"linear", AttitudeFilter::kLinear},
                                                           {"ekf", AttitudeFilter::kEkf}};
  for (const auto& [name, filter] : filters) {
    ReplayOptions each = o;
    each.filter = filter;
    std::vector<quad::replay::Estimate> t;
    std::ostringstream discard;
    quad::replay::replay(rows, each, discard, &t);
    print_figures(name, quad::replay::error_figures(t, truth, from, to));
  }
  return 0;
}
