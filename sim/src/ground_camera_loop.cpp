#include "quad/sim/ground_camera_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <thread>

#include <opencv2/core/persistence.hpp>

#include "quad/sim/ground_camera_calibration.h"
#include "quad/vision/ground/ground_sim_protocol.h"

namespace quad::sim {
namespace wire = quad::vision::ground_sim_protocol;
namespace mav = quad::mavlink;

namespace {

constexpr double kAssociationSlackPx = 3.0;  // a detection may sit this far beyond its ball's image radius
constexpr double kVisibleEnough = 0.3;       // another vehicle's ball counts as a rival when this much shows

double yaw_of(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d R = q.toRotationMatrix();
  return std::atan2(R(1, 0), R(0, 0));
}

}  // namespace

Json ground_station_json(const GroundCameraFigures& f, const GroundCameraParams& p) {
  Json j;
  j.add("trigger", p.triggered ? "together" : "free").add("cameras", static_cast<long>(p.count));
  j.add("sets_captured", static_cast<long>(f.sets_captured)).add("sets_lost", static_cast<long>(f.sets_lost));
  j.add("sets_answered", static_cast<long>(f.sets_answered)).add("fixes", static_cast<long>(f.fixes));
  j.add("capture_skew_us", percentiles_json(f.capture_skew_us));
  j.add("fix_error_m", percentiles_json(f.fix_error_m));
  j.add("fix_latency_s", percentiles_json(f.fix_latency_s));
  j.add("processing_us", percentiles_json(f.processing_us)).add("cpu_us", percentiles_json(f.cpu_us));
  j.add("configured_latency_s", p.latency_s).add("late_answers", static_cast<long>(f.late_answers));
  j.add("pixels_checked", static_cast<long>(f.pixels_checked)).add("association_errors", static_cast<long>(f.association_errors));
  j.add("ambiguous_sets", static_cast<long>(f.ambiguous_sets)).add("epipolar_sets", static_cast<long>(f.epipolar_sets));
  j.add("ambiguous_gates", static_cast<long>(f.ambiguous_gates)).add("epipolar_resolutions", static_cast<long>(f.epipolar_resolutions));
  return j;
}

Json ground_vehicle_json(const GroundVehicleFigures& f) {
  Json j;
  j.add("fixes", static_cast<long>(f.fixes)).add("fix_error_m", percentiles_json(f.fix_error_m));
  j.add("fix_latency_s", percentiles_json(f.fix_latency_s));
  j.add("pixels_checked", static_cast<long>(f.pixels_checked)).add("association_errors", static_cast<long>(f.association_errors));
  j.add("ambiguous_sets", static_cast<long>(f.ambiguous_sets)).add("ambiguous_gates", static_cast<long>(f.ambiguous_gates));
  j.add("epipolar_resolutions", static_cast<long>(f.epipolar_resolutions));
  return j;
}

void write_ground_vehicles_file(const std::string& path, const std::vector<MarkedVehicle>& start) {
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw StationError(path + ": cannot write the ground station's vehicles file");
  const char* names[kMarkerColourCount] = {"marker_red", "marker_green", "marker_blue", "marker_yellow"};
  for (int k = 0; k < kMarkerColourCount; ++k) {
    const Eigen::Vector3d& m = start.front().markers_frd[static_cast<size_t>(k)];
    fs << names[k] << "[:" << m.x() << m.y() << m.z() << "]";
  }
  fs << "vehicles" << "[";
  for (const MarkedVehicle& v : start) {
    fs << "{" << "id" << v.id << "ned" << "[:" << v.p_ned.x() << v.p_ned.y() << v.p_ned.z() << "]" << "yaw_deg"
       << yaw_of(v.q_ib) * 180.0 / M_PI;
    for (int k = 0; k < kMarkerColourCount; ++k) {
      const Eigen::Vector3d& m = v.markers_frd[static_cast<size_t>(k)];
      fs << names[k] << "[:" << m.x() << m.y() << m.z() << "]";
    }
    fs << "}";
  }
  fs << "]";
}

GroundCameraLoop::GroundCameraLoop(const GroundCameraParams& params, uint64_t seed, int radio_baud,
                                   const std::vector<MarkedVehicle>& start, const std::string& out_dir,
                                   const std::vector<std::string>& station_argv, const GroundCameraLoopOptions& options)
    : p_(params),
      renderer_(params, ground_cameras_from(params), Rng(seed, "ground_cameras")),
      loss_rng_(seed, "ground_frame_loss"),
      station_("ground station", "quad_sim_ground"),
      next_frame_(static_cast<size_t>(params.count), 0),
      images_(static_cast<size_t>(params.count)) {
  if (start.empty()) throw StationError("ground cameras: no vehicle to watch");
  std::string room = options.room_file;
  if (room.empty()) {
    const std::string cache =
        options.room_cache.empty() ? default_station_calibration_cache(station_argv, out_dir) : options.room_cache;
    room = room_calibration_file(p_, station_subcommand(station_argv, "calibrate-room"), cache, options.progress);
  }
  std::filesystem::copy_file(room, out_dir + "/room_calib.yaml", std::filesystem::copy_options::overwrite_existing);
  write_ground_vehicles_file(out_dir + "/ground_vehicles.yaml", start);
  std::string radio;
  for (const MarkedVehicle& v : start) {
    ids_.push_back(v.id);
    Link& link = links_[v.id];
    link.port = std::make_unique<Pty>(radio_baud);
    radio += (radio.empty() ? "" : ",") + std::to_string(v.id) + "=" + link.port->slave_path();
  }

  std::vector<std::string> argv = station_subcommand(station_argv, "track");
  for (const std::string& a :
       {std::string("--room"), out_dir + "/room_calib.yaml", std::string("--vehicles"), out_dir + "/ground_vehicles.yaml",
        std::string("--source"), "sim:" + station_.socket_path(), std::string("--radio"), radio, std::string("--baud"),
        std::to_string(radio_baud), std::string("--message"), std::string(ground_fix_message_name(p_.message)),
        std::string("--out"), out_dir + "/ground_track.jsonl", std::string("--status-s"), std::string("10"),
        std::string("--timeout-ms"), std::string("10000")})
    argv.push_back(a);
  station_.start(argv, out_dir + "/ground_station.log");
  filling_.sequence = 0;
}

double GroundCameraLoop::capture_time(size_t camera, uint64_t n) const {
  const double period = 1.0 / p_.rate_hz;
  if (p_.triggered) return n * period;
  const double phase = camera < p_.phase_s.size() ? p_.phase_s[camera] : camera * period / p_.count;
  return phase + n * period;
}

void GroundCameraLoop::update(double t, const std::vector<MarkedVehicle>& vehicles, const RadioSink& to_radio) {
  while (!pending_.empty() && t + 1e-9 >= pending_.front().complete_t + p_.latency_s) {
    collect(pending_.front(), to_radio);
    pending_.pop_front();
  }
  bool complete = true;
  for (size_t k = 0; k < next_frame_.size(); ++k) {
    if (next_frame_[k] == filling_.sequence && t + 1e-9 >= capture_time(k, filling_.sequence)) capture(k, t, vehicles);
    complete = complete && next_frame_[k] > filling_.sequence;
  }
  if (!complete) return;
  filling_.complete_t = t;
  ++figures_.sets_captured;
  if (filling_.lost) {
    ++figures_.sets_lost;
  } else {
    for (Eigen::Vector3d& p : filling_.truth_ned) p /= static_cast<double>(p_.count);
    send_set(filling_);
    pending_.push_back(std::move(filling_));
  }
  filling_ = Pending{};
  filling_.sequence = ++next_set_;
}

void GroundCameraLoop::capture(size_t camera, double t, const std::vector<MarkedVehicle>& vehicles) {
  const bool first = std::all_of(next_frame_.begin(), next_frame_.end(), [&](uint64_t n) { return n == filling_.sequence; });
  if (first) {
    filling_.lost = loss_rng_.bernoulli(p_.frame_loss);
    filling_.capture_us.assign(next_frame_.size(), 0);
    filling_.views.assign(next_frame_.size(), {});
    filling_.truth_ned.assign(vehicles.size(), Eigen::Vector3d::Zero());
  }
  ++next_frame_[camera];
  filling_.capture_us[camera] = std::llround(t * 1e6);
  for (size_t i = 0; i < vehicles.size() && i < filling_.truth_ned.size(); ++i) filling_.truth_ned[i] += vehicles[i].p_ned;
  if (filling_.lost) return;
  renderer_.render(camera, vehicles, t, images_[camera], &filling_.views[camera]);
}

void GroundCameraLoop::send_set(const Pending& set) {
  wire::SetHeader header;
  header.cameras = static_cast<uint32_t>(images_.size());
  header.width = static_cast<uint32_t>(p_.image_width);
  header.height = static_cast<uint32_t>(p_.image_height);
  header.sequence = set.sequence;
  int64_t lo = set.capture_us.front(), hi = lo;
  for (size_t k = 0; k < set.capture_us.size(); ++k) {
    header.capture_time_us[k] = set.capture_us[k];
    lo = std::min(lo, set.capture_us[k]);
    hi = std::max(hi, set.capture_us[k]);
  }
  figures_.capture_skew_us.push_back(static_cast<double>(hi - lo));
  station_.send_all(&header, sizeof header, "a frame set");
  for (const cv::Mat& image : images_) station_.send_all(image.data, image.total() * image.elemSize(), "a frame set");
}

void GroundCameraLoop::collect(const Pending& set, const RadioSink& to_radio) {
  wire::SetAnswer answer;
  station_.read_exact(&answer, sizeof answer, "its answer");
  if (answer.magic != wire::kAnswerMagic || answer.sequence != set.sequence || answer.vehicles > 256)
    throw StationError("the ground station answered set " + std::to_string(answer.sequence) + ", expected " +
                       std::to_string(set.sequence));
  std::vector<wire::VehicleReport> reports(answer.vehicles);
  if (!reports.empty())
    station_.read_exact(reports.data(), reports.size() * sizeof(wire::VehicleReport), "its vehicle reports");
  ++figures_.sets_answered;
  figures_.processing_us.push_back(answer.processing_us);
  figures_.cpu_us.push_back(answer.cpu_us);
  if (answer.processing_us > p_.latency_s * 1e6) ++figures_.late_answers;
  // The fixes follow the station's writes to the ports; the ptys may hand the bytes over a little later.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(StationChannel::kAnswerTimeoutMs);
  while (frames_read_ < answer.fixes_sent) {
    bool any = false;
    for (auto& entry : links_) {
      auto& link = entry.second;  // a plain reference: C++17 lambdas cannot capture a structured binding
      uint8_t buf[1024];
      for (size_t n; (n = link.port->read_some(buf, sizeof buf)) > 0;) {
        any = true;
        link.parser.feed(buf, n, [&](const mav::Frame& f) {
          link.frames.emplace_back(f.bytes, f.bytes + f.size);
          ++frames_read_;
        });
      }
    }
    if (any) continue;
    if (std::chrono::steady_clock::now() > deadline)
      throw StationError("the ground station reported a fix that did not arrive on its radio port");
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  // Release this set's fixes only: one frame for each vehicle the set found.
  const double release_t = set.complete_t + p_.latency_s;
  bool ambiguous = false, epipolar = false;
  for (const wire::VehicleReport& r : reports) {
    GroundVehicleFigures& mine = figures_.per_vehicle[r.id];
    mine.ambiguous_gates += static_cast<uint64_t>(std::max(0, r.ambiguous_gates));
    mine.epipolar_resolutions += static_cast<uint64_t>(std::max(0, r.epipolar_resolutions));
    if (r.ambiguous_gates > 0) ++mine.ambiguous_sets;
    figures_.ambiguous_gates += static_cast<uint64_t>(std::max(0, r.ambiguous_gates));
    figures_.epipolar_resolutions += static_cast<uint64_t>(std::max(0, r.epipolar_resolutions));
    ambiguous = ambiguous || r.ambiguous_gates > 0;
    epipolar = epipolar || r.epipolar_resolutions > 0;
  }
  figures_.ambiguous_sets += ambiguous ? 1 : 0;
  figures_.epipolar_sets += epipolar ? 1 : 0;
  for (size_t i = 0; i < reports.size(); ++i) {
    const wire::VehicleReport& r = reports[i];
    const auto it = links_.find(r.id);
    if (!r.found || it == links_.end() || it->second.frames.empty()) continue;
    const std::vector<uint8_t> bytes = std::move(it->second.frames.front());
    it->second.frames.pop_front();
    ++figures_.fixes;
    ++figures_.fixes_per_vehicle[r.id];
    ++figures_.per_vehicle[r.id].fixes;
    const auto v = std::find(ids_.begin(), ids_.end(), r.id);
    if (v != ids_.end()) {
      const Eigen::Vector3d& truth = set.truth_ned[static_cast<size_t>(v - ids_.begin())];
      const double error = (Eigen::Vector3d(r.ned[0], r.ned[1], r.ned[2]) - truth).norm();
      figures_.fix_error_m.push_back(error);
      figures_.per_vehicle[r.id].fix_error_m.push_back(error);
    }
    to_radio(r.id, release_t, bytes.data(), bytes.size());
  }
  score(set, reports);
}

void GroundCameraLoop::score(const Pending& set, const std::vector<wire::VehicleReport>& reports) {
  // An associated detection is wrong when another vehicle's ball of that colour, showing, is nearer
  // to it than the vehicle's own, or when it lies off its own ball's image (a stray blob).
  for (const wire::VehicleReport& r : reports) {
    const auto v = std::find(ids_.begin(), ids_.end(), r.id);
    if (v == ids_.end()) continue;
    const size_t own = static_cast<size_t>(v - ids_.begin());
    for (size_t camera = 0; camera < set.views.size(); ++camera) {
      const MarkerViews& views = set.views[camera];
      for (int c = 0; c < kMarkerColourCount; ++c) {
        const float u = r.pixels[c][camera][0], w = r.pixels[c][camera][1];
        if (std::isnan(u) || std::isnan(w) || own >= views.size()) continue;
        ++figures_.pixels_checked;
        GroundVehicleFigures& mine_figures = figures_.per_vehicle[r.id];
        ++mine_figures.pixels_checked;
        const Eigen::Vector2d px(u, w);
        const MarkerView& mine = views[own][static_cast<size_t>(c)];
        const double d_own = (px - mine.pixel).norm();
        bool wrong = d_own > mine.radius_px + kAssociationSlackPx;
        for (size_t o = 0; o < views.size() && !wrong; ++o) {
          const MarkerView& other = views[o][static_cast<size_t>(c)];
          if (o != own && other.visible >= kVisibleEnough && (px - other.pixel).norm() < d_own) wrong = true;
        }
        if (wrong) {
          ++figures_.association_errors;
          ++mine_figures.association_errors;
        }
      }
    }
  }
}

void GroundCameraLoop::delivered(int vehicle_id, double t, const uint8_t* data, size_t length) {
  const auto it = links_.find(vehicle_id);
  if (it == links_.end()) return;
  it->second.delivered.feed(data, length, [&](const mav::Frame& f) {
    mav::VisionPositionEstimate m;
    if (f.message_id == mav::VisionPositionEstimate::kId && mav::decode(f, m)) {
      figures_.fix_latency_s.push_back(t - static_cast<double>(m.usec) * 1e-6);
      figures_.per_vehicle[vehicle_id].fix_latency_s.push_back(t - static_cast<double>(m.usec) * 1e-6);
    }
  });
}

}  // namespace quad::sim
