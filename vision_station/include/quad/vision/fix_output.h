// What the station emits for a fix: a JSON line (offline evaluation) and MAVLink LANDING_TARGET +
// TIMESYNC on a serial port (docs/hil-protocol.md: sysid 1, compid 197, frame MAV_FRAME_BODY_FRD).
#pragma once

#include <cstdint>
#include <string>

#include "quad/link/dialect.h"
#include "quad/link/mavlink.h"
#include "quad/vision/stereo_locator.h"

namespace quad::vision {

// {"found":true,"x":..,"y":..,"z":..,"sigma":[..],"body_frd":[..],"disparity_px":..,"q":[w,x,y,z],
// "attitude_sigma_rad":[..],"tilt_deg":..} (x y z sigma: left camera frame, OpenCV axes, metres; q: the
// star's axes in the body FRD frame, attitude_sigma_rad about the body axes, tilt_deg between the star's
// normal and the body z axis; q and attitude_sigma_rad null without a pose) or {"found":false}; `label`
// is added as "pair" when not empty.
std::string fix_json(const StarFix& fix, const CameraMount& mount, const std::string& label);

// LANDING_TARGET: x, y, z the star relative to the vehicle in body FRD (eq. 7.22), angles and distance
// from the left camera, time_usec the capture time on the vehicle clock.
// With a pose: q = the star's axes in body FRD (star_attitude_in_body), type VISION_FIDUCIAL.
mavlink::LandingTarget landing_target(const StarFix& fix, const CameraMount& mount, uint64_t vehicle_time_us);

// The covariances of the same fix in body FRD: position (from the centroid triangulation) and attitude.
mavlink::LandingTargetCovariance landing_target_covariance(const StarFix& fix, const CameraMount& mount,
                                                           uint64_t vehicle_time_us);

// A serial port in termios raw mode, non-blocking.
class SerialPort {
 public:
  SerialPort(const std::string& path, int baud);  // throws std::runtime_error naming the path
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;
  bool write_all(const uint8_t* data, size_t length);  // false when the port would not take it all
  size_t read_some(uint8_t* data, size_t capacity);
 private:
  int fd_ = -1;
  std::string path_;
};

// LANDING_TARGET out, TIMESYNC both ways: the station asks once a second (tc1 = 0, ts1 = its clock) and
// estimates the vehicle clock offset from the reply (offset = tc1 − (ts1 + now)/2, ns); it also answers
// the vehicle's requests. Until a reply has arrived time_usec is on the station clock. With `timesync`
// false (a source whose capture times are already on the vehicle clock, the simulator's) no TIMESYNC is
// sent or answered and time_usec is the capture time as is.
class FixLink {
 public:
  // With `covariance`, each LANDING_TARGET is followed by its LANDING_TARGET_COVARIANCE.
  explicit FixLink(SerialPort& port, bool timesync = true, bool covariance = true);
  void poll(int64_t now_us);  // reads replies, sends the periodic request
  bool send(const StarFix& fix, const CameraMount& mount, int64_t capture_time_us);
  bool synchronised() const { return synchronised_; }
  int64_t offset_us() const { return offset_ns_ / 1000; }
  uint64_t frames_sent() const { return sent_; }
  uint64_t frames_dropped() const { return dropped_; }

 private:
  SerialPort& port_;
  mavlink::Sender sender_;
  mavlink::Parser parser_;
  int64_t last_request_us_ = -1;
  bool timesync_ = true;
  bool covariance_ = true;
  bool synchronised_ = false;
  int64_t offset_ns_ = 0;
  uint64_t sent_ = 0, dropped_ = 0;
};

}  // namespace quad::vision
