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

// The scenario for flying from a ground station (quad_sim --gcs) schedules nothing itself.
TEST(Scenario, TheGroundStationScenarioLeavesEveryCommandToTheGroundStation) {
  const Scenario s = load_scenario(QUAD_SIM_SOURCE_DIR "/scenarios/ground_station.yaml");
  EXPECT_EQ(s.name, "ground_station");
  EXPECT_TRUE(s.commands.empty());
  EXPECT_GE(s.duration_s, 600.0);
  EXPECT_TRUE(s.vision.enabled);
}

TEST(Scenario, EveryShippedScenarioLoads) {
  for (const char* name : {"hover", "steps", "square", "gusts", "faults", "flight", "flight_plain"}) {
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

TEST(Scenario, ALogDownloadTakesAnIdAndAByteLimit) {
  const Scenario s = parse_scenario(
      "name: x\nduration_s: 10\ncommands:\n  - {at_s: 2, log_download: true}\n"
      "  - {at_s: 3, log_download: {id: 2, max_bytes: 4000}}\n",
      "p.yaml", ".");
  ASSERT_EQ(s.commands.size(), 2u);
  ASSERT_TRUE(s.commands[0].log_download);
  EXPECT_FALSE(s.commands[0].log_download->id || s.commands[0].log_download->max_bytes);
  ASSERT_TRUE(s.commands[1].log_download);
  EXPECT_EQ(*s.commands[1].log_download->id, 2);
  EXPECT_EQ(*s.commands[1].log_download->max_bytes, 4000u);
  const std::string head = "name: x\nduration_s: 10\ncommands:\n";
  EXPECT_NE(error_of(head + "  - {at_s: 1, log_download: false}\n").find("'commands[0].log_download' must be true or a mapping"),
            std::string::npos);
  EXPECT_NE(error_of(head + "  - {at_s: 1, log_download: {ids: 2}}\n").find("'commands[0].log_download.ids' is not a known key"),
            std::string::npos);
  EXPECT_NE(error_of(head + "  - {at_s: 1, log_download: {id: 0}}\n").find("'commands[0].log_download.id' must be in"),
            std::string::npos);
}

TEST(Scenario, CameraKeysAndStationSettingsAreParsed) {
  const Scenario s = parse_scenario(
      "name: x\nduration_s: 10\n"
      "camera: {enabled: true, image_size: [640, 480], left: {fx: 500, fy: 490, cx: 320, cy: 240,\n"
      "         distortion: [-0.3, 0.1, 0.001, -0.002, 0.0]}, floor_texture: floor.png, interlaced: true,\n"
      "         exposure_s: 0.004, jpeg_quality: 80, star_inner_ratio: 0.35}\n"
      "station_settings: {deinterlace: field, min_area_px: 120}\n",
      "x.yaml", "/scenarios");
  EXPECT_EQ(s.camera.image_width, 640);
  EXPECT_EQ(s.camera.image_height, 480);
  EXPECT_EQ(s.camera.left.fx, 500.0);
  EXPECT_EQ(s.camera.left.p2, -0.002);
  EXPECT_EQ(s.camera.right.fx, CameraParams().right.fx);  // untouched: the default
  EXPECT_EQ(s.camera.floor_texture, "/scenarios/floor.png");
  EXPECT_TRUE(s.camera.interlaced);
  EXPECT_EQ(s.camera.exposure_s, 0.004);
  EXPECT_EQ(s.camera.jpeg_quality, 80);
  EXPECT_EQ(s.camera.star_inner_ratio, 0.35);
  ASSERT_EQ(s.station_settings.size(), 2u);
  EXPECT_EQ(s.station_settings[0], (std::pair<std::string, std::string>("deinterlace", "field")));
  EXPECT_EQ(s.station_settings[1], (std::pair<std::string, std::string>("min_area_px", "120")));
  const std::string head = "name: x\nduration_s: 10\n";
  EXPECT_NE(error_of(head + "camera: {left: {fx: 500, distortion: [0.1, 0.2]}}\n").find("'camera.left.distortion' must be a list of five"),
            std::string::npos);
  EXPECT_NE(error_of(head + "camera: {jpeg_quality: 101}\n").find("'camera.jpeg_quality' must be in [0, 100]"), std::string::npos);
  EXPECT_NE(error_of(head + "station_settings: {deinterlace: 'a b'}\n").find("'station_settings.deinterlace' must be a number or a single word"),
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
  // A list or vector that is not there at all (the fuzzer's find: a gust without its velocity).
  EXPECT_NE(error_of(head + "wind:\n  gusts:\n    - {start_s: 2, end_s: 5}\n").find("'wind.gusts[0].velocity_ned_m_s' is required"),
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
