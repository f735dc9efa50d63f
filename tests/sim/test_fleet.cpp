// Several vehicles in one world (docs/simulator.md, "Several vehicles"): the scenario's vehicles: key,
// the generated model, the hull contacts counted as collisions, the fix sources; and, with the real host
// firmware (one process per vehicle, lockstep), two vehicles holding side by side and four swapping
// corners with crossing paths and no collision.
#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "quad/link/dialect.h"
#include "quad/sim/fix_source.h"
#include "quad/sim/fleet_model.h"
#include "quad/sim/fleet_session.h"
#include "quad/sim/fleet_world.h"
#include "quad/sim/ground_ids.h"
#include "quad/sim/run_output.h"
#include "quad/sim/scenario.h"

namespace quad::sim {
namespace {

#ifndef QUAD_SIM_FIRMWARE  // the model, world and scenario (test_sim_fleet); the flights below (test_sim_fleet_flight)
const char* kTwo = R"(
name: t
duration_s: 10
firmware_params: {EST_TYPE: 1}
vehicles:
  - {name: a, initial: {north_east_m: [0, -1]}}
  - {name: b, system_id: 7, initial: {north_east_m: [0, 1]}, firmware_params: {EST_TYPE: 0, POS_KP_XY: 2}}
commands:
  - {at_s: 1, arm: true}
  - {at_s: 2, setpoint_ned_m: [0.5, 0, -1.5]}
)";

std::string error_of(const std::string& yaml) {
  try {
    parse_scenario(yaml, "f.yaml", ".");
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "";
}

TEST(FleetScenario, SharedCommandsAreOffsetAndParametersMerged) {
  const Scenario s = parse_scenario(kTwo, "f.yaml", ".");
  ASSERT_EQ(s.vehicles.size(), 2u);
  EXPECT_EQ(s.vehicles[0].system_id, 1);
  EXPECT_EQ(s.vehicles[1].system_id, 7);
  ASSERT_EQ(s.vehicles[1].commands.size(), 2u);
  EXPECT_EQ(*s.vehicles[1].commands[1].setpoint_ned_m, Eigen::Vector3d(0.5, 1.0, -1.5));
  EXPECT_EQ(*s.vehicles[0].commands[1].setpoint_ned_m, Eigen::Vector3d(0.5, -1.0, -1.5));
  const auto& p = s.vehicles[1].firmware_params;
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0], std::make_pair(std::string("EST_TYPE"), 0.0));
  EXPECT_EQ(p[1], std::make_pair(std::string("POS_KP_XY"), 2.0));
  EXPECT_EQ(s.vehicles[0].markers.size(), 4u);
}

TEST(FleetScenario, RefusesWhatAFleetDoesNotShare) {
  EXPECT_NE(error_of(std::string(kTwo) + "initial: {height_m: 1}\n").find("'initial' is per vehicle"), std::string::npos);
  EXPECT_NE(error_of(std::regex_replace(std::string(kTwo), std::regex("name: b,"), "name: a,")).find("repeats the name"),
            std::string::npos);
  EXPECT_NE(error_of(std::regex_replace(std::string(kTwo), std::regex("system_id: 7"), "system_id: 1")).find("repeats the system id"),
            std::string::npos);
  EXPECT_NE(error_of(std::regex_replace(std::string(kTwo), std::regex("name: a,"), "name: a, fix_source: sonar,")).find("not a fix source"),
            std::string::npos);
  EXPECT_NE(error_of(std::string(kTwo) + "camera: {enabled: true}\n").find("fix source"), std::string::npos);
}

