#include "quad/sim/station_loop.h"

#include <chrono>
#include <cmath>
#include <filesystem>

#include "quad/sim/station_calibration.h"
#include "quad/sim/vision_fix.h"
#include "quad/vision/sim_protocol.h"

namespace quad::sim {
namespace wire = quad::vision::sim_protocol;
namespace mav = quad::mavlink;

namespace {

constexpr double kHistoryS = 0.1;  // vehicle poses kept for interlaced fields and motion blur

}  // namespace

StationLoop::StationLoop(const Scenario& scenario, const SimStereoRig& rig, const std::string& out_dir,
                         const std::vector<std::string>& station_argv, const StationLoopOptions& options)
    : s_(scenario),
      // The rendered rig carries the scenario's mount error; the station learns the model's mount.
      renderer_(scenario.camera, misaligned(rig, scenario.camera.mount_error_rad), make_floor_scene(scenario.camera, Rng(scenario.seed, "floor_scene")),
                Rng(scenario.seed, "camera")),
      loss_rng_(scenario.seed, "camera_frame_loss"),
      port_(scenario.radio_baud),
      station_("vision station", "quad_sim") {
  // The station learns the cameras from chessboards the simulator renders (quad/sim/station_calibration.h),
  // unless it is given a calibration file; a scenario's `calibration_focal_error` then scales its focal
  // lengths (fault campaign).
  std::string calib = options.calibration_file;
  if (calib.empty()) {
    const std::string cache = options.calibration_cache.empty()
                                  ? default_station_calibration_cache(station_argv, out_dir)
                                  : options.calibration_cache;
    calib = station_calibration_file(rig, scenario.camera, calibrate_command_for(station_argv), cache, options.progress);
  }
  if (scenario.camera.calibration_focal_error != 0.0) {
    write_focal_error_calibration(calib, out_dir + "/station_calib.yaml", scenario.camera.calibration_focal_error);
  } else {
    std::filesystem::copy_file(calib, out_dir + "/station_calib.yaml", std::filesystem::copy_options::overwrite_existing);
  }
  calib = out_dir + "/station_calib.yaml";
  const std::string settings = out_dir + "/station_settings.yaml";
  write_station_settings(settings, rig.left_mount, scenario.station_settings);
  for (const auto& [key, value] : scenario.station_settings)
    if (key == "send_covariance") expect_covariance_ = !(value == "0" || value == "false");

  std::vector<std::string> argv = station_argv;
  for (const std::string& a : {std::string("--calib"), calib, std::string("--settings"), settings, std::string("--source"),
                               "sim:" + station_.socket_path(), std::string("--out"), port_.slave_path(), std::string("--baud"),
                               std::to_string(scenario.radio_baud), std::string("--status-s"), std::string("10"),
                               // A slow simulator is not a stalled camera: a stall would reset the
                               // station's tracking and make its output depend on the wall clock.
                               std::string("--timeout-ms"), std::string("60000")})
    argv.push_back(a);
  station_.start(argv, out_dir + "/station.log");
}

void StationLoop::update(double t, const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool star_hidden,
                         const RadioSink& to_radio, const std::optional<Eigen::Vector2d>& decoy_ne) {
  while (!pending_.empty() && t + 1e-9 >= pending_.front().capture_t + s_.vision.latency_s) {
    collect(pending_.front(), to_radio);
    pending_.pop_front();
  }
  history_.push_back(Timed{t, VehiclePose{p_ned, q_ib}});
  while (history_.size() > 2 && history_[1].t < t - kHistoryS) history_.pop_front();
  if (t + 1e-9 < next_capture_t_) return;
  next_capture_t_ += 1.0 / s_.vision.rate_hz;
  const uint64_t sequence = next_sequence_++;
  ++figures_.pairs_captured;
  if (loss_rng_.bernoulli(s_.camera.frame_loss)) {
    ++figures_.pairs_lost;
    return;
  }
  renderer_.set_decoy(decoy_ne);
  renderer_.render([this](double when) { return pose_at(when); }, t, star_hidden, left_, right_);
  send_pair(sequence, t);
  pending_.push_back(Pending{sequence, t, star_in_body_frd(p_ned, q_ib)});
}

VehiclePose StationLoop::pose_at(double t) const {
  if (t <= history_.front().t) return history_.front().pose;
  for (size_t i = 1; i < history_.size(); ++i) {
    const Timed& a = history_[i - 1];
    const Timed& b = history_[i];
    if (t > b.t) continue;
    const double f = b.t > a.t ? (t - a.t) / (b.t - a.t) : 1.0;
    return VehiclePose{a.pose.p_ned + f * (b.pose.p_ned - a.pose.p_ned), a.pose.q_ib.slerp(f, b.pose.q_ib)};
  }
  return history_.back().pose;
}

void StationLoop::send_pair(uint64_t sequence, double t) {
  wire::FrameHeader header;
  header.width = static_cast<uint32_t>(left_.cols);
  header.height = static_cast<uint32_t>(left_.rows);
  header.sequence = sequence;
  header.capture_time_us = std::llround(t * 1e6);
  station_.send_all(&header, sizeof header, "a frame pair");
  station_.send_all(left_.data, left_.total(), "a frame pair");
  station_.send_all(right_.data, right_.total(), "a frame pair");
}

void StationLoop::collect(const Pending& pending, const RadioSink& to_radio) {
  wire::FrameAnswer answer;
  station_.read_exact(&answer, sizeof answer, "its answer");
  if (answer.magic != wire::kAnswerMagic || answer.sequence != pending.sequence)
    throw StationError("the vision station answered pair " + std::to_string(answer.sequence) + ", expected " +
                       std::to_string(pending.sequence));
  ++figures_.pairs_answered;
  figures_.processing_us.push_back(answer.processing_us);
  if (answer.processing_us > s_.vision.latency_s * 1e6) ++figures_.late_answers;
  // The answer follows the station's write to its port; the pty may hand the bytes over a little later.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(StationChannel::kAnswerTimeoutMs);
  while (frames_read_ < answer.fixes_sent || (expect_covariance_ && covariances_read_ < answer.fixes_sent)) {
    if (!port_.wait_readable(100)) {
      if (std::chrono::steady_clock::now() > deadline)
        throw StationError("the vision station reported a fix that did not arrive on its radio port");
      continue;
    }
    uint8_t buf[1024];
    for (size_t n; (n = port_.read_some(buf, sizeof buf)) > 0;)
      parser_.feed(buf, n, [&](const mav::Frame& f) {
        frames_.emplace_back(f.bytes, f.bytes + f.size);
        if (f.message_id == mav::LandingTarget::kId) ++frames_read_;
        if (f.message_id == mav::LandingTargetCovariance::kId) ++covariances_read_;
      });
  }
  // Release this pair's output only (a later pair's fix may already be in the pty): its fix and the
  // frames that follow it up to the next fix (its LANDING_TARGET_COVARIANCE).
  const double release_t = pending.capture_t + s_.vision.latency_s;
  auto is_fix = [](const std::vector<uint8_t>& bytes) {
    bool fix = false;
    mav::Parser check;
    check.feed(bytes.data(), bytes.size(), [&](const mav::Frame& f) { fix = f.message_id == mav::LandingTarget::kId; });
    return fix;
  };
  auto is_covariance = [](const std::vector<uint8_t>& bytes) {
    bool cov = false;
    mav::Parser check{mav::dialect_message_info};
    check.feed(bytes.data(), bytes.size(),
               [&](const mav::Frame& f) { cov = f.message_id == mav::LandingTargetCovariance::kId; });
    return cov;
  };
  while (!frames_.empty() && (figures_.fixes < answer.fixes_sent || !is_fix(frames_.front()))) {
    const std::vector<uint8_t> bytes = std::move(frames_.front());
    frames_.pop_front();
    mav::Parser check;
    check.feed(bytes.data(), bytes.size(), [&](const mav::Frame& f) {
      mav::LandingTarget lt;
      if (!mav::decode(f, lt)) return;
      ++figures_.fixes;
      figures_.fix_error_m.push_back((Eigen::Vector3d(lt.x, lt.y, lt.z) - pending.star_body_frd).norm());
    });
    if (is_covariance(bytes)) ++figures_.covariances;
    to_radio(release_t, bytes.data(), bytes.size());
  }
}

}  // namespace quad::sim
