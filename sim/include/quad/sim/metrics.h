// Flight figures of one run: position error statistics during the hold, settling, crash detection.
#pragma once

#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace quad::sim {

// Mean, standard deviation, RMS and maximum magnitude of one error component (Welford's update).
class ErrorStats {
 public:
  void add(double e);
  long count() const { return n_; }
  double mean() const { return n_ ? mean_ : 0.0; }
  double stddev() const { return n_ > 1 ? std::sqrt(m2_ / static_cast<double>(n_ - 1)) : 0.0; }
  double rms() const { return n_ ? std::sqrt(sum_sq_ / static_cast<double>(n_)) : 0.0; }
  double max_abs() const { return max_abs_; }

 private:
  long n_ = 0;
  double mean_ = 0.0, m2_ = 0.0, sum_sq_ = 0.0, max_abs_ = 0.0;
};

// The error statistics of one hold window.
struct HoldStats {
  double start_s = 0.0, end_s = 0.0;
  ErrorStats axis[3];     // north, east, down
  ErrorStats horizontal;  // north-east error magnitude
  void add(const Eigen::Vector3d& e);
  // 2-D standard deviation of the horizontal position: sqrt(var_n + var_e).
  double horizontal_stddev() const;
};

struct FlightMetricsConfig {
  double hold_start_s = 0.0, hold_end_s = 0.0;
  std::vector<std::pair<double, double>> extra_holds;  // further hold windows (start, end), e.g. a second flight's
  double settle_band_m = 0.05;
  double crash_tilt_rad = 1.05;         // 60 deg: a multirotor beyond this is not flying any more
  double crash_impact_speed_m_s = 2.0;  // touching the ground faster than this breaks the gear
  double ground_down_m = 0.0;           // NED z of the centre of mass standing on the gear
};

// The estimate on the ground after each touchdown: how far it moves from its value at the touchdown in
// the window that follows (30 s, or up to the next lift-off). Touchdown is the truth's contact: the
// centre back within 5 mm of its standing height after it had been more than 5 cm above it; lift-off is
// the centre 2 cm above it. The estimate is taken at its own time stamps (the firmware's HIL clock), so
// the telemetry's age does not count as motion: the reference is the first estimate stamped at or after
// the touchdown.
struct LandingMove {
  double touchdown_s = 0.0;
  double window_s = 0.0;           // stamps covered after the touchdown
  double move_m = 0.0;             // largest 3-D distance from the reference
  double horizontal_m = 0.0;       // largest north-east distance
  double vertical_m = 0.0;         // largest |down| difference
  bool has_reference = false;
  Eigen::Vector3d reference = Eigen::Vector3d::Zero();
};

class GroundMoves {
 public:
  static constexpr double kWindowS = 30.0;
  explicit GroundMoves(double ground_down_m) : ground_down_m_(ground_down_m) {}
  // The truth's position at time t (every log row).
  void add_truth(double t, const Eigen::Vector3d& position_ned);
  // An estimate stamped t_stamp (s on the simulator clock).
  void add_estimate(double t_stamp, const Eigen::Vector3d& estimate_ned);
  const std::vector<LandingMove>& landings() const { return landings_; }

 private:
  double ground_down_m_;
  bool high_ = false;          // the centre has been more than 5 cm above standing since the last touchdown
  bool window_open_ = false;   // the last landing's window still runs
  double window_end_s_ = 0.0;
  std::vector<LandingMove> landings_;
};

class FlightMetrics {
 public:
  explicit FlightMetrics(const FlightMetricsConfig& config);

  // One sample (at the log rate). `setpoint_time_s` is when the active setpoint was commanded.
  void add(double t, const Eigen::Vector3d& position_ned, const Eigen::Vector3d& velocity_ned, double tilt_rad,
           const std::optional<Eigen::Vector3d>& setpoint_ned, double setpoint_time_s);

  const ErrorStats& hold(int axis) const { return hold_[axis]; }
  // The further windows, in the configuration's order.
  const std::vector<HoldStats>& extra_holds() const { return extra_holds_; }
  // Horizontal (north-east) error magnitude during the hold.
  const ErrorStats& hold_horizontal() const { return hold_horizontal_; }
  // 2-D standard deviation of the horizontal position during the hold: sqrt(var_n + var_e).
  double horizontal_stddev() const;
  // Time from the last setpoint command before the hold until the 3-D error stayed within the band
  // to the end of the hold; nullopt when it never settled.
  std::optional<double> settling_time_s() const;
  bool crashed() const { return crashed_; }
  double crash_time_s() const { return crash_time_s_; }

 private:
  FlightMetricsConfig c_;
  ErrorStats hold_[3];
  ErrorStats hold_horizontal_;
  std::vector<HoldStats> extra_holds_;
  struct Settle {
    double setpoint_time_s, last_outside_s, last_sample_s;
  };
  double setpoint_time_s_ = -1.0;
  double last_outside_band_s_ = -1.0;
  std::optional<Settle> settle_;
  bool crashed_ = false;
  double crash_time_s_ = -1.0;
};

}  // namespace quad::sim