// With the room cameras on, every vehicle's fix source defaults to them (one may keep the simulated fix);
// each needs one ball of each colour; the rig's own layout key is per vehicle in a fleet.
TEST(FleetScenario, GroundCamerasKeys) {
  const std::string on = std::string(kTwo) + "ground_cameras: {enabled: true}\n";
  const Scenario s = parse_scenario(on, "f.yaml", ".");
  EXPECT_EQ(s.vehicles[0].fix_source, FixSourceKind::kGroundCameras);
  EXPECT_EQ(s.vehicles[1].fix_source, FixSourceKind::kGroundCameras);
  const Scenario mixed = parse_scenario(std::regex_replace(on, std::regex("name: a,"), "name: a, fix_source: synthetic,"), "f.yaml", ".");
  EXPECT_EQ(mixed.vehicles[0].fix_source, FixSourceKind::kSynthetic);
  const std::string two_reds = std::regex_replace(
      on, std::regex("name: a,"),
      "name: a, markers: [{colour: red, position_frd_m: [0.2, 0, 0]}, {colour: red, position_frd_m: [0, 0.2, 0]}, "
      "{colour: blue, position_frd_m: [-0.2, 0, 0]}, {colour: yellow, position_frd_m: [0, 0, -0.1]}],");
  EXPECT_NE(error_of(two_reds).find("exactly one red marker"), std::string::npos) << error_of(two_reds);
  EXPECT_NE(error_of(std::string(kTwo) + "ground_cameras: {enabled: true, markers_frd_m: {red: [0.2, 0, 0]}}\n")
                .find("'ground_cameras.markers_frd_m' is per vehicle"),
            std::string::npos);
}

TEST(FleetScenario, UnavailableFixSourcesAreRefusedByName) {
  Scenario s = parse_scenario(kTwo, "f.yaml", ".");
  s.vehicles[1].fix_source = FixSourceKind::kOnboardStar;
  try {
    make_fix_sources(s);
    FAIL() << "onboard_star accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("vehicle 'b': fix_source onboard_star"), std::string::npos) << e.what();
  }
  // The ground cameras need the station's command (quad_sim's --station).
  s.vehicles[1].fix_source = FixSourceKind::kGroundCameras;
  try {
    make_fix_sources(s);
    FAIL() << "ground_cameras accepted without a station";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("ground_cameras needs the vision station"), std::string::npos) << e.what();
  }
}

// The generated model holds both airframes; hulls that overlap are in contact (one collision), the
// hulls of vehicles 1.5 m apart are not.
TEST(FleetWorld, HullsTouchingCountAsOneCollision) {
  Scenario s = parse_scenario(kTwo, "f.yaml", ".");
  s.vehicles[0].initial_north_east_m = {0.0, -0.3};  // 0.6 m apart: the 0.39 m hulls overlap
  s.vehicles[1].initial_north_east_m = {0.0, 0.3};
  s.vehicles[0].initial_height_m = s.vehicles[1].initial_height_m = 1.0;
  const std::string dir = std::string(::testing::TempDir()) + "/fleet_world_" + std::to_string(getpid());
  make_directories(dir);
  write_file_atomically(dir + "/m.xml", fleet_model_xml(s.model_path, s.vehicles));
  VehicleParams p;
  p.model_path = dir + "/m.xml";
  FleetWorld w(p, s.vehicles);
  ASSERT_EQ(w.size(), 2u);
  w.start(s.vehicles, 0.0);
  EXPECT_NEAR(w.truth(1).position_ned.y() - w.truth(0).position_ned.y(), 0.6, 1e-9);
  for (int i = 0; i < 50; ++i) w.step();
  ASSERT_EQ(w.collisions().size(), 1u) << "a lasting touch counts once";
  EXPECT_EQ(w.collisions()[0].a, 0u);
  EXPECT_EQ(w.collisions()[0].b, 1u);
  EXPECT_GT(w.truth(1).velocity_ned.y(), 0.0) << "the contact pushes them apart";

  s.vehicles[0].initial_north_east_m = {0.0, -0.75};
  s.vehicles[1].initial_north_east_m = {0.0, 0.75};
  w.start(s.vehicles, 0.0);
  for (int i = 0; i < 50; ++i) w.step();
  EXPECT_TRUE(w.collisions().empty());
}

namespace mav = quad::mavlink;

// One frame through the codec's parser (CRC checked); calls f with it.
template <class F>
void parse_one(const uint8_t* bytes, size_t n, F&& f) {
  mav::Parser p{mav::dialect_message_info};
  int frames = 0;
  p.feed(bytes, n, [&](const mav::Frame& frame) { ++frames, f(frame); });
  ASSERT_EQ(frames, 1) << "one valid frame";
}

