// The firmware's flight log (FlightLogger in FlightApp): when a log starts and ends (LOG_MODE), what it
// holds, read back by the field's reader (@foxglove/ulog through tools/node/ulog_check.js).
#include <gtest/gtest.h>

#include <string>

#include "app_bench.h"
#include "log_test_support.h"
#include "quad/firmware/app.h"

namespace {

using quad::fw::FlightMode;
using quad::fw::test::Bench;
using quad::fw::test::RamLogStore;
using quad::fw::test::read_with_node;
using quad::fw::test::topic_number;
namespace mav = quad::mavlink;

// Calibrated, with RC and fixes seen (ready to arm).
void calibrate(Bench& b) {
  for (int i = 0; i < 250 && !b.app->calibrated(); ++i) b.still_step();
  ASSERT_TRUE(b.app->calibrated());
  // The pre-arm check: the ground hold brings the position filter's variances under its thresholds.
  quad::fw::test::ready_to_arm(b);
  b.sticks(0);
}

// Still steps on the ground with a fix every third step and RC every fifth.
void hold(Bench& b, int steps) {
  for (int i = 0; i < steps; ++i) {
    b.still_step();
    if (i % 3 == 0) b.landing_target(Eigen::Vector3f(0, 0, 0), Eigen::Quaternionf::Identity(), b.t_us - 30000);
    if (i % 5 == 0) b.sticks(0);
  }
}

void boot(Bench& b, RamLogStore& ram, float log_mode = 1.0f, float imu_div = 1.0f) {
  b.log_store = ram.store();
  b.boot();
  ASSERT_EQ(b.app->override_param(quad::fw::kLogMode, log_mode), nullptr);
  ASSERT_EQ(b.app->override_param(quad::fw::kLogImuDiv, imu_div), nullptr);
}

uint8_t disarm(Bench& b) { return b.command(mav::kCmdComponentArmDisarm, 0.0f); }

TEST(FlightLogger, OneLogFromArmingToDisarmingPerFlight) {
  RamLogStore ram;
  Bench b;
  boot(b, ram);
  calibrate(b);
  hold(b, 30);
  EXPECT_TRUE(ram.logs.empty()) << "no log before arming";
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  ASSERT_EQ(ram.logs.size(), 1u);
  EXPECT_TRUE(ram.open());
  hold(b, 100);
  EXPECT_TRUE(b.app->logger().header_done()) << "the definitions take a few iterations";
  ASSERT_EQ(disarm(b), mav::kResultAccepted);
  EXPECT_FALSE(ram.open()) << "disarming closes the log";
  hold(b, 30);
  EXPECT_EQ(ram.logs.size(), 1u);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  EXPECT_EQ(ram.logs.size(), 2u) << "the next flight, the next log";
  hold(b, 20);
  ASSERT_EQ(disarm(b), mav::kResultAccepted);
  EXPECT_EQ(b.app->logger().logs_opened(), 2u);
  EXPECT_EQ(b.app->logger().dropped(), 0u);

  const auto r = read_with_node(ram.logs[0], "arm_to_disarm");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(topic_number(r.out, "vehicle_status", "arming_state", "first"), 1);
  EXPECT_EQ(topic_number(r.out, "vehicle_status", "arming_state", "last"), 0);
  const long imu = topic_number(r.out, "sensor_combined", "count");
  EXPECT_GT(imu, 90) << "every iteration once the definitions are written";
  EXPECT_LE(imu, 100);
  EXPECT_EQ(topic_number(r.out, "actuator_motors", "count"), imu) << "100 Hz: every iteration is a frame";
  EXPECT_GT(topic_number(r.out, "sensor_mag", "count"), 0);
  EXPECT_GT(topic_number(r.out, "vision_fix", "count"), 25);
  EXPECT_EQ(topic_number(r.out, "vision_fix", "result", "last"), 0) << "fused";
  EXPECT_GE(topic_number(r.out, "loop_timing", "count"), 1);
  EXPECT_NE(r.out.find("\"SYS_LOOP_HZ\": 100"), std::string::npos);
  EXPECT_NE(r.out.find("DISARMED"), std::string::npos) << "the disarming line is in the log";
  EXPECT_EQ(r.out.find("\"monotonic\": false"), std::string::npos);
}

TEST(FlightLogger, ModeOffLogsNothing) {
  RamLogStore ram;
  Bench b;
  boot(b, ram, 0.0f);
  calibrate(b);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  hold(b, 50);
  EXPECT_TRUE(ram.logs.empty());
  EXPECT_FALSE(b.app->logger().logging());
}

TEST(FlightLogger, ModeBootLogsFromTheFirstIterationAcrossFlights) {
  RamLogStore ram;
  Bench b;
  boot(b, ram, 2.0f);
  b.still_step();
  ASSERT_EQ(ram.logs.size(), 1u);
  calibrate(b);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  hold(b, 20);
  ASSERT_EQ(disarm(b), mav::kResultAccepted);
  hold(b, 20);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  hold(b, 20);
  EXPECT_EQ(ram.logs.size(), 1u) << "one log per boot";
  EXPECT_TRUE(ram.open());
  b.app->close_log();
  const auto r = read_with_node(ram.logs[0], "boot");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(topic_number(r.out, "vehicle_status", "arming_state", "first"), 0) << "logging while disarmed";
  EXPECT_EQ(topic_number(r.out, "vehicle_status", "count"), 4) << "start, armed, disarmed, armed";
}

TEST(FlightLogger, WithoutAStoreNothingIsLogged) {
  Bench b;
  b.boot();
  calibrate(b);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  hold(b, 50);
  EXPECT_FALSE(b.app->logger().logging());
  EXPECT_EQ(b.app->logger().logs_opened(), 0u);
}

TEST(FlightLogger, ParameterChangesInFlightAndImuDecimation) {
  RamLogStore ram;
  Bench b;
  boot(b, ram, 1.0f, 4.0f);
  calibrate(b);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  hold(b, 50);
  ASSERT_EQ(b.app->set_param(quad::fw::kPosKpXY, 4.5f).status, quad::fw::ParamUpdate::Status::kApplied);
  hold(b, 50);
  ASSERT_EQ(disarm(b), mav::kResultAccepted);
  const auto r = read_with_node(ram.logs[0], "param_change");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("\"POS_KP_XY\": 3.625"), std::string::npos) << "the value at the start";
  EXPECT_NE(r.out.find("\"key\": \"float POS_KP_XY\",\n   \"value\": 4.5"), std::string::npos) << r.out.substr(0, 3000);
  const long frames = topic_number(r.out, "vehicle_local_position", "count");
  const long imu = topic_number(r.out, "sensor_combined", "count");
  EXPECT_GT(frames, 80);
  EXPECT_NEAR(static_cast<double>(imu), frames / 4.0, 1.0) << "LOG_IMU_DIV 4";
}

TEST(FlightLogger, BusyStoreDropsWholeRecordsAndTheLogStaysReadable) {
  RamLogStore ram;
  // Busy for 5 calls in 10, and at most 120 bytes a call: about one iteration in two loses a record.
  ram.busy_every = 10;
  ram.busy_run = 5;
  ram.max_take = 120;
  Bench b;
  boot(b, ram);
  calibrate(b);
  ASSERT_EQ(b.arm(), mav::kResultAccepted);
  hold(b, 300);
  EXPECT_TRUE(b.app->logger().header_done());
  ASSERT_EQ(disarm(b), mav::kResultAccepted);
  EXPECT_GT(b.app->logger().dropped(), 0u);
  const auto r = read_with_node(ram.logs[0], "busy_flight");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_GT(topic_number(r.out, "sensor_combined", "count"), 50);
  EXPECT_EQ(r.out.find("\"monotonic\": false"), std::string::npos);
}

}  // namespace
