#include "replay.h"

#include <cmath>
#include <cstdio>
#include <algorithm>
#include <string>
#include <utility>

namespace quad::replay {

namespace {

Vec3 vec(const double v[3]) { return {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])}; }

uint32_t to_us(double t) { return static_cast<uint32_t>(static_cast<int64_t>(std::llround(t * 1e6))); }

// The four attitude filters behind one interface (host code: a switch keeps the core free of virtuals).
class Attitude {
 public:
  explicit Attitude(const ReplayOptions& o) : kind_(o.filter), mahony_(o.mahony), linear_(o.linear) {
    est::ObserverParams p = o.observer;
    p.innovation = kind_ == AttitudeFilter::kUnconditioned ? est::Innovation::kUnconditioned : est::Innovation::kConditioned;
    observer_.set_params(p);
  }

  bool initialize(const Vec3& a, const Vec3& m) {
    switch (kind_) {
      case AttitudeFilter::kMahony: return mahony_.initialize(a, m);
      case AttitudeFilter::kLinear: return linear_.initialize(a, m);
      default: return observer_.initialize(a, m);
    }
  }
  void update(const Vec3& g, const Vec3& a, const Vec3& m, bool mag_valid, float dt) {
    switch (kind_) {
      case AttitudeFilter::kMahony: mahony_.update(g, a, m, mag_valid, dt); break;
      case AttitudeFilter::kLinear: linear_.update(g, a, m, mag_valid, dt); break;
      default: observer_.update(g, a, m, mag_valid, dt); break;
    }
  }
  Quat attitude() const {
    switch (kind_) {
      case AttitudeFilter::kMahony: return mahony_.attitude();
      case AttitudeFilter::kLinear: return linear_.attitude();
      default: return observer_.attitude();
    }
  }
  Vec3 gyro_bias() const {
    switch (kind_) {
      case AttitudeFilter::kMahony: return mahony_.gyro_bias();
      case AttitudeFilter::kLinear: return Vec3{};  // the linear filter has no bias estimate
      default: return observer_.gyro_bias();
    }
  }
  const est::ObserverHealth& health() const { return observer_.health(); }
  bool uses_observer() const { return kind_ == AttitudeFilter::kConditioned || kind_ == AttitudeFilter::kUnconditioned; }

 private:
  AttitudeFilter kind_;
  est::ConditionedObserver observer_;
  est::MahonyFilter mahony_;
  est::LinearComplementaryFilter linear_;
};

void put(std::string& line, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ",%.9g", v);
  line += buf;
}

// The row's CSV cells after t: attitude, Euler angles and gyro bias, then position and velocity (empty
// where not initialised); and its estimate.
void write_row(std::ostream& out, double t, bool att_valid, const Quat& q, const Vec3& b, bool pos_valid,
               const Vec3& p, const Vec3& v, std::vector<Estimate>* track) {
  std::string line;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", t);
  line += buf;
  if (att_valid) {
    const Euler e = to_euler(q);
    for (double x : {q.w, q.x, q.y, q.z, e.roll, e.pitch, e.yaw, b.x, b.y, b.z}) put(line, x);
  } else {
    line += ",,,,,,,,,,";
  }
  if (pos_valid) {
    for (double x : {p.x, p.y, p.z, v.x, v.y, v.z}) put(line, x);
  } else {
    line += ",,,,,,";
  }
  out << line << "\n";
  if (track) track->push_back(Estimate{t, att_valid, pos_valid, q, p});
}

// The row's magnetometer sample, or the last one when the row has none (the filters hold it).
Vec3 held_mag(const LogRow& r, Vec3* last_mag) {
  if (r.mag) {
    *last_mag = Vec3{static_cast<float>((*r.mag)[0]), static_cast<float>((*r.mag)[1]),
                     static_cast<float>((*r.mag)[2])};
  }
  return *last_mag;
}

