#include "firmware_replay.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include "quad/firmware/frame_schedule.h"
#include "quad/firmware/params.h"
#include "quad/firmware/state_estimator.h"
#include "sensor_log.h"

namespace quad::replay {

namespace {

struct Topic {
  const ulog::Layout* layout = nullptr;
  std::vector<uint16_t> ids;
  bool is(const ulog::Record& r) const {
    if (r.kind != ulog::Record::Kind::kData) return false;
    for (uint16_t id : ids) {
      if (id == r.msg_id) return true;
    }
    return false;
  }
  const ulog::FieldRef& field(const ulog::File& log, const char* name) const {
    try {
      return layout->field(name);
    } catch (const ulog::Error& e) {
      throw LogError(log.path() + ": " + e.what());
    }
  }
};

Topic topic(const ulog::File& log, const char* name, bool required) {
  Topic t;
  t.ids = log.ids_of(name);
  if (!t.ids.empty()) {
    t.layout = &log.layout(name);
  } else if (required) {
    throw LogError(log.path() + ": the log has no topic '" + name + "'");
  }
  return t;
}

Vec3 vec3(const ulog::Record& r, const ulog::FieldRef& f) {
  return {ulog::float_value(r, f, 0), ulog::float_value(r, f, 1), ulog::float_value(r, f, 2)};
}

// Sets a logged parameter as the firmware would take it; false for a name this firmware does not have.
bool set_param(const ulog::File& log, fw::Params* p, const std::string& name, double value) {
  const int16_t index = fw::param_find(name.c_str());
  if (index < 0) return false;
  if (p->set(static_cast<uint8_t>(index), static_cast<float>(value)) != fw::ParamError::kNone) {
    throw LogError(log.path() + ": logged parameter " + name + " = " + std::to_string(value) + " is refused by the firmware's table");
  }
  return true;
}

void configure(const ulog::File& log, const fw::Params& p, fw::StateEstimator* est, fw::FrameSchedule* schedule) {
  if (const char* bad = est->check(p)) throw LogError(log.path() + ": the logged parameters are refused: " + bad);
  const float loop_hz = p.get(fw::kLoopHz);
  est->configure(p, loop_hz);
  schedule->configure(loop_hz);
}

void put(std::string& line, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ",%.9g", v);
  line += buf;
}

}  // namespace

