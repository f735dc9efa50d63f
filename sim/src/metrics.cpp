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

double FlightMetrics::horizontal_stddev() const {
  return std::sqrt(hold_[0].stddev() * hold_[0].stddev() + hold_[1].stddev() * hold_[1].stddev());
}

std::optional<double> FlightMetrics::settling_time_s() const {
  if (!settle_ || hold_[0].count() == 0 || settle_->last_outside_s >= settle_->last_sample_s) return std::nullopt;
  return settle_->last_outside_s - settle_->setpoint_time_s;
}

}  // namespace quad::sim
