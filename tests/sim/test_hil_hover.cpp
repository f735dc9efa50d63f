// The hover with the real firmware: sim/scenarios/hover.yaml (thesis sec. 8.4) flown by
// quad_firmware on its own estimate, fed by the simulated vision fix over the emulated radio. The
// vehicle must take off, hold 1.5 m above the star with a horizontal standard deviation <= 3 cm, land
// and disarm; and the same seed must give the same log, byte for byte.
#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "quad/sim/hil_session.h"
#include "quad/sim/scenario.h"

namespace quad::sim {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The first number after "key": in a summary.json (keys are unique enough for the ones used here).
double json_number(const std::string& json, const std::string& key) {
  std::smatch m;
  if (!std::regex_search(json, m, std::regex("\"" + key + "\": (-?[0-9.eE+-]+)"))) return NAN;
  return std::stod(m[1]);
}

std::string last_line(const std::string& text) {
  const size_t end = text.find_last_not_of('\n');
  return text.substr(text.find_last_of('\n', end) + 1, end - text.find_last_of('\n', end));
}

SessionResult fly(const Scenario& s, const std::string& out) {
  SessionOptions o;
  o.out_dir = out;
  o.firmware_argv = {QUAD_SIM_FIRMWARE};
  o.progress = false;
  return run_session(s, o);
}

TEST(HilHover, TakesOffHoldsWithinThreeCentimetresAndLands) {
  const Scenario s = load_scenario(QUAD_SIM_SOURCE_DIR "/scenarios/hover.yaml");
  const std::string out = std::string(::testing::TempDir()) + "/quad_sim_hover_" + std::to_string(getpid());
  const SessionResult r = fly(s, out);
  ASSERT_TRUE(r.complete) << r.reason;
  EXPECT_FALSE(r.crashed);
  const std::string summary = slurp(out + "/summary.json");
  const double std_2d = json_number(summary, "std_2d");
  EXPECT_LE(std_2d, 0.03) << summary;
  EXPECT_LE(json_number(summary, "altitude_reached_s"), 10.0) << "1.5 m reached soon after the setpoint";
  EXPECT_GT(json_number(summary, "samples"), 2900.0) << "the whole 30 s hold was flown";
  // The firmware's estimate follows the truth (vision fix through the radio, in body FRD).
  EXPECT_LT(json_number(summary, "horizontal_rms_m"), 0.10);
  EXPECT_LT(json_number(summary, "vertical_rms_m"), 0.05);
  // Landed and disarmed at the end: on the gear, the HEARTBEAT's armed flag clear.
  std::stringstream last(last_line(slurp(out + "/log.csv")));
  std::vector<double> row;
  for (std::string cell; std::getline(last, cell, ',');) row.push_back(std::stod(cell));
  ASSERT_GT(row.size(), 36u);
  EXPECT_GT(row[3], -0.2) << "true down position: on the ground";
  EXPECT_EQ(row[35], 0.0) << "disarmed";
  std::printf("hover: horizontal std %.4f m, north mean %.4f m, east mean %.4f m, vertical std %.4f m\n", std_2d,
              json_number(summary.substr(summary.find("\"north\"")), "mean"),
              json_number(summary.substr(summary.find("\"east\"")), "mean"),
              json_number(summary.substr(summary.find("\"vertical\"")), "std"));
}

TEST(HilHover, TheSameSeedGivesTheSameLogWithTheRealFirmware) {
  Scenario s = load_scenario(QUAD_SIM_SOURCE_DIR "/scenarios/hover.yaml");
  s.duration_s = 20.0;  // take-off, climb and the start of the hold
  const std::string base = std::string(::testing::TempDir()) + "/quad_sim_hover_seed_" + std::to_string(getpid());
  ASSERT_TRUE(fly(s, base + "_a").complete);
  ASSERT_TRUE(fly(s, base + "_b").complete);
  const std::string a = slurp(base + "_a/log.csv");
  EXPECT_GT(a.size(), 100000u);
  EXPECT_TRUE(a == slurp(base + "_b/log.csv"));
}

}  // namespace
}  // namespace quad::sim
