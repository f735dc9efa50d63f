// Scenario files: the shipped ones load; a malformed one is rejected with the file, line and key.
#include <gtest/gtest.h>

#include <string>

#include "quad/firmware/modes.h"
#include "quad/sim/scenario.h"

namespace quad::sim {
namespace {

std::string error_of(const std::string& yaml) {
  try {
    parse_scenario(yaml, "bad.yaml", ".");
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Scenario, EveryShippedScenarioLoads) {
  for (const char* name : {"hover", "steps", "square", "gusts", "faults"}) {
    const Scenario s = load_scenario(std::string(QUAD_SIM_SOURCE_DIR) + "/scenarios/" + name + ".yaml");
    EXPECT_EQ(s.name, name);
    EXPECT_GT(s.duration_s, 10.0);
    EXPECT_FALSE(s.commands.empty());
    EXPECT_GT(s.hold_end_s, s.hold_start_s) << name;
  }
}

TEST(Scenario, HoverIsTheThesisExperiment) {
  const Scenario s = load_scenario(QUAD_SIM_SOURCE_DIR "/scenarios/hover.yaml");
  bool arm = false, setpoint = false, land = false;
  for (const GcsCommand& c : s.commands) {
    arm |= c.arm.value_or(false);
    if (c.setpoint_ned_m) setpoint = c.setpoint_ned_m->isApprox(Eigen::Vector3d(0, 0, -1.5));
    land |= c.land;
    if (c.mode) {
      EXPECT_EQ(*c.mode, static_cast<int>(fw::FlightMode::kAuto));
    }
  }
  EXPECT_TRUE(arm && setpoint && land);
  EXPECT_DOUBLE_EQ(s.vision.rate_hz, 30.0);
}

TEST(Scenario, FaultsAndWindAreParsed) {
  const Scenario s = load_scenario(QUAD_SIM_SOURCE_DIR "/scenarios/faults.yaml");
  ASSERT_EQ(s.faults.size(), 8u);
  EXPECT_EQ(s.faults[5].type, FaultType::kMotorEfficiency);
  EXPECT_EQ(s.faults[5].motor, 1);
  EXPECT_DOUBLE_EQ(s.faults[5].value, 0.85);
  EXPECT_TRUE(s.faults[5].active(40.0));
  EXPECT_FALSE(s.faults[5].active(45.0));
  const Scenario g = load_scenario(QUAD_SIM_SOURCE_DIR "/scenarios/gusts.yaml");
  EXPECT_TRUE(g.wind_at(21.0).isApprox(Eigen::Vector3d(-4.4, -1.4, 0.0)));
  EXPECT_TRUE(g.wind_at(25.0).isApprox(Eigen::Vector3d(-1.4, -1.4, 0.0)));
}

TEST(Scenario, ErrorsNameTheFileLineAndKey) {
  const std::string head = "name: x\nduration_s: 10\n";
  EXPECT_EQ(error_of(head + "vision:\n  rate_hz: fast\n"), "bad.yaml:4: 'vision.rate_hz' must be a number, not 'fast'");
  EXPECT_NE(error_of(head + "visoin: {rate_hz: 30}\n").find("bad.yaml:3: 'visoin' is not a known key"), std::string::npos);
  EXPECT_NE(error_of(head + "commands:\n  - {at_s: 1, mode: HOVER}\n").find("bad.yaml:4: 'commands[0].mode' is not a flight mode"),
            std::string::npos);
  EXPECT_NE(error_of(head + "commands:\n  - {at_s: 1, arm: true, land: true}\n").find("'commands[0]' must hold exactly one"),
            std::string::npos);
  EXPECT_NE(error_of(head + "faults:\n  - {type: motor_efficiency, start_s: 1}\n").find("'faults[0].motor' is required"),
            std::string::npos);
  EXPECT_NE(error_of(head + "radio: {loss: 1.5}\n").find("bad.yaml:3: 'radio.loss' must be in [0, 1]"), std::string::npos);
  EXPECT_NE(error_of("duration_s: 10\n").find("'name' is required"), std::string::npos);
  EXPECT_NE(error_of(head + "wind: {mean_ned_m_s: [1, 2]}\n").find("'wind.mean_ned_m_s' must be a list of three numbers"),
            std::string::npos);
  EXPECT_NE(error_of("name: [unclosed\n").find("bad.yaml:"), std::string::npos);
}

// quad_sim --set: a key replaced, a firmware parameter and a map created, a list item by index; a bad
// path or value names the --set argument.
TEST(Scenario, OverridesReplaceKeysBeforeTheScenarioIsChecked) {
  const std::string yaml =
      "name: x\nduration_s: 10\nradio: {latency_s: 0.004}\ncommands:\n  - {at_s: 3.0, arm: true}\n"
      "  - {at_s: 8.0, land: true}\n";
  const Scenario s = parse_scenario(yaml, "o.yaml", ".",
                                    {parse_override("radio.latency_s=0.02"), parse_override("duration_s=12"),
                                     parse_override("firmware_params.POS_KP_XY=4"), parse_override("commands.1.at_s=9.5"),
                                     parse_override("wind.mean_ned_m_s=[1, 0, 0]")});
  EXPECT_DOUBLE_EQ(s.radio.latency_s, 0.02);
  EXPECT_DOUBLE_EQ(s.duration_s, 12.0);
  ASSERT_EQ(s.firmware_params.size(), 1u);
  EXPECT_EQ(s.firmware_params[0].first, "POS_KP_XY");
  EXPECT_DOUBLE_EQ(s.firmware_params[0].second, 4.0);
  ASSERT_EQ(s.commands.size(), 2u);
  EXPECT_DOUBLE_EQ(s.commands[1].at_s, 9.5);
  EXPECT_TRUE(s.wind_mean_ned_m_s.isApprox(Eigen::Vector3d(1, 0, 0)));

  auto error = [&](const std::string& o) {
    try {
      parse_scenario(yaml, "o.yaml", ".", {parse_override(o)});
    } catch (const ScenarioError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(error("commands.2.at_s=1").find("--set commands.2.at_s=1"), std::string::npos);
  EXPECT_NE(error("radio.latency_s.x=1").find("neither a mapping nor a list"), std::string::npos);
  EXPECT_NE(error("radio.latncy_s=1").find("'radio.latncy_s' is not a known key"), std::string::npos);
  EXPECT_NE(error("radio.latency_s=abc").find("(with --set radio.latency_s)"), std::string::npos);
  EXPECT_THROW(parse_override("no_equals_sign"), ScenarioError);
}

}  // namespace
}  // namespace quad::sim
