#include "quad/sim/fix_source.h"

#include <deque>
#include <map>
#include <stdexcept>

#include "quad/sim/ground_camera_loop.h"
#include "quad/sim/vision_fix.h"

namespace quad::sim {
namespace {

// The simulated onboard-star fix (vision_fix.h) of each vehicle it serves, each with its own noise
// stream (seeded by the scenario seed and the vehicle's name).
class SyntheticFixes final : public FixSource {
 public:
  SyntheticFixes(const Scenario& s, const std::vector<size_t>& served) {
    for (size_t i : served) {
      fixes_.emplace_back(i, SimulatedVisionFix(s.vision, Rng(s.seed, "vision/" + s.vehicles[i].name)));
    }
  }
  void update(double t, const std::vector<VehicleTruth>& fleet) override {
    for (auto& [i, fix] : fixes_) fix.update(t, fleet[i].position_ned, fleet[i].q_ib, false);
  }
  void release_until(double t, const FixSink& sink) override {
    for (auto& [i, fix] : fixes_) {
      const size_t vehicle = i;
      fix.release_until(t, [&](double when, const uint8_t* d, size_t n) { sink(vehicle, when, d, n); });
    }
  }
  uint64_t released(size_t vehicle) const override {
    for (const auto& [i, fix] : fixes_)
      if (i == vehicle) return fix.released();
    return 0;
  }

 private:
  std::vector<std::pair<size_t, SimulatedVisionFix>> fixes_;
};

// A vehicle as the room cameras see it: its pose, its system id and its marker layout (one ball per
// colour; the scenario checks the layout, scenario.cpp).
MarkedVehicle marked(const FleetVehicle& v, const VehicleTruth& truth) {
  static const char* const kColours[kMarkerColourCount] = {"red", "green", "blue", "yellow"};
  MarkedVehicle m;
  m.id = v.system_id;
  m.p_ned = truth.position_ned;
  m.q_ib = truth.q_ib;
  for (const Marker& marker : v.markers)
    for (int k = 0; k < kMarkerColourCount; ++k)
      if (marker.colour == kColours[k]) {
        m.markers_frd[static_cast<size_t>(k)] = marker.position_frd_m;
        m.marker_radius_m = marker.radius_m;
      }
  return m;
}

// The fixed room cameras (seed 003) seeing every vehicle of the fleet, the ground-camera station
// tracking all of them (`vision_station track`, ground_camera_loop.h) and each served vehicle's fix on
// that vehicle's own radio: one link per vehicle, as the firmware takes VISION_POSITION_ESTIMATE on
// its radio. Vehicles with another fix source are still drawn and tracked (they wear their markers) but
// get no ground-camera fix.
class GroundCameraFixes final : public FixSource {
 public:
  GroundCameraFixes(const Scenario& s, const std::vector<size_t>& served, const FixSourceContext& c)
      : s_(s), serves_(s.vehicles.size(), false), released_(s.vehicles.size(), 0) {
    if (c.station_argv.empty())
      throw std::runtime_error(s.path + ": fix_source ground_cameras needs the vision station command (--station)");
    if (c.start.size() != s.vehicles.size()) throw std::logic_error("GroundCameraFixes: the fleet's start poses are missing");
    for (size_t i : served) serves_[i] = true;
    for (size_t i = 0; i < s.vehicles.size(); ++i) {
      index_of_id_[s.vehicles[i].system_id] = i;
      marked_.push_back(marked(s.vehicles[i], c.start[i]));
    }
    GroundCameraLoopOptions o;
    o.room_file = c.room_calibration;
    o.room_cache = c.calibration_cache;
    o.progress = c.progress;
    loop_ = std::make_unique<GroundCameraLoop>(s.ground_cameras, s.seed, s.radio_baud, marked_, c.out_dir, c.station_argv, o);
  }
  void update(double t, const std::vector<VehicleTruth>& fleet) override {
    for (size_t i = 0; i < marked_.size(); ++i) {
      marked_[i].p_ned = fleet[i].position_ned;
      marked_[i].q_ib = fleet[i].q_ib;
    }
    loop_->update(t, marked_, [&](int id, double when, const uint8_t* d, size_t n) {
      const size_t i = index_of_id_.at(id);
      if (!serves_[i]) return;
      ++released_[i];
      due_.push_back({when, i, std::vector<uint8_t>(d, d + n)});
    });
  }
  void release_until(double t, const FixSink& sink) override {
    while (!due_.empty() && due_.front().when <= t + 1e-9) {
      const Due& f = due_.front();
      sink(f.vehicle, f.when, f.bytes.data(), f.bytes.size());
      due_.pop_front();
    }
  }
  uint64_t released(size_t vehicle) const override { return vehicle < released_.size() ? released_[vehicle] : 0; }
  void delivered(size_t vehicle, double t, const uint8_t* d, size_t n) override {
    if (vehicle < serves_.size() && serves_[vehicle]) loop_->delivered(s_.vehicles[vehicle].system_id, t, d, n);
  }
  void add_summary(Json& summary) const override {
    summary.add("ground_station", ground_station_json(loop_->figures(), s_.ground_cameras));
  }
  void add_vehicle_summary(size_t vehicle, Json& v) const override {
    const auto& per = loop_->figures().per_vehicle;
    const auto it = per.find(s_.vehicles[vehicle].system_id);
    v.add("ground_station", ground_vehicle_json(it == per.end() ? GroundVehicleFigures() : it->second));
  }
  int helper_pid() const override { return loop_->station_pid(); }
  void finish() override { loop_->finish(); }

 private:
  struct Due {
    double when;
    size_t vehicle;
    std::vector<uint8_t> bytes;
  };
  const Scenario& s_;
  std::vector<bool> serves_;
  std::vector<uint64_t> released_;
  std::map<int, size_t> index_of_id_;
  std::vector<MarkedVehicle> marked_;
  std::unique_ptr<GroundCameraLoop> loop_;
  std::deque<Due> due_;
};

}  // namespace

std::vector<std::unique_ptr<FixSource>> make_fix_sources(const Scenario& s, const FixSourceContext& context) {
  std::vector<size_t> synthetic, ground;
  for (size_t i = 0; i < s.vehicles.size(); ++i) {
    const FleetVehicle& v = s.vehicles[i];
    switch (v.fix_source) {
      case FixSourceKind::kSynthetic: synthetic.push_back(i); break;
      case FixSourceKind::kGroundCameras: ground.push_back(i); break;
      case FixSourceKind::kOnboardStar:
        throw std::runtime_error(s.path + ": vehicle '" + v.name + "': fix_source " + fix_source_name(v.fix_source) +
                                 " is not available in a multi-vehicle run (docs/simulator.md, \"Several vehicles\"); "
                                 "use synthetic or ground_cameras");
    }
  }
  std::vector<std::unique_ptr<FixSource>> out;
  if (!synthetic.empty()) out.push_back(std::make_unique<SyntheticFixes>(s, synthetic));
  if (!ground.empty()) out.push_back(std::make_unique<GroundCameraFixes>(s, ground, context));
  return out;
}

}  // namespace quad::sim
