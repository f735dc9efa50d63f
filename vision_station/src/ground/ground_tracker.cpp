#include "quad/vision/ground/ground_tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <numeric>
#include <stdexcept>

#include <time.h>

#include <opencv2/calib3d.hpp>

namespace quad::vision::ground {

void AssociationStats::add(const AssociationStats& o) {
  detections += o.detections;
  assigned += o.assigned;
  ambiguous_gates += o.ambiguous_gates;
  epipolar_resolutions += o.epipolar_resolutions;
  nn_disagreements += o.nn_disagreements;
  roi_searches += o.roi_searches;
  full_searches += o.full_searches;
}

namespace {

constexpr double kVelocitySpanS = 0.2;  // a velocity from two poses at most this far apart (six frame sets at 30 Hz)
constexpr double kMoveOnS = 0.5;        // a lost vehicle's pose is carried on for at most this long

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

cv::Matx33d yaw_rotation(double yaw) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  return cv::Matx33d(c, -s, 0, s, c, 0, 0, 0, 1);
}

cv::Point2d project(const RoomCamera& camera, const cv::Vec3d& ned) {
  cv::Vec3d rvec;
  cv::Rodrigues(camera.R_CI, rvec);
  std::vector<cv::Point2d> out;
  cv::projectPoints(std::vector<cv::Point3d>{cv::Point3d(ned)}, rvec, camera.t_CI, camera.K, camera.D, out);
  return out[0];
}

cv::Point2d undistort_one(const RoomCamera& camera, const cv::Point2d& pixel) {
  return camera.undistort({pixel})[0];
}

// Distance (px) of an undistorted pixel from the epipolar line F·x of another camera's pixel.
double epipolar_distance(const cv::Matx33d& F, const cv::Point2d& from, const cv::Point2d& to) {
  const cv::Vec3d line = F * cv::Vec3d(from.x, from.y, 1.0);  // seed 003 eq. 3.3: x'ᵀ F x = 0
  return std::abs(line.dot(cv::Vec3d(to.x, to.y, 1.0))) / std::hypot(line[0], line[1]);
}

cv::Vec3d read_vec3(const cv::FileNode& node, const std::string& path, const std::string& key) {
  if (node.empty() || !node.isSeq() || node.size() != 3) {
    throw std::runtime_error(path + ": key '" + key + "' must be a list of 3 numbers");
  }
  cv::Vec3d v;
  for (int i = 0; i < 3; ++i) {
    if (!node[i].isReal() && !node[i].isInt()) throw std::runtime_error(path + ": key '" + key + "' has a non-number");
    v[i] = static_cast<double>(node[i]);
  }
  return v;
}

}  // namespace

TrackerConfig load_tracker_config(const std::string& path) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception&) {
    throw std::runtime_error(path + ": not a readable OpenCV YAML file");
  }
  if (!fs.isOpened()) throw std::runtime_error(path + ": cannot open");
  TrackerConfig config;
  for (int k = 0; k < kMarkerColours; ++k) {
    const std::string key = std::string("marker_") + colour_name(static_cast<MarkerColour>(k));
    config.marker_frd[k] = read_vec3(fs[key], path, key);
  }
  const cv::FileNode vehicles = fs["vehicles"];
  if (vehicles.empty() || !vehicles.isSeq() || vehicles.size() == 0) {
    throw std::runtime_error(path + ": key 'vehicles' must be a non-empty list of {id, ned, yaw_deg}");
  }
  for (size_t i = 0; i < vehicles.size(); ++i) {
    const cv::FileNode v = vehicles[static_cast<int>(i)];
    const std::string key = "vehicles[" + std::to_string(i) + "]";
    if (!v["id"].isInt()) throw std::runtime_error(path + ": key '" + key + ".id' must be an integer");
    if (!v["yaw_deg"].isReal() && !v["yaw_deg"].isInt()) {
      throw std::runtime_error(path + ": key '" + key + ".yaw_deg' must be a number");
    }
    VehicleStart start;
    start.id = static_cast<int>(v["id"]);
    start.ned = read_vec3(v["ned"], path, key + ".ned");
    start.yaw_rad = static_cast<double>(v["yaw_deg"]) * CV_PI / 180.0;
    for (int k = 0; k < kMarkerColours; ++k) {
      const std::string marker = std::string("marker_") + colour_name(static_cast<MarkerColour>(k));
      start.marker_frd[k] = v[marker].empty() ? config.marker_frd[k] : read_vec3(v[marker], path, key + "." + marker);
    }
    config.vehicles.push_back(start);
  }
  return config;
}

