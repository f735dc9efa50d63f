// Where each vehicle of a multi-vehicle run gets its position fix (the scenario's vehicles[i].fix_source).
// A source serves one or more vehicles: the onboard star is one per vehicle, the fixed ground cameras see
// every vehicle at once and produce each one's fix from the same frame set. The run calls update() every
// physics step with the truth of the whole fleet and hands the frames release() gives it to each
// vehicle's radio, at their release time (capture plus processing), as the single-vehicle run does with
// the simulated fix (vision_fix.h).
//
// A source kind plugs in by a class derived from FixSource and a case in make_fix_sources(); the kinds
// without one are refused there with the vehicle's name, before any process starts.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "quad/sim/run_output.h"
#include "quad/sim/scenario.h"
#include "quad/sim/vehicle.h"

namespace quad::sim {

// (vehicle index in the scenario, release time, frame bytes, size)
using FixSink = std::function<void(size_t, double, const uint8_t*, size_t)>;

class FixSource {
 public:
  virtual ~FixSource() = default;
  // The fleet's truth at time t, indexed like scenario.vehicles; a source reads only its own vehicles.
  virtual void update(double t, const std::vector<VehicleTruth>& fleet) = 0;
  // Every frame due by time t, in order of release.
  virtual void release_until(double t, const FixSink& sink) = 0;
  // The fixes handed over so far to the vehicle (0 for a vehicle the source does not serve).
  virtual uint64_t released(size_t vehicle) const = 0;
  // Bytes of the vehicle's radio uplink handed to its firmware at time t (for the fix latency).
  virtual void delivered(size_t /*vehicle*/, double /*t*/, const uint8_t* /*data*/, size_t /*length*/) {}
  // The source's own figures: summary.json at the top and per vehicle (nothing to add by default).
  virtual void add_summary(Json& /*summary*/) const {}
  virtual void add_vehicle_summary(size_t /*vehicle*/, Json& /*vehicle_json*/) const {}
  // The process the source runs beside the simulator (the vision station), or -1: its CPU time counts
  // in the run's cost.
  virtual int helper_pid() const { return -1; }
  // The run has ended: stop any helper process (its last output written).
  virtual void finish() {}
};

// What a source that runs the vision station needs from the run (quad_sim's options).
struct FixSourceContext {
  std::string out_dir;
  std::vector<std::string> station_argv;  // ends in `run` (replaced by the subcommand)
  std::string room_calibration;           // empty: calibrate-room on rendered boards, cached
  std::string calibration_cache;          // empty: station_calibration/ beside the station
  std::function<void(const std::string&)> progress = [](const std::string&) {};
  std::vector<VehicleTruth> start;        // the fleet at rest before take-off, indexed like scenario.vehicles
};

// The sources of a scenario's vehicles (one per source kind in use). Throws std::runtime_error naming the
// vehicle and its fix_source when that kind is not available in a multi-vehicle run.
std::vector<std::unique_ptr<FixSource>> make_fix_sources(const Scenario& scenario,
                                                         const FixSourceContext& context = FixSourceContext());

}  // namespace quad::sim
