// The flight log's definitions: the topics' formats, the information, the parameters and the
// subscriptions, written over the first iterations of a log (flight_logger.h).
#include "quad/firmware/flight_logger.h"

#include "quad/firmware/app.h"

namespace quad {
namespace fw {

namespace {

// The topics' formats (PX4's field names where PX4 has the topic), one after the other, each ended by a
// NUL, in LogTopic order. Field order is the data's byte order.
constexpr char kFormats[] QUAD_FLASH =
    "sensor_combined:uint64_t timestamp;float[3] gyro_rad;float[3] accelerometer_m_s2;float dt;uint8_t hovering;uint8_t on_ground;\0"
    "sensor_mag:uint64_t timestamp;float[3] magnetometer_ga;\0"
    "vehicle_attitude:uint64_t timestamp;float[4] q;float[3] gyro_bias;\0"
    "vehicle_local_position:uint64_t timestamp;float x;float y;float z;float vx;float vy;float vz;"
    "float[3] pos_variance;float[3] vel_variance;float[3] accel_bias;\0"
    "vision_fix:uint64_t timestamp;uint64_t timestamp_sample;float x;float y;float z;float[4] q;"
    "uint8_t result;\0"
    "vehicle_local_position_setpoint:uint64_t timestamp;float x;float y;float z;float yaw;\0"
    "actuator_motors:uint64_t timestamp;float[4] control;\0"
    "vehicle_status:uint64_t timestamp;uint8_t nav_state;uint8_t arming_state;uint8_t failsafe;\0"
    "loop_timing:uint64_t timestamp;uint32_t iterations;uint32_t overruns;uint32_t last_us;uint32_t max_us;"
    "float load;uint16_t records_deferred;\0"
    "estimator_status:uint64_t timestamp;float vel_test_ratio;float pos_test_ratio;float hgt_test_ratio;"
    "float mag_test_ratio;float pos_horiz_accuracy;float pos_vert_accuracy;uint16_t solution_status_flags;";

#if defined(__AVR__)
#define QUAD_LOG_HW "apm25"
#elif defined(__arm__)
#define QUAD_LOG_HW "mps2-an386"
#else
#define QUAD_LOG_HW "host"
#endif
#if !defined(QUAD_GIT_HASH)
#define QUAD_GIT_HASH ""
#endif

// Where a topic's format starts in kFormats and its length, counted by the compiler: walking the texts
// in flash from the start for each format and subscription record costs the AVR thousands of cycles in
// the header's armed iterations (docs/logging.md, "Cost on the ATmega2560").
struct FormatSpan {
  uint16_t offset;
  uint16_t length;
};

constexpr FormatSpan format_span(uint8_t topic) {
  uint16_t at = 0;
  for (uint8_t i = 0; i < topic; ++i) {
    while (kFormats[at] != '\0') ++at;
    ++at;
  }
  uint16_t n = 0;
  while (kFormats[at + n] != '\0') ++n;
  return FormatSpan{at, n};
}

constexpr FormatSpan kFormatSpans[kLogTopicCount] QUAD_FLASH = {
    format_span(0), format_span(1), format_span(2), format_span(3), format_span(4),
    format_span(5), format_span(6), format_span(7), format_span(8), format_span(9)};
static_assert(kLogTopicCount == 10, "one span per topic");

FormatSpan log_topic_span(uint8_t topic) {
  FormatSpan span;
  flash_copy(&span, &kFormatSpans[topic], sizeof span);
  return span;
}

}  // namespace

FlashText log_topic_format(uint8_t topic) { return FlashText{kFormats + log_topic_span(topic).offset}; }

void FlightLogger::write_definitions(const FlightApp& app) {
  // On the ground no iteration has a deadline to keep: a log opened at boot gets its definitions in its
  // first iteration, so that its data starts with the first IMU sample (the replay needs the boot
  // calibration's samples).
  const bool armed = app.armed();
  const uint16_t budget = armed ? kHeaderBytesPerIteration : 0xFFFFu;
  const BackgroundBudget& background = app.background();
  uint16_t bytes = 0;
  while (phase_ != kPhaseData && bytes < budget &&
         (!armed || background.fits(app.iteration_elapsed_us(), BackgroundBudget::kDefinitionUs)) && writer_.flush()) {
    if (!next_definition(app, &bytes)) {
      phase_ = kPhaseData;
      write_status(app);
    }
  }
}

bool FlightLogger::next_definition(const FlightApp& app, uint16_t* bytes) {
  switch (phase_) {
    case kPhaseFormats: {
      const FormatSpan span = log_topic_span(item_);
      writer_.format(FlashText{kFormats + span.offset}, span.length);
      *bytes = static_cast<uint16_t>(*bytes + span.length);
      if (++item_ == kLogTopicCount) phase_ = kPhaseInfo, item_ = 0;
      return true;
    }
    case kPhaseInfo:
      switch (item_++) {
        case 0: writer_.info(QUAD_TEXT("sys_name"), QUAD_TEXT("quad-stereo")); break;
        case 1: writer_.info(QUAD_TEXT("ver_hw"), QUAD_TEXT(QUAD_LOG_HW)); break;
        case 2: if (QUAD_GIT_HASH[0] != '\0') writer_.info(QUAD_TEXT("ver_sw"), QUAD_TEXT(QUAD_GIT_HASH)); break;
        default:
          writer_.info(QUAD_TEXT("loop_hz"), static_cast<uint32_t>(app.params().get(kLoopHz) + 0.5f));
          phase_ = kPhaseParams, item_ = 0;
          break;
      }
      *bytes = static_cast<uint16_t>(*bytes + 32);
      return true;
    case kPhaseParams: {
      const ParamInfo info = param_info(item_);
      writer_.parameter(info.name, app.params().get(item_));
      *bytes = static_cast<uint16_t>(*bytes + 30);
      if (++item_ == kParamCount) phase_ = kPhaseSubscriptions, item_ = 0;
      return true;
    }
    case kPhaseSubscriptions:
      if (item_ == kLogTopicCount) return false;
      writer_.add_logged(item_, log_topic_format(item_));
      ++item_;
      *bytes = static_cast<uint16_t>(*bytes + 30);
      return true;
    case kPhaseData:
      break;
  }
  return false;
}

}  // namespace fw
}  // namespace quad