// A group of tracks and detections of one colour in one camera linked by shared gates.
struct GroundTracker::Gate {
  int camera = 0;
  int colour = 0;
  std::vector<int> vehicles;
  std::vector<int> blobs;  // indices into that camera's blobs
};

GroundTracker::GroundTracker(RoomRig rig, TrackerConfig config, GroundTrackerSettings settings)
    : rig_(std::move(rig)), config_(std::move(config)), settings_(settings) {
  const size_t cameras = rig_.cameras.size();
  if (cameras < 2) throw std::invalid_argument("GroundTracker: at least two cameras");
  fundamental_.assign(cameras, std::vector<cv::Matx33d>(cameras));
  for (size_t a = 0; a < cameras; ++a) {
    projection_.push_back(rig_.cameras[a].projection());
    for (size_t b = 0; b < cameras; ++b) {
      if (a != b) fundamental_[a][b] = fundamental(rig_.cameras[a], rig_.cameras[b]);
    }
  }
  const size_t n = config_.vehicles.size();
  tracks_.assign(cameras, std::vector<std::array<ImageTrack, kMarkerColours>>(n));
  assigned_.assign(cameras, std::vector<std::array<int, kMarkerColours>>(n));
  shared_.assign(cameras, std::vector<std::array<bool, kMarkerColours>>(n));
  last_pose_.assign(n, std::nullopt);
  last_pose_time_us_.assign(n, 0);
  last_velocity_ned_.assign(n, cv::Vec3d(0.0, 0.0, 0.0));
  // Seed 003 sec. 3.3.1: each marker's initial position is known.
  for (size_t v = 0; v < n; ++v) {
    const VehicleStart& start = config_.vehicles[v];
    for (size_t c = 0; c < cameras; ++c) {
      for (int k = 0; k < kMarkerColours; ++k) {
        const cv::Vec3d p = start.ned + yaw_rotation(start.yaw_rad) * start.marker_frd[k];
        tracks_[c][v][k].reset(project(rig_.cameras[c], p), 10.0);
      }
    }
  }
}

void GroundTracker::predict_tracks(double dt) {
  for (size_t c = 0; c < tracks_.size(); ++c) {
    for (size_t v = 0; v < tracks_[c].size(); ++v) {
      for (int k = 0; k < kMarkerColours; ++k) {
        ImageTrack& track = tracks_[c][v][k];
        // A track lost for a while restarts from the vehicle's last pose, projected (its image
        // velocity is unknown after an occlusion).
        if (track.missed >= settings_.reseed_after_missed && last_pose_[v]) {
          const int missed = track.missed;
          const RigidPose& pose = *last_pose_[v];
          track.reset(project(rig_.cameras[c], pose.position_ned + pose.R_IB * config_.vehicles[v].marker_frd[k]), 8.0);
          track.missed = missed;
        }
        track.predict(dt, settings_.noise);
      }
    }
  }
}

