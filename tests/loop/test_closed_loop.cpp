// The closed-loop flight in ctest: the simulator renders the two downward cameras, a separate
// vision_station process finds the star and its LANDING_TARGET crosses the emulated radio to the real
// quad_firmware. A 20 s hold must meet the targets of docs/results.md (with a margin where noted), one
// seed must give one log, and losing the star for 2 s must trigger the vision failsafe and end in a safe
// landing. A commanded landing loses the star close to the floor without a failsafe (below LAND_VIS_HGT),
// and still fails safe when it loses it at 1 m.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "loop_session.h"
#include "loop_summary.h"
#include "quad/sim/hil_session.h"
#include "quad/sim/scenario.h"

namespace quad::sim {
namespace {

SessionResult fly(const std::string& scenario, const std::string& out) {
  const Scenario s = load_scenario(std::string(QUAD_LOOP_TEST_DIR) + "/" + scenario);
  return run_session(s, loop_session_options(out));
}

std::string run_dir(const std::string& name) {
  return std::string(::testing::TempDir()) + "/quad_loop_" + name + "_" + std::to_string(getpid());
}

TEST(ClosedLoop, TwentySecondHoldOnTheStationsFixes) {
  const std::string out = run_dir("hold");
  const SessionResult r = fly("loop_hold.yaml", out);
  ASSERT_TRUE(r.complete) << r.reason;
  EXPECT_FALSE(r.crashed);
  const std::string summary = slurp(out + "/summary.json");
  std::printf("[figure] loop hold 20 s: %s\n", summary.c_str());
  // The targets of docs/results.md: horizontal std <= 2 cm, vertical std <= 2 cm (margin 0.5 cm for a
  // 20 s window); horizontal and vertical |mean| <= 1 cm (the firmware's position trim, POS_KI_XY and
  // POS_KI_Z, and the hover accelerometer-bias tracker; the 60 s holds of docs/results.md give
  // 0.08-0.25 cm horizontal and 0.00-0.66 cm vertical over five seeds).
  EXPECT_LE(json_number(summary, {"horizontal", "std_2d"}), 0.025) << summary;
  EXPECT_LE(json_number(summary, {"vertical", "std"}), 0.025) << summary;
  EXPECT_LE(std::abs(json_number(summary, {"vertical", "mean"})), 0.01) << summary;
  EXPECT_LE(std::hypot(json_number(summary, {"north", "mean"}), json_number(summary, {"east", "mean"})), 0.01)
      << summary;
  EXPECT_GT(json_number(summary, {"hold", "samples"}), 1990.0);
  // The station: every pair answered, 5 % lost on the way, fixes accurate to millimetres.
  const double captured = json_number(summary, {"vision_station", "pairs_captured"});
  const double lost = json_number(summary, {"vision_station", "pairs_lost"});
  EXPECT_NEAR(captured, 38.0 * 30.0, 2.0);
  EXPECT_NEAR(lost / captured, 0.05, 0.02);
  // Every pair sent was answered, but for one still in flight when the run ended.
  EXPECT_GE(json_number(summary, {"vision_station", "pairs_answered"}), captured - lost - 1.0);
  EXPECT_LE(json_number(summary, {"vision_station", "pairs_answered"}), captured - lost);
  EXPECT_GT(json_number(summary, {"vision_station", "fixes"}), 0.75 * (captured - lost));
  // Each fix followed by its covariances (LANDING_TARGET_COVARIANCE) on the radio.
  EXPECT_EQ(json_number(summary, {"vision_station", "covariances"}), json_number(summary, {"vision_station", "fixes"}));
  EXPECT_LT(json_number(summary, {"fix_error_m", "median"}), 0.005);
  EXPECT_LT(json_number(summary, {"fix_error_m", "p95"}), 0.015);
  // Landed and disarmed at the end.
  const std::string events = slurp(out + "/events.log");
  EXPECT_NE(events.find("DISARMED: landed"), std::string::npos) << events;
}

TEST(ClosedLoop, SameSeedSameLog) {
  // The station's processing time is accounted as the configured latency, so its wall clock does not
  // reach the log: two runs of one seed agree byte for byte.
  const std::string a = run_dir("det_a"), b = run_dir("det_b");
  ASSERT_TRUE(fly("loop_star_lost.yaml", a).complete);
  ASSERT_TRUE(fly("loop_star_lost.yaml", b).complete);
  const std::string la = slurp(a + "/log.csv"), lb = slurp(b + "/log.csv");
  ASSERT_GT(la.size(), 100000u);
  EXPECT_TRUE(la == lb) << "log.csv differs between two runs of the same seed";
}

TEST(ClosedLoop, StarLostForTwoSecondsTriggersTheFailsafeAndLandsSafely) {
  const std::string out = run_dir("lost");
  const SessionResult r = fly("loop_star_lost.yaml", out);
  ASSERT_TRUE(r.complete) << r.reason;
  EXPECT_FALSE(r.crashed);
  const std::string events = slurp(out + "/events.log");
  // The failsafe fires after FS_VIS_TIMEOUT (0.5 s) without a fix, inside the 2 s window.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(events, m, std::regex(R"(\s*([0-9.]+) firmware \(uart0\): LANDING: FAILSAFE vision lost)")))
      << events;
  const double failsafe_t = std::stod(m[1]);
  EXPECT_GT(failsafe_t, 16.4);
  EXPECT_LT(failsafe_t, 16.9);
  EXPECT_NE(events.find("DISARMED: landed"), std::string::npos) << events;
  const std::string summary = slurp(out + "/summary.json");
  // No fix while the star was hidden: 2 s at 30 Hz of answered pairs without one.
  EXPECT_LT(json_number(summary, {"vision_station", "fixes"}),
            json_number(summary, {"vision_station", "pairs_answered"}) - 55.0);
}

// The time of the first events.log line matching `pattern` (its first group is the time), or -1.
double event_time(const std::string& events, const std::string& pattern) {
  std::smatch m;
  return std::regex_search(events, m, std::regex(pattern)) ? std::stod(m[1]) : -1.0;
}

TEST(ClosedLoop, ALandingLosesTheStarNearTheFloorWithoutAFailsafe) {
  const std::string out = run_dir("landing");
  const SessionResult r = fly("loop_landing.yaml", out);
  ASSERT_TRUE(r.complete) << r.reason;
  EXPECT_FALSE(r.crashed);
  const std::string events = slurp(out + "/events.log");
  ASSERT_GT(event_time(events, R"(\s*([0-9.]+) firmware \(uart0\): LANDING: land commanded)"), 7.9) << events;
  EXPECT_EQ(events.find("FAILSAFE"), std::string::npos) << events;
  EXPECT_EQ(events.find("position jumped"), std::string::npos) << events;
  EXPECT_GT(event_time(events, R"(\s*([0-9.]+) firmware \(uart0\): DISARMED: landed, disarmed)"), 9.0) << events;
  // The station did lose the star before the touchdown: its last fix came from above the floor, and
  // the landing went on without one for longer than FS_VIS_TIMEOUT.
  const std::string summary = slurp(out + "/summary.json");
  EXPECT_LT(json_number(summary, {"vision_station", "fixes"}),
            json_number(summary, {"vision_station", "pairs_answered"}) - 30.0) << summary;
}

TEST(ClosedLoop, ALandingThatLosesTheStarAtOneMetreIsTheFailsafe) {
  const std::string out = run_dir("landing_lost");
  const SessionResult r = fly("loop_landing_star_lost.yaml", out);
  ASSERT_TRUE(r.complete) << r.reason;
  EXPECT_FALSE(r.crashed);
  const std::string events = slurp(out + "/events.log");
  // FS_VIS_TIMEOUT (0.5 s) after the last fix, which was captured just before the star was hidden at 8 s.
  const double failsafe_t = event_time(events, R"(\s*([0-9.]+) firmware \(uart0\): FAILSAFE vision lost: level, land)");
  EXPECT_GT(failsafe_t, 8.4) << events;
  EXPECT_LT(failsafe_t, 8.9) << events;
  EXPECT_GT(event_time(events, R"(\s*([0-9.]+) firmware \(uart0\): DISARMED: landed, disarmed)"), failsafe_t) << events;
}

}  // namespace
}  // namespace quad::sim
