#include "quad/sim/metrics.h"

#include <algorithm>

namespace quad::sim {

void ErrorStats::add(double e) {
  ++n_;
  const double d = e - mean_;
  mean_ += d / static_cast<double>(n_);
  m2_ += d * (e - mean_);
  sum_sq_ += e * e;
  max_abs_ = std::max(max_abs_, std::abs(e));
}

void HoldStats::add(const Eigen::Vector3d& e) {
  for (int i = 0; i < 3; ++i) axis[i].add(e[i]);
  horizontal.add(e.head<2>().norm());
}

double HoldStats::horizontal_stddev() const {
  return std::sqrt(axis[0].stddev() * axis[0].stddev() + axis[1].stddev() * axis[1].stddev());
}

FlightMetrics::FlightMetrics(const FlightMetricsConfig& config) : c_(config) {
  for (const auto& [start, end] : c_.extra_holds) {
    HoldStats h;
    h.start_s = start;
    h.end_s = end;
    extra_holds_.push_back(h);
  }
}

void FlightMetrics::add(double t, const Eigen::Vector3d& p, const Eigen::Vector3d& v, double tilt,
                        const std::optional<Eigen::Vector3d>& setpoint, double setpoint_time_s) {
  if (!crashed_) {
    const bool on_ground = p.z() > c_.ground_down_m - 0.02;
    if (tilt > c_.crash_tilt_rad || (on_ground && v.z() > c_.crash_impact_speed_m_s)) {
      crashed_ = true;
      crash_time_s_ = t;
    }
  }
  if (!setpoint) return;
  const Eigen::Vector3d e = p - *setpoint;
  for (HoldStats& h : extra_holds_) {
    if (t >= h.start_s && t <= h.end_s) h.add(e);
  }
  // Settling is watched for whichever setpoint is active, and frozen at the end of the hold.
  if (setpoint_time_s != setpoint_time_s_) {
    setpoint_time_s_ = setpoint_time_s;
    last_outside_band_s_ = setpoint_time_s;
  }
  if (e.norm() > c_.settle_band_m) last_outside_band_s_ = t;
  if (t > c_.hold_end_s) return;
  settle_ = Settle{setpoint_time_s_, last_outside_band_s_, t};
  if (t < c_.hold_start_s) return;
  for (int i = 0; i < 3; ++i) hold_[i].add(e[i]);
  hold_horizontal_.add(e.head<2>().norm());
}

void GroundMoves::add_truth(double t, const Eigen::Vector3d& p) {
  const double height = ground_down_m_ - p.z();
  if (window_open_ && height > 0.02) window_end_s_ = std::min(window_end_s_, t);  // lifted off
  if (height > 0.05) {
    high_ = true;
  } else if (high_ && height < 0.005) {
    high_ = false;
    LandingMove m;
    m.touchdown_s = t;
    landings_.push_back(m);
    window_open_ = true;
    window_end_s_ = t + kWindowS;
  }
}

void GroundMoves::add_estimate(double t, const Eigen::Vector3d& e) {
  if (!window_open_ || !e.allFinite()) return;
  LandingMove& m = landings_.back();
  if (t < m.touchdown_s) return;
  if (t > window_end_s_) {
    window_open_ = false;
    return;
  }
  if (!m.has_reference) {
    m.has_reference = true;
    m.reference = e;
  }
  const Eigen::Vector3d d = e - m.reference;
  m.window_s = t - m.touchdown_s;
  m.move_m = std::max(m.move_m, d.norm());
  m.horizontal_m = std::max(m.horizontal_m, d.head<2>().norm());
  m.vertical_m = std::max(m.vertical_m, std::abs(d.z()));
}

double FlightMetrics::horizontal_stddev() const {
  return std::sqrt(hold_[0].stddev() * hold_[0].stddev() + hold_[1].stddev() * hold_[1].stddev());
}

std::optional<double> FlightMetrics::settling_time_s() const {
  if (!settle_ || hold_[0].count() == 0 || settle_->last_outside_s >= settle_->last_sample_s) return std::nullopt;
  return settle_->last_outside_s - settle_->setpoint_time_s;
}

}  // namespace quad::sim