std::vector<MarkerBlob> GroundTracker::search(int camera, const cv::Mat& image, AssociationStats& stats) {
  bool all_held = settings_.use_roi && last_time_us_.has_value();
  for (const auto& vehicle : tracks_[camera]) {
    for (const ImageTrack& track : vehicle) all_held = all_held && track.missed == 0;
  }
  if (!all_held) {
    ++stats.full_searches;
    return detect_markers(image, settings_.colours);
  }
  // Seed 003 sec. 3.2: a small rectangle around each track's predicted centre.
  ++stats.roi_searches;
  std::vector<MarkerBlob> blobs;
  for (const auto& vehicle : tracks_[camera]) {
    for (int k = 0; k < kMarkerColours; ++k) {
      const ImageTrack& track = vehicle[k];
      const double gate_px = std::sqrt(settings_.gate_chi2) *
                             std::hypot(track.position_sigma_px(), settings_.noise.measurement_px);
      const int half = std::max(settings_.roi_min_half_px, static_cast<int>(std::ceil(gate_px)) + 16);
      const cv::Point2d p = track.predicted();
      const cv::Rect roi(static_cast<int>(p.x) - half, static_cast<int>(p.y) - half, 2 * half, 2 * half);
      for (const MarkerBlob& blob : detect_markers(image, settings_.colours, roi)) {
        if (blob.touches_border) continue;
        const bool seen = std::any_of(blobs.begin(), blobs.end(), [&](const MarkerBlob& b) {
          return b.colour == blob.colour && cv::norm(b.centre - blob.centre) < 1.5;
        });
        if (!seen) blobs.push_back(blob);
      }
    }
  }
  return blobs;
}

FrameSetResult GroundTracker::process(const std::vector<cv::Mat>& images, int64_t time_us) {
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = thread_cpu_ms();
  if (images.size() != rig_.cameras.size()) {
    throw std::invalid_argument("GroundTracker: " + std::to_string(images.size()) + " images for " +
                                std::to_string(rig_.cameras.size()) + " cameras");
  }
  FrameSetResult result;
  const double dt = last_time_us_ ? (time_us - *last_time_us_) * 1e-6 : 0.0;
  predict_tracks(dt);
  std::vector<std::vector<MarkerBlob>> blobs(images.size());
  for (size_t c = 0; c < images.size(); ++c) {
    if (images[c].size() != rig_.cameras[c].image_size) {
      throw std::invalid_argument("GroundTracker: camera " + std::to_string(c) + " image size differs from its calibration");
    }
    blobs[c] = search(static_cast<int>(c), images[c], result.stats);
    result.stats.detections += static_cast<int>(blobs[c].size());
  }
  last_time_us_ = time_us;
  for (const VehicleStart& v : config_.vehicles) {
    VehicleFix fix;
    fix.id = v.id;
    fix.time_us = time_us;
    for (auto& per_camera : fix.pixels) per_camera.assign(images.size(), std::nullopt);
    result.vehicles.push_back(fix);
  }
  associate(blobs, result);
  estimate_poses(blobs, time_us, result);
  totals_.add(result.stats);
  result.processing_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  result.cpu_ms = thread_cpu_ms() - cpu_start;
  return result;
}

