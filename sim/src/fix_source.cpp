#include "quad/sim/fix_source.h"

#include <stdexcept>

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

}  // namespace

std::vector<std::unique_ptr<FixSource>> make_fix_sources(const Scenario& s) {
  std::vector<size_t> synthetic;
  for (size_t i = 0; i < s.vehicles.size(); ++i) {
    const FleetVehicle& v = s.vehicles[i];
    switch (v.fix_source) {
      case FixSourceKind::kSynthetic: synthetic.push_back(i); break;
      case FixSourceKind::kOnboardStar:
      case FixSourceKind::kGroundCameras:
        throw std::runtime_error(s.path + ": vehicle '" + v.name + "': fix_source " + fix_source_name(v.fix_source) +
                                 " is not available in a multi-vehicle run (docs/simulator.md, \"Several vehicles\"); "
                                 "use synthetic");
    }
  }
  std::vector<std::unique_ptr<FixSource>> out;
  if (!synthetic.empty()) out.push_back(std::make_unique<SyntheticFixes>(s, synthetic));
  return out;
}

}  // namespace quad::sim
