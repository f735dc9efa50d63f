#include "quad/vision/fix_output.h"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "quad/hal/termios_speed.h"

namespace quad::vision {

std::string fix_json(const StarFix& fix, const CameraMount& mount, const std::string& label) {
  std::string out = "{";
  if (!label.empty()) {
    out += "\"pair\":\"";
    for (char c : label) {
      if (c == '"' || c == '\\') out += '\\';
      out += c;
    }
    out += "\",";
  }
  if (!fix.found) return out + "\"found\":false}";
  const cv::Vec3d b = camera_to_body(mount, fix.p_left);
  char buffer[512];
  std::snprintf(buffer, sizeof buffer,
                "\"found\":true,\"x\":%.5f,\"y\":%.5f,\"z\":%.5f,\"sigma\":[%.5f,%.5f,%.5f],"
                "\"body_frd\":[%.5f,%.5f,%.5f],\"disparity_px\":%.3f,\"row_difference_px\":%.3f",
                fix.p_left[0], fix.p_left[1], fix.p_left[2], fix.sigma_left[0], fix.sigma_left[1], fix.sigma_left[2],
                b[0], b[1], b[2], fix.disparity_px, fix.row_difference_px);
  out += buffer;
  if (!fix.pose.valid) return out + ",\"q\":null,\"attitude_sigma_rad\":null}";
  const cv::Matx33d R_BS = star_attitude_in_body(mount.R_BC, fix.pose.R_CS);
  const cv::Vec4d q = quaternion_from_rotation(R_BS);
  const cv::Matx33d cov = mount.R_BC * fix.pose.attitude_cov_C * mount.R_BC.t();
  const double tilt = std::acos(std::min(1.0, std::fabs(R_BS(2, 2))));
  // The star's normal (its z axis, away from the cameras) in the left camera frame, for scoring the tilt.
  const cv::Vec3d n(fix.pose.R_CS(0, 2), fix.pose.R_CS(1, 2), fix.pose.R_CS(2, 2));
  std::snprintf(buffer, sizeof buffer,
                ",\"q\":[%.6f,%.6f,%.6f,%.6f],\"attitude_sigma_rad\":[%.6f,%.6f,%.6f],\"tilt_deg\":%.3f,"
                "\"normal_camera\":[%.6f,%.6f,%.6f],\"pose_rms_px\":%.3f}",
                q[0], q[1], q[2], q[3], std::sqrt(cov(0, 0)), std::sqrt(cov(1, 1)), std::sqrt(cov(2, 2)),
                tilt * 180.0 / CV_PI, n[0], n[1], n[2], fix.pose.rms_px);
  return out + buffer;
}

mavlink::LandingTarget landing_target(const StarFix& fix, const CameraMount& mount, uint64_t vehicle_time_us) {
  mavlink::LandingTarget m;
  m.time_usec = vehicle_time_us;
  m.frame = mavlink::kFrameBodyFrd;
  const cv::Vec3d& p = fix.p_left;
  m.angle_x = static_cast<float>(std::atan2(p[0], p[2]));
  m.angle_y = static_cast<float>(std::atan2(p[1], p[2]));
  m.distance = static_cast<float>(cv::norm(p));
  const cv::Vec3d b = camera_to_body(mount, p);  // thesis eq. 7.22
  m.x = static_cast<float>(b[0]);
  m.y = static_cast<float>(b[1]);
  m.z = static_cast<float>(b[2]);
  m.q[0] = 1.0f;
  if (fix.pose.valid) {
    const cv::Vec4d q = quaternion_from_rotation(star_attitude_in_body(mount.R_BC, fix.pose.R_CS));
    for (int i = 0; i < 4; ++i) m.q[i] = static_cast<float>(q[i]);
  }
  m.type = mavlink::kLandingTargetTypeVisionFiducial;
  m.position_valid = 1;
  return m;
}

namespace {

void upper_triangle(const cv::Matx33d& m, float out[6]) {
  const int rows[6] = {0, 0, 0, 1, 1, 2}, cols[6] = {0, 1, 2, 1, 2, 2};
  for (int i = 0; i < 6; ++i) out[i] = static_cast<float>(m(rows[i], cols[i]));
}

}  // namespace

mavlink::LandingTargetCovariance landing_target_covariance(const StarFix& fix, const CameraMount& mount,
                                                           uint64_t vehicle_time_us) {
  mavlink::LandingTargetCovariance m;
  m.time_usec = vehicle_time_us;
  upper_triangle(mount.R_BC * fix.cov_left * mount.R_BC.t(), m.position_covariance);
  if (fix.pose.valid) {
    upper_triangle(mount.R_BC * fix.pose.attitude_cov_C * mount.R_BC.t(), m.attitude_covariance);
    m.attitude_valid = 1;
  }
  return m;
}

namespace {

speed_t baud_constant(int baud) {
  speed_t speed;
  if (baud <= 0 || !hal::termios_speed(static_cast<uint32_t>(baud), &speed)) {
    throw std::runtime_error("--baud " + std::to_string(baud) + ": unsupported (a termios rate, 9600 ... 4000000)");
  }
  return speed;
}

}  // namespace

SerialPort::SerialPort(const std::string& path, int baud) : path_(path) {
  const speed_t speed = baud_constant(baud);
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (fd_ < 0) throw std::runtime_error(path + ": cannot open serial port: " + std::strerror(errno));
  termios tio{};
  if (tcgetattr(fd_, &tio) != 0) {
    ::close(fd_);
    throw std::runtime_error(path + ": not a terminal device: " + std::strerror(errno));
  }
  cfmakeraw(&tio);
  cfsetispeed(&tio, speed);
  cfsetospeed(&tio, speed);
  tio.c_cflag |= CLOCAL | CREAD;
  if (tcsetattr(fd_, TCSANOW, &tio) != 0) {
    ::close(fd_);
    throw std::runtime_error(path + ": cannot set raw mode: " + std::strerror(errno));
  }
}

SerialPort::~SerialPort() {
  if (fd_ >= 0) ::close(fd_);
}

bool SerialPort::write_all(const uint8_t* data, size_t length) {
  while (length > 0) {
    const ssize_t n = ::write(fd_, data, length);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;  // EAGAIN: the link is saturated; the caller drops this frame rather than queue stale fixes
    }
    data += n;
    length -= static_cast<size_t>(n);
  }
  return true;
}

