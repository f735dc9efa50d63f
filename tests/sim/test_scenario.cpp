// Scenario files: the shipped ones load; a malformed one is rejected with the file, line and key.
#include <gtest/gtest.h>

#include <string>

#include "quad/link/dialect.h"
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
      EXPECT_EQ(*c.mode, static_cast<int>(mavlink::FlightMode::kAuto));
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

TEST(Scenario, AParameterListIsACommandOfItsOwn) {
  const Scenario s = parse_scenario("name: x\nduration_s: 10\ncommands:\n  - {at_s: 2, param_list: true}\n", "p.yaml", ".");
  ASSERT_EQ(s.commands.size(), 1u);
  EXPECT_TRUE(s.commands[0].param_list);
  EXPECT_FALSE(s.commands[0].arm || s.commands[0].mode || s.commands[0].setpoint_ned_m || s.commands[0].land);
  const std::string head = "name: x\nduration_s: 10\ncommands:\n";
  EXPECT_NE(error_of(head + "  - {at_s: 1, param_list: false}\n").find("'commands[0].param_list' can only be true"),
            std::string::npos);
  EXPECT_NE(error_of(head + "  - {at_s: 1, param_list: true, land: true}\n").find("'commands[0]' must hold exactly one"),
            std::string::npos);
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

}  // namespace
}  // namespace quad::sim