TEST(GroundIds, TheVehicleLeavesAsItsSystemIdAndIsAddressedByIt) {
  GroundIds ids(2);
  mav::Sender firmware(1, 1), gcs(255, 190);
  uint8_t in[mav::kMaxFrameLength], out[mav::kMaxFrameLength];
  mav::Heartbeat hb;
  hb.custom_mode = 2;
  parse_one(in, firmware.encode(hb, in, sizeof in), [&](const mav::Frame& f) {
    const size_t n = ids.to_ground(f, out, sizeof out);
    parse_one(out, n, [&](const mav::Frame& g) {
      EXPECT_EQ(g.system_id, 2);
      mav::Heartbeat back;
      ASSERT_TRUE(mav::decode(g, back));
      EXPECT_EQ(back.custom_mode, 2u);
    });
  });
  for (const auto& [target, expected] : {std::pair<int, int>{2, 1}, {0, 0}, {3, -1}}) {
    mav::CommandLong cmd;
    cmd.command = 21;
    cmd.target_system = static_cast<uint8_t>(target);
    parse_one(in, gcs.encode(cmd, in, sizeof in), [&](const mav::Frame& f) {
      const size_t n = ids.to_vehicle(f, out, sizeof out);
      if (expected < 0) {
        EXPECT_EQ(n, 0u) << "another system's command is dropped";
        return;
      }
      parse_one(out, n, [&](const mav::Frame& g) {
        mav::CommandLong back;
        ASSERT_TRUE(mav::decode(g, back));
        EXPECT_EQ(back.target_system, expected);
        EXPECT_EQ(back.command, 21);
        EXPECT_EQ(g.system_id, 255);
      });
    });
  }
  EXPECT_EQ(ids.stats().restamped, 1u);
  EXPECT_EQ(ids.stats().readdressed, 1u);
  EXPECT_EQ(ids.stats().dropped, 1u);
}

#else
std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The first number after "key": in `json` from the vehicle's object on (or the whole text).
double number(const std::string& json, const std::string& key, const std::string& vehicle = "") {
  const size_t from = vehicle.empty() ? 0 : json.find("\"" + vehicle + "\": {");
  if (from == std::string::npos) return NAN;
  std::smatch m;
  const std::string rest = json.substr(from);
  if (!std::regex_search(rest, m, std::regex("\"" + key + "\": (-?[0-9.eE+-]+)"))) return NAN;
  return std::stod(m[1]);
}

std::string fly(const std::string& scenario, const std::string& name) {
  const Scenario s = load_scenario(QUAD_SIM_SOURCE_DIR "/scenarios/" + scenario);
  SessionOptions o;
  o.out_dir = std::string(::testing::TempDir()) + "/" + name + "_" + std::to_string(getpid());
  o.firmware_argv = {QUAD_SIM_FIRMWARE};
  o.progress = false;
  const SessionResult r = run_fleet_session(s, o);
  EXPECT_TRUE(r.complete) << r.reason;
  return slurp(o.out_dir + "/summary.json");
}

TEST(FleetFlight, TwoVehiclesHoldSideBySide) {
  const std::string j = fly("two_vehicles.yaml", "fleet_two");
  EXPECT_EQ(number(j, "count", "collisions"), 0.0) << j;
  EXPECT_GT(number(j, "min_m"), 1.8) << j;
  for (const char* v : {"west", "east"}) {
    EXPECT_LE(number(j, "std_2d", v), 0.02) << v << "\n" << j;
    EXPECT_GT(number(j, "samples", v), 1900.0) << v;
  }
  EXPECT_EQ(j.find("\"crashed\": true"), std::string::npos) << j;
  EXPECT_EQ(j.find("\"armed_at_end\": true"), std::string::npos) << "both landed and disarmed\n" << j;
}

TEST(FleetFlight, FourVehiclesSwapCornersWithoutCollision) {
  const std::string j = fly("four_vehicles_swap.yaml", "fleet_four");
  EXPECT_EQ(number(j, "count", "collisions"), 0.0) << j;
  EXPECT_GT(number(j, "min_m"), 2.0 * kHullRadiusM) << "hulls never closer than touching\n" << j;
  EXPECT_EQ(j.find("\"crashed\": true"), std::string::npos) << j;
  // Each holds at the opposite corner after the swap (the hold's error is to the last setpoint there).
  for (const char* v : {"nw", "se", "ne", "sw"}) EXPECT_LT(number(j, "rms", v), 0.10) << v << "\n" << j;
  std::printf("four_vehicles_swap: min separation %.3f m, collisions %.0f\n", number(j, "min_m"), number(j, "count", "collisions"));
}
#endif

}  // namespace
}  // namespace quad::sim