size_t SerialPort::read_some(uint8_t* data, size_t capacity) {
  const ssize_t n = ::read(fd_, data, capacity);
  return n > 0 ? static_cast<size_t>(n) : 0;
}

FixLink::FixLink(SerialPort& port, bool timesync, bool covariance)
    : port_(port), sender_(1, mavlink::kCompIdVisualInertialOdometry), timesync_(timesync), covariance_(covariance) {}

void FixLink::poll(int64_t now_us) {
  if (!timesync_) return;
  uint8_t buffer[256];
  for (size_t n; (n = port_.read_some(buffer, sizeof buffer)) > 0;) {
    parser_.feed(buffer, n, [&](const mavlink::Frame& frame) {
      mavlink::Timesync t;
      if (!mavlink::decode(frame, t)) return;
      const int64_t now_ns = now_us * 1000;
      if (t.tc1 == 0) {
        // The vehicle asks: answer with our clock.
        mavlink::Timesync reply;
        reply.tc1 = now_ns;
        reply.ts1 = t.ts1;
        reply.target_system = frame.system_id;
        reply.target_component = frame.component_id;
        uint8_t out[mavlink::max_frame_length<mavlink::Timesync>()];
        port_.write_all(out, sender_.encode(reply, out, sizeof out));
      } else if (t.ts1 > 0 && t.ts1 <= now_ns && now_ns - t.ts1 < 1'000'000'000) {
        // Our request came back: the vehicle's clock tc1 was read half a round trip ago.
        offset_ns_ = t.tc1 - (t.ts1 + now_ns) / 2;
        synchronised_ = true;
      }
    });
  }
  if (last_request_us_ < 0 || now_us - last_request_us_ >= 1'000'000) {
    mavlink::Timesync request;
    request.tc1 = 0;
    request.ts1 = now_us * 1000;
    uint8_t out[mavlink::max_frame_length<mavlink::Timesync>()];
    port_.write_all(out, sender_.encode(request, out, sizeof out));
    last_request_us_ = now_us;
  }
}

bool FixLink::send(const StarFix& fix, const CameraMount& mount, int64_t capture_time_us) {
  const int64_t vehicle_us = capture_time_us + (synchronised_ ? offset_ns_ / 1000 : 0);
  const mavlink::LandingTarget message = landing_target(fix, mount, static_cast<uint64_t>(std::max<int64_t>(vehicle_us, 0)));
  uint8_t out[mavlink::max_frame_length<mavlink::LandingTarget>()];
  const size_t n = sender_.encode(message, out, sizeof out);
  if (n > 0 && port_.write_all(out, n)) {
    ++sent_;
    if (covariance_) {
      const mavlink::LandingTargetCovariance cov = landing_target_covariance(fix, mount, message.time_usec);
      uint8_t cov_out[mavlink::max_frame_length<mavlink::LandingTargetCovariance>()];
      port_.write_all(cov_out, sender_.encode(cov, cov_out, sizeof cov_out));
    }
    return true;
  }
  ++dropped_;
  return false;
}

}  // namespace quad::vision