void GroundTracker::associate(const std::vector<std::vector<MarkerBlob>>& blobs, FrameSetResult& result) {
  const int nv = static_cast<int>(config_.vehicles.size());
  std::vector<Gate> ambiguous;
  for (size_t c = 0; c < blobs.size(); ++c) {
    for (auto& a : assigned_[c]) a.fill(-1);
    for (auto& a : shared_[c]) a.fill(false);
    for (int k = 0; k < kMarkerColours; ++k) {
      // Gate graph of this colour: vehicle v and blob b linked when b is inside v's gate.
      std::vector<int> candidates;
      for (int b = 0; b < static_cast<int>(blobs[c].size()); ++b) {
        if (static_cast<int>(blobs[c][b].colour) == k) candidates.push_back(b);
      }
      std::vector<int> group(nv + candidates.size());
      std::iota(group.begin(), group.end(), 0);
      std::function<int(int)> root = [&](int i) { return group[i] == i ? i : group[i] = root(group[i]); };
      std::vector<bool> linked(group.size(), false);
      for (int v = 0; v < nv; ++v) {
        for (size_t j = 0; j < candidates.size(); ++j) {
          if (tracks_[c][v][k].mahalanobis2(blobs[c][candidates[j]].centre, settings_.noise) <= settings_.gate_chi2) {
            group[root(v)] = root(nv + static_cast<int>(j));
            linked[v] = linked[nv + j] = true;
          }
        }
      }
      std::vector<Gate> gates;
      for (int i = 0; i < static_cast<int>(group.size()); ++i) {
        if (!linked[i]) continue;
        const int r = root(i);
        auto it = std::find_if(gates.begin(), gates.end(), [&](const Gate& g) {
          return root(g.vehicles.empty() ? nv + g.blobs[0] : g.vehicles[0]) == r;
        });
        if (it == gates.end()) {
          gates.push_back(Gate{static_cast<int>(c), k, {}, {}});
          it = gates.end() - 1;
        }
        if (i < nv) {
          it->vehicles.push_back(i);
        } else {
          it->blobs.push_back(i - nv);
        }
      }
      // A gate's blob indices are local to the candidates of this colour: map them to the camera's blobs.
      for (Gate& g : gates) {
        for (int& b : g.blobs) b = candidates[b];
        if (g.vehicles.size() == 1 && g.blobs.size() == 1) {
          assigned_[c][g.vehicles[0]][k] = g.blobs[0];  // seed 003 sec. 3.3.1: nearest neighbour, no ambiguity
        } else {
          ambiguous.push_back(g);
        }
      }
    }
  }
  // Seed 003 sec. 3.3.2: overlapping gates are settled with the other cameras' associations. Gates whose
  // vehicles all have a partner view go first, so that their result can serve the others.
  auto has_partners = [&](const Gate& g) {
    for (int v : g.vehicles) {
      bool any = false;
      for (size_t o = 0; o < blobs.size(); ++o) any = any || (static_cast<int>(o) != g.camera && assigned_[o][v][g.colour] >= 0);
      if (!any) return false;
    }
    return true;
  };
  std::stable_sort(ambiguous.begin(), ambiguous.end(),
                   [&](const Gate& a, const Gate& b) { return has_partners(a) && !has_partners(b); });
  for (const Gate& g : ambiguous) resolve(g, blobs, result);

  for (size_t c = 0; c < blobs.size(); ++c) {
    for (int v = 0; v < nv; ++v) {
      for (int k = 0; k < kMarkerColours; ++k) {
        ImageTrack& track = tracks_[c][v][k];
        const int b = assigned_[c][v][k];
        if (b < 0) {
          ++track.missed;
          continue;
        }
        if (track.missed > 0) shared_[c][v][k] = true;  // re-acquired after a loss: as unconfirmed as a shared gate
        track.update(blobs[c][b].centre, settings_.noise);
        result.vehicles[v].pixels[k][c] = blobs[c][b].centre;
        ++result.stats.assigned;
      }
    }
  }
}

void GroundTracker::resolve(const Gate& g, const std::vector<std::vector<MarkerBlob>>& blobs, FrameSetResult& result) {
  const int nt = static_cast<int>(g.vehicles.size()), nb = static_cast<int>(g.blobs.size());
  const RoomCamera& camera = rig_.cameras[g.camera];
  // Costs: squared Mahalanobis distance, plus the squared epipolar distances (in units of their sigma)
  // from the same vehicle's same-colour marker in each other camera.
  std::vector<std::vector<double>> nn(nt, std::vector<double>(nb)), epi(nt, std::vector<double>(nb, 0.0));
  bool evidence = false;
  for (int t = 0; t < nt; ++t) {
    const int v = g.vehicles[t];
    for (int b = 0; b < nb; ++b) {
      const cv::Point2d pixel = blobs[g.camera][g.blobs[b]].centre;
      nn[t][b] = tracks_[g.camera][v][g.colour].mahalanobis2(pixel, settings_.noise);
      if (!settings_.use_epipolar) continue;
      const cv::Point2d here = undistort_one(camera, pixel);
      for (size_t o = 0; o < blobs.size(); ++o) {
        const int ob = static_cast<int>(o) == g.camera ? -1 : assigned_[o][v][g.colour];
        if (ob < 0) continue;
        const cv::Point2d there = undistort_one(rig_.cameras[o], blobs[o][ob].centre);
        const double d = epipolar_distance(fundamental_[o][g.camera], there, here) / settings_.epipolar_sigma_px;
        epi[t][b] += d * d;
        evidence = true;
      }
    }
  }
  // Best one-to-one assignment (a track may stay without a detection at the cost of a full gate).
  const double miss = settings_.gate_chi2;
  auto best = [&](bool with_epipolar) {
    std::vector<int> choice(nt, -1), current(nt, -1);
    std::vector<bool> used(nb, false);
    double best_cost = std::numeric_limits<double>::infinity();
    std::function<void(int, double)> search = [&](int t, double cost) {
      if (cost >= best_cost) return;
      if (t == nt) {
        best_cost = cost;
        choice = current;
        return;
      }
      current[t] = -1;
      search(t + 1, cost + miss + (with_epipolar && evidence ? miss : 0.0));
      for (int b = 0; b < nb; ++b) {
        if (used[b] || nn[t][b] > settings_.gate_chi2) continue;
        used[b] = true;
        current[t] = b;
        search(t + 1, cost + nn[t][b] + (with_epipolar ? epi[t][b] : 0.0));
        used[b] = false;
      }
      current[t] = -1;
    };
    search(0, 0.0);
    return choice;
  };
  const std::vector<int> chosen = best(true);
  ++result.stats.ambiguous_gates;
  const bool used_epipolar = settings_.use_epipolar && evidence;
  if (used_epipolar) {
    ++result.stats.epipolar_resolutions;
    if (best(false) != chosen) ++result.stats.nn_disagreements;
  }
  for (int t = 0; t < nt; ++t) {
    const int v = g.vehicles[t];
    ++result.vehicles[v].ambiguous_gates;
    if (used_epipolar) ++result.vehicles[v].epipolar_resolutions;
    assigned_[g.camera][v][g.colour] = chosen[t] < 0 ? -1 : g.blobs[chosen[t]];
    shared_[g.camera][v][g.colour] = true;
  }
}