FirmwareReplaySummary replay_firmware(const ulog::File& log, double tolerance, std::ostream& out) {
  const Topic imu = topic(log, "sensor_combined", true);
  const Topic mag = topic(log, "sensor_mag", false);
  const Topic fix = topic(log, "vision_fix", false);
  const Topic att = topic(log, "vehicle_attitude", false);
  const ulog::FieldRef& gyro = imu.field(log, "gyro_rad");
  const ulog::FieldRef& accel = imu.field(log, "accelerometer_m_s2");
  const ulog::FieldRef& dt_field = imu.field(log, "dt");
  FirmwareReplaySummary s;
  s.hovering_logged = imu.layout->has("hovering");

  // The magnetometer sample handed to an iteration, and the attitude it logged, by timestamp.
  std::map<uint64_t, Vec3> mags;
  std::map<uint64_t, std::array<float, 4>> logged_q;
  for (const ulog::Record& r : log.records()) {
    if (mag.is(r)) mags[r.timestamp] = vec3(r, mag.field(log, "magnetometer_ga"));
    if (att.is(r)) {
      const ulog::FieldRef& q = att.field(log, "q");
      logged_q[r.timestamp] = {ulog::float_value(r, q, 0), ulog::float_value(r, q, 1), ulog::float_value(r, q, 2),
                               ulog::float_value(r, q, 3)};
    }
  }

  fw::Params params;
  for (const auto& [name, value] : log.initial_params()) set_param(log, &params, name, value);
  fw::StateEstimator est;
  fw::FrameSchedule schedule;
  configure(log, params, &est, &schedule);
  est.restart_calibration();

  out << "t,qw,qx,qy,qz,roll,pitch,yaw,bgx,bgy,bgz,px,py,pz,vx,vy,vz\n";
  for (const ulog::Record& r : log.records()) {
    if (r.kind == ulog::Record::Kind::kParameter) {
      // A change in flight reaches the estimator between two iterations (FlightApp::apply_params).
      if (set_param(log, &params, r.key, r.value)) configure(log, params, &est, &schedule);
      continue;
    }
    if (fix.is(r)) {
      const Vec3 p{ulog::float_value(r, fix.field(log, "x")), ulog::float_value(r, fix.field(log, "y")),
                   ulog::float_value(r, fix.field(log, "z"))};
      if (!is_finite(p)) continue;  // invalid before conversion: the filter never saw it
      const uint32_t capture = static_cast<uint32_t>(ulog::number(r, fix.field(log, "timestamp_sample")));
      ++s.fixes;
      // FlightApp::position_fix_at: fused on arrival at the thesis' rate, else queued for the frame.
      if (!schedule.fuses_on_arrival() || est.fix_in_progress()) {
        est.queue_fix(p, capture);
      } else {
        est.fuse_fix(p, capture);
      }
      continue;
    }
    if (!imu.is(r)) continue;
    const float dt = ulog::float_value(r, dt_field);
    hal::ImuSample sample;
    sample.gyro = vec3(r, gyro);
    sample.accel = vec3(r, accel);
    const auto m = mags.find(r.timestamp);
    hal::MagSample mag_sample;
    if (m != mags.end()) mag_sample.field = m->second;
    // FlightApp::step. A mode entered by a command while a fix waits (above 100 Hz) is not in the log:
    // the schedule here assumes none.
    const fw::IterationPlan plan = schedule.next(dt, est.fix_in_progress());
    if (plan.fix_step) est.advance_fix();
    const bool hovering =
        plan.frame_work && s.hovering_logged && ulog::number(r, imu.field(log, "hovering")) != 0.0;
    const bool on_ground = imu.layout->has("on_ground") && ulog::number(r, imu.field(log, "on_ground")) != 0.0;
    est.step(static_cast<uint32_t>(r.timestamp), sample, m != mags.end() ? &mag_sample : nullptr, dt, plan, hovering,
             on_ground);
    ++s.iterations;
    s.calibrated = s.calibrated || est.calibrated();

    const Quat q = est.attitude();
    const auto logged = logged_q.find(r.timestamp);
    if (logged != logged_q.end()) {
      const auto& l = logged->second;
      // q and -q are one attitude: compare with the sign that aligns them.
      const double sign = q.w * l[0] + q.x * l[1] + q.y * l[2] + q.z * l[3] < 0.0f ? -1.0 : 1.0;
      double d = 0.0;
      const float mine[4] = {q.w, q.x, q.y, q.z};
      for (int i = 0; i < 4; ++i) d = std::max(d, std::fabs(sign * mine[i] - l[i]));
      if (!(d <= tolerance) && s.first_difference_t < 0.0) s.first_difference_t = static_cast<double>(r.timestamp) * 1e-6;
      if (!(d <= s.max_q_difference)) s.max_q_difference = d;  // NaN sticks
      ++s.compared;
    }

    std::string line;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", static_cast<double>(r.timestamp) * 1e-6);
    line += buf;
    if (est.converged()) {
      const Euler e = to_euler(q);
      for (double v : {q.w, q.x, q.y, q.z, e.roll, e.pitch, e.yaw}) put(line, v);
      line += ",,,";
      const Vec3 p = est.position(), v = est.velocity();
      for (double x : {p.x, p.y, p.z, v.x, v.y, v.z}) put(line, x);
    } else {
      line += ",,,,,,,,,,,,,,,,";
    }
    out << line << "\n";
  }
  return s;
}

}  // namespace quad::replay