// The EKF over the rows: IMU increments every row, the predict every row (the log's rate), fixes as the
// star in the body frame at their capture time. It starts (attitude from the conditioned observer's
// initialisation, the observer's learned field as its reference) on the first row with a magnetometer
// sample.
ReplaySummary replay_ekf(const std::vector<LogRow>& rows, const ReplayOptions& options, std::ostream& out,
                         std::vector<Estimate>* track) {
  est::ConditionedObserver observer;
  observer.set_params(options.observer);
  est::DelayedEkf<est::history_length(1000)> ekf;
  std::vector<std::pair<double, Quat>> history;  // the EKF's attitude per row, for fixes
  ReplaySummary summary;
  bool initialized = false;
  Vec3 last_mag;
  double t_prev = 0.0;
  out << kOutputHeader << "\n";
  for (const LogRow& r : rows) {
    const Vec3 g = vec(r.gyro), a = vec(r.accel);
    const bool mag_new = r.mag.has_value();
    const Vec3 m = held_mag(r, &last_mag);
    const uint32_t now = to_us(r.t);
    if (!initialized) {
      initialized = mag_new && observer.initialize(a, m);
      if (initialized) {
        est::EkfParams p = options.ekf;
        p.star_ned = options.star_ned;
        p.mag_ref_ned = observer.params().mag_ref_ned;
        ekf.set_params(p, 0.1f, true, false);
        ekf.reset(observer.attitude(), Vec3{}, Vec3{}, now);
      }
    } else {
      const float dt = static_cast<float>(r.t - t_prev);
      ekf.imu(g, a, dt);
      if (mag_new) ekf.mag(m);
      ekf.predict(now, false, false);
    }
    t_prev = r.t;
    if (initialized) history.emplace_back(r.t, ekf.attitude());
    if (r.fix && initialized) {
      ++summary.fixes;
      const double tc = options.fuse_on_arrival ? r.t : r.fix->t;
      // The EKF's own attitude at the row at or before the capture time: the logged fix is a NED position,
      // taken back into the body frame so that the update sees the position alone.
      auto it = std::upper_bound(history.begin(), history.end(), tc,
                                 [](double t, const std::pair<double, Quat>& h) { return t < h.first; });
      if (it != history.begin()) --it;
      est::StarFix f;
      f.capture_us = to_us(tc);
      f.star_body = rotate_inverse(it->second, options.star_ned - vec(r.fix->p));
      ekf.queue_fix(f);
    }
    const est::EkfState& x = ekf.delayed_state();
    write_row(out, r.t, initialized, ekf.attitude(), x.gyro_bias, initialized && ekf.position_initialized(),
              ekf.position(), ekf.velocity(), track);
    ++summary.rows;
  }
  summary.ekf = ekf.health();
  return summary;
}

}  // namespace

ReplaySummary replay(const std::vector<LogRow>& rows, const ReplayOptions& options, std::ostream& out,
                     std::vector<Estimate>* track) {
  if (options.filter == AttitudeFilter::kEkf) return replay_ekf(rows, options, out, track);
  Attitude attitude(options);
  // History for 250 ms at up to 1 kHz: logs of any rate up to the firmware's fastest loop.
  est::PositionFilter<est::history_length(1000)> position(options.position);
  ReplaySummary summary;
  bool initialized = false;
  Vec3 last_mag;
  double t_prev = 0.0;
  out << kOutputHeader << "\n";
  for (const LogRow& r : rows) {
    const Vec3 g = vec(r.gyro), a = vec(r.accel);
    const bool mag_new = r.mag.has_value();
    const Vec3 m = held_mag(r, &last_mag);
    if (!initialized) {
      initialized = mag_new && attitude.initialize(a, m);
    } else {
      attitude.update(g, a, m, mag_new, static_cast<float>(r.t - t_prev));
    }
    t_prev = r.t;

    const uint32_t now = to_us(r.t);
    const Quat q = attitude.attitude();
    position.predict(initialized ? est::kinematic_acceleration(q, a) : Vec3{}, now);
    if (r.fix && initialized) {
      ++summary.fixes;
      position.fuse_position(vec(r.fix->p), options.fuse_on_arrival ? now : to_us(r.fix->t));
    }

    write_row(out, r.t, initialized, q, attitude.gyro_bias(), position.initialized(), position.position(),
              position.velocity(), track);
    ++summary.rows;
  }
  summary.position = position.health();
  if (attitude.uses_observer()) summary.observer = attitude.health();
  return summary;
}

}  // namespace quad::replay