// The pose from the triangulated markers; with trusted_only, from detections assigned without a shared
// gate alone (nullopt when those give fewer than three markers).
std::optional<RigidPose> GroundTracker::fit_pose(size_t v, VehicleFix& fix, bool trusted_only) const {
  std::vector<cv::Vec3d> body;
  std::vector<TriangulatedPoint> points;
  for (int k = 0; k < kMarkerColours; ++k) {
    std::vector<PixelObservation> views;
    for (size_t c = 0; c < rig_.cameras.size(); ++c) {
      if (fix.pixels[k][c] && !(trusted_only && shared_[c][v][k]))
        views.push_back({projection_[c], undistort_one(rig_.cameras[c], *fix.pixels[k][c])});
    }
    const auto point = triangulate(views, settings_.pixel_sigma_px);
    if (!point || point->reprojection_rms_px > settings_.max_reprojection_px) continue;
    body.push_back(config_.vehicles[v].marker_frd[k]);
    points.push_back(*point);
  }
  if (!trusted_only) fix.markers = static_cast<int>(points.size());
  return fit_rigid_pose(body, points);
}

void GroundTracker::estimate_poses(const std::vector<std::vector<MarkerBlob>>& blobs, int64_t time_us,
                                   FrameSetResult& result) {
  // Each vehicle's pose to check its detections against: from the detections not taken in a shared gate
  // (nor re-acquired) when those give one, since a blob merged with another vehicle's ball pulls a pose
  // fitted with it towards itself; else from all. Its neighbours are checked against that pose and its
  // last one carried on to this frame set (this frame set's own, once it has one).
  const size_t n = result.vehicles.size();
  std::vector<std::optional<RigidPose>> check(n), moved_on(n);
  for (size_t v = 0; v < n; ++v) {
    check[v] = fit_pose(v, result.vehicles[v], true);
    if (!check[v]) check[v] = fit_pose(v, result.vehicles[v], false);
    if (last_pose_[v]) moved_on[v] = pose_moved_on(v, time_us);
  }
  for (size_t v = 0; v < n; ++v) {
    VehicleFix& fix = result.vehicles[v];
    if (check[v]) disown_stray_detections(v, *check[v], {check, moved_on}, blobs, fix);
    fix.pose = fit_pose(v, fix, false);
    if (fix.pose) {
      remember_pose(v, *fix.pose, time_us);
      moved_on[v] = fix.pose;
      continue;
    }
    // No pose to confirm them: detections from shared gates or re-acquired after a loss are not reported,
    // and their tracks count a miss (restarted from the last pose after reseed_after_missed).
    for (int k = 0; k < kMarkerColours; ++k)
      for (size_t c = 0; c < rig_.cameras.size(); ++c)
        if (fix.pixels[k][c] && shared_[c][v][k]) {
          fix.pixels[k][c].reset();
          ++tracks_[c][v][k].missed;
          ++fix.disowned;
        }
  }
}

