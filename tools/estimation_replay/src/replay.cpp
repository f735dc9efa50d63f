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

// One row's sensor samples as the filters take them.
struct RowSamples {
  Vec3 gyro, accel;
  Vec3 mag;      // the row's magnetometer sample, or the last one when the row has none (the filters hold it)
  bool mag_new;  // whether the row has a magnetometer sample of its own
  float dt;      // time since the previous row, s
};

// Reads the rows in order, keeping the last magnetometer sample and the previous row's time.
class SampleReader {
 public:
  RowSamples next(const LogRow& r) {
    RowSamples s;
    s.gyro = vec(r.gyro);
    s.accel = vec(r.accel);
    s.mag_new = r.mag.has_value();
    if (r.mag) last_mag_ = vec(r.mag->data());
    s.mag = last_mag_;
    s.dt = static_cast<float>(r.t - t_prev_);
    t_prev_ = r.t;
    return s;
  }

 private:
  Vec3 last_mag_;
  double t_prev_ = 0.0;
};

// The replay loop: the header, then per log row its samples through `filter_row`, which writes the output
// row and returns whether it took the row's fix.
template <class FilterRow>
ReplaySummary replay_rows(const std::vector<LogRow>& rows, std::ostream& out, FilterRow&& filter_row) {
  ReplaySummary summary;
  SampleReader samples;
  out << kOutputHeader << "\n";
  for (const LogRow& r : rows) {
    if (filter_row(r, samples.next(r))) ++summary.fixes;
    ++summary.rows;
  }
  return summary;
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
  bool initialized = false;
  ReplaySummary summary = replay_rows(rows, out, [&](const LogRow& r, const RowSamples& s) {
    const uint32_t now = to_us(r.t);
    if (!initialized) {
      initialized = s.mag_new && observer.initialize(s.accel, s.mag);
      if (initialized) {
        est::EkfParams p = options.ekf;
        p.star_ned = options.star_ned;
        p.mag_ref_ned = observer.params().mag_ref_ned;
        ekf.set_params(p, 0.1f, true, false);
        ekf.reset(observer.attitude(), Vec3{}, Vec3{}, now);
      }
    } else {
      ekf.imu(s.gyro, s.accel, s.dt);
      if (s.mag_new) ekf.mag(s.mag);
      ekf.predict(now, false, false);
    }
    if (initialized) history.emplace_back(r.t, ekf.attitude());
    const bool fused = r.fix && initialized;
    if (fused) {
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
    return fused;
  });
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
  bool initialized = false;
  ReplaySummary summary = replay_rows(rows, out, [&](const LogRow& r, const RowSamples& s) {
    if (!initialized) {
      initialized = s.mag_new && attitude.initialize(s.accel, s.mag);
    } else {
      attitude.update(s.gyro, s.accel, s.mag, s.mag_new, s.dt);
    }

    const uint32_t now = to_us(r.t);
    const Quat q = attitude.attitude();
    position.predict(initialized ? est::kinematic_acceleration(q, s.accel) : Vec3{}, now);
    const bool fused = r.fix && initialized;
    if (fused) position.fuse_position(vec(r.fix->p), options.fuse_on_arrival ? now : to_us(r.fix->t));

    write_row(out, r.t, initialized, q, attitude.gyro_bias(), position.initialized(), position.position(),
              position.velocity(), track);
    return fused;
  });
  summary.position = position.health();
  if (attitude.uses_observer()) summary.observer = attitude.health();
  return summary;
}

}  // namespace quad::replay