void GroundTracker::remember_pose(size_t v, const RigidPose& pose, int64_t time_us) {
  const double dt = (time_us - last_pose_time_us_[v]) * 1e-6;
  const bool recent = last_pose_[v] && dt > 0.0 && dt <= kVelocitySpanS;
  last_velocity_ned_[v] = recent ? (pose.position_ned - last_pose_[v]->position_ned) / dt : cv::Vec3d(0.0, 0.0, 0.0);
  last_pose_[v] = pose;
  last_pose_time_us_[v] = time_us;
}

// The vehicle's last pose carried on at its last velocity to time_us, for at most kMoveOnS: where its
// markers are while its own detections give no pose (a vehicle crossing at 1 m/s moves 3 cm a frame).
RigidPose GroundTracker::pose_moved_on(size_t v, int64_t time_us) const {
  RigidPose pose = *last_pose_[v];
  const double dt = std::clamp((time_us - last_pose_time_us_[v]) * 1e-6, 0.0, kMoveOnS);
  pose.position_ned += last_velocity_ned_[v] * dt;
  return pose;
}

// A detection that is not clearly nearer its own marker under the vehicle's pose than another vehicle's
// marker of that colour, by pose_check_px, went to the wrong track or is shared: a same-colour ball taken
// in a shared gate, then followed, or a blob merged with it. So is one with another vehicle's marker of
// that colour inside the blob's diameter: the two balls overlap in that image, and the blob is the other
// ball, or ours merged with it or partly hidden by it. Each other vehicle's marker is taken under all its
// poses in `neighbours` (its pose of this frame set and its last pose carried on), since a pose fitted
// with a stray detection of its own can lie tens of pixels off, and a vehicle hidden in a crossing has
// none. The detection is removed from the fix and the track restarts at the expected pixel, its next
// detection a re-acquisition. Off its marker alone is not enough: frames of free-running cameras put a
// moving vehicle's markers a few pixels off its pose.
void GroundTracker::disown_stray_detections(size_t v, const RigidPose& pose, const NeighbourPoses& neighbours,
                                            const std::vector<std::vector<MarkerBlob>>& blobs, VehicleFix& fix) {
  for (int k = 0; k < kMarkerColours; ++k) {
    const cv::Vec3d marker = pose.position_ned + pose.R_IB * config_.vehicles[v].marker_frd[k];
    for (size_t c = 0; c < rig_.cameras.size(); ++c) {
      if (!fix.pixels[k][c]) continue;
      const cv::Point2d pixel = *fix.pixels[k][c];
      const cv::Point2d expected = project(rig_.cameras[c], marker);
      const double own = cv::norm(pixel - expected);
      const int b = assigned_[c][v][k];
      const double diameter = b < 0 ? 0.0 : 2.0 * std::sqrt(blobs[c][static_cast<size_t>(b)].area_px / CV_PI);
      auto near_theirs = [&](size_t o, const std::optional<RigidPose>& other) {
        if (!other) return false;
        const cv::Vec3d theirs = other->position_ned + other->R_IB * config_.vehicles[o].marker_frd[k];
        const double d = cv::norm(pixel - project(rig_.cameras[c], theirs));
        return d < own + settings_.pose_check_px || d < diameter;
      };
      bool nearer_other = false;
      for (size_t o = 0; o < neighbours.this_set.size() && !nearer_other; ++o) {
        if (o != v) nearer_other = near_theirs(o, neighbours.this_set[o]) || near_theirs(o, neighbours.moved_on[o]);
      }
      if (!nearer_other) continue;
      fix.pixels[k][c].reset();
      tracks_[c][v][k].reset(expected, 8.0);
      tracks_[c][v][k].missed = 1;  // its next detection is a re-acquisition, to be confirmed
      ++fix.disowned;
    }
  }
}

}  // namespace quad::vision::ground
