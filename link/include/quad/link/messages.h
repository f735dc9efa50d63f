// The MAVLink messages this system exchanges, as plain structs with the MAVLink field names.
//
// Members are declared in wire order: MAVLink sorts the base fields by type size, largest first (stable
// for equal sizes, arrays by their element size), then appends the extension fields in definition order.
// `fields()` walks a message in that order with one of the visitors of wire.h; it is the single place the
// layout is written down, shared by the encoder, the decoder and the compile-time length checks at the
// end of this file. Ids, CRC_EXTRA bytes, field order and lengths were checked against mavlink-mappings
// (the definitions node-mavlink uses) and are proven against node-mavlink by tests/link's conformance test.
//
// Every field defaults to zero (HEARTBEAT's mavlink_version to 3, as the protocol requires), so
// `HilSensor msg{};` or `HilSensor msg;` is a valid all-zero message. char arrays are not NUL-terminated
// when full (MAVLink convention); a shorter string is NUL-padded.
#pragma once

#include <stdint.h>

#include "quad/link/wire.h"

namespace quad {
namespace mavlink {

// HEARTBEAT (0): presence, vehicle type, armed state (base_mode) and the flight mode (custom_mode).
struct Heartbeat {
  static constexpr uint32_t kId = 0;
  static constexpr uint8_t kCrcExtra = 50;
  static constexpr uint8_t kBaseLength = 9;
  static constexpr uint8_t kLength = 9;
  static constexpr const char* kName = "HEARTBEAT";
  uint32_t custom_mode = 0;
  uint8_t type = 0;
  uint8_t autopilot = 0;
  uint8_t base_mode = 0;
  uint8_t system_status = 0;
  uint8_t mavlink_version = 3;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.custom_mode); io(m.type); io(m.autopilot); io(m.base_mode); io(m.system_status);
    io(m.mavlink_version);
  }
};

// SYS_STATUS (1): sensor health, loop load (d%), link drop rate and error counts.
struct SysStatus {
  static constexpr uint32_t kId = 1;
  static constexpr uint8_t kCrcExtra = 124;
  static constexpr uint8_t kBaseLength = 31;
  static constexpr uint8_t kLength = 43;
  static constexpr const char* kName = "SYS_STATUS";
  uint32_t onboard_control_sensors_present = 0;
  uint32_t onboard_control_sensors_enabled = 0;
  uint32_t onboard_control_sensors_health = 0;
  uint16_t load = 0;
  uint16_t voltage_battery = 0;
  int16_t current_battery = 0;
  uint16_t drop_rate_comm = 0;
  uint16_t errors_comm = 0;
  uint16_t errors_count1 = 0;
  uint16_t errors_count2 = 0;
  uint16_t errors_count3 = 0;
  uint16_t errors_count4 = 0;
  int8_t battery_remaining = 0;
  // extensions
  uint32_t onboard_control_sensors_present_extended = 0;
  uint32_t onboard_control_sensors_enabled_extended = 0;
  uint32_t onboard_control_sensors_health_extended = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.onboard_control_sensors_present); io(m.onboard_control_sensors_enabled);
    io(m.onboard_control_sensors_health); io(m.load); io(m.voltage_battery); io(m.current_battery);
    io(m.drop_rate_comm); io(m.errors_comm); io(m.errors_count1); io(m.errors_count2);
    io(m.errors_count3); io(m.errors_count4); io(m.battery_remaining);
    io.extensions();
    io(m.onboard_control_sensors_present_extended); io(m.onboard_control_sensors_enabled_extended);
    io(m.onboard_control_sensors_health_extended);
  }
};

// PARAM_REQUEST_READ (20): one parameter by name, or by index when param_index >= 0.
struct ParamRequestRead {
  static constexpr uint32_t kId = 20;
  static constexpr uint8_t kCrcExtra = 214;
  static constexpr uint8_t kBaseLength = 20;
  static constexpr uint8_t kLength = 20;
  static constexpr const char* kName = "PARAM_REQUEST_READ";
  int16_t param_index = 0;
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  char param_id[16] = {};
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.param_index); io(m.target_system); io(m.target_component); io(m.param_id);
  }
};

// PARAM_REQUEST_LIST (21): ask for every parameter.
struct ParamRequestList {
  static constexpr uint32_t kId = 21;
  static constexpr uint8_t kCrcExtra = 159;
  static constexpr uint8_t kBaseLength = 2;
  static constexpr uint8_t kLength = 2;
  static constexpr const char* kName = "PARAM_REQUEST_LIST";
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.target_system); io(m.target_component);
  }
};

// PARAM_VALUE (22): one parameter, with its index and the total count.
struct ParamValue {
  static constexpr uint32_t kId = 22;
  static constexpr uint8_t kCrcExtra = 220;
  static constexpr uint8_t kBaseLength = 25;
  static constexpr uint8_t kLength = 25;
  static constexpr const char* kName = "PARAM_VALUE";
  float param_value = 0.0f;
  uint16_t param_count = 0;
  uint16_t param_index = 0;
  char param_id[16] = {};
  uint8_t param_type = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.param_value); io(m.param_count); io(m.param_index); io(m.param_id); io(m.param_type);
  }
};

// PARAM_SET (23): set one parameter by name.
struct ParamSet {
  static constexpr uint32_t kId = 23;
  static constexpr uint8_t kCrcExtra = 168;
  static constexpr uint8_t kBaseLength = 23;
  static constexpr uint8_t kLength = 23;
  static constexpr const char* kName = "PARAM_SET";
  float param_value = 0.0f;
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  char param_id[16] = {};
  uint8_t param_type = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.param_value); io(m.target_system); io(m.target_component); io(m.param_id); io(m.param_type);
  }
};

// ATTITUDE_QUATERNION (31): attitude q1..q4 = w, x, y, z (Hamilton, scalar first, body to NED).
struct AttitudeQuaternion {
  static constexpr uint32_t kId = 31;
  static constexpr uint8_t kCrcExtra = 246;
  static constexpr uint8_t kBaseLength = 32;
  static constexpr uint8_t kLength = 48;
  static constexpr const char* kName = "ATTITUDE_QUATERNION";
  uint32_t time_boot_ms = 0;
  float q1 = 0.0f;
  float q2 = 0.0f;
  float q3 = 0.0f;
  float q4 = 0.0f;
  float rollspeed = 0.0f;
  float pitchspeed = 0.0f;
  float yawspeed = 0.0f;
  // extensions
  float repr_offset_q[4] = {};
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_boot_ms); io(m.q1); io(m.q2); io(m.q3); io(m.q4); io(m.rollspeed); io(m.pitchspeed);
    io(m.yawspeed);
    io.extensions();
    io(m.repr_offset_q);
  }
};

// LOCAL_POSITION_NED (32): position (m) and velocity (m/s) in the local NED frame.
struct LocalPositionNed {
  static constexpr uint32_t kId = 32;
  static constexpr uint8_t kCrcExtra = 185;
  static constexpr uint8_t kBaseLength = 28;
  static constexpr uint8_t kLength = 28;
  static constexpr const char* kName = "LOCAL_POSITION_NED";
  uint32_t time_boot_ms = 0;
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;
  float vx = 0.0f;
  float vy = 0.0f;
  float vz = 0.0f;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_boot_ms); io(m.x); io(m.y); io(m.z); io(m.vx); io(m.vy); io(m.vz);
  }
};

// MANUAL_CONTROL (69): RC sticks; x pitch, y roll, r yaw in -1000..1000, z throttle 0..1000.
struct ManualControl {
  static constexpr uint32_t kId = 69;
  static constexpr uint8_t kCrcExtra = 243;
  static constexpr uint8_t kBaseLength = 11;
  static constexpr uint8_t kLength = 30;
  static constexpr const char* kName = "MANUAL_CONTROL";
  int16_t x = 0;
  int16_t y = 0;
  int16_t z = 0;
  int16_t r = 0;
  uint16_t buttons = 0;
  uint8_t target = 0;
  // extensions
  uint16_t buttons2 = 0;
  uint8_t enabled_extensions = 0;
  int16_t s = 0;
  int16_t t = 0;
  int16_t aux1 = 0;
  int16_t aux2 = 0;
  int16_t aux3 = 0;
  int16_t aux4 = 0;
  int16_t aux5 = 0;
  int16_t aux6 = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.x); io(m.y); io(m.z); io(m.r); io(m.buttons); io(m.target);
    io.extensions();
    io(m.buttons2); io(m.enabled_extensions); io(m.s); io(m.t); io(m.aux1); io(m.aux2); io(m.aux3);
    io(m.aux4); io(m.aux5); io(m.aux6);
  }
};

// COMMAND_LONG (76): a command (MAV_CMD) with seven parameters.
struct CommandLong {
  static constexpr uint32_t kId = 76;
  static constexpr uint8_t kCrcExtra = 152;
  static constexpr uint8_t kBaseLength = 33;
  static constexpr uint8_t kLength = 33;
  static constexpr const char* kName = "COMMAND_LONG";
  float param1 = 0.0f;
  float param2 = 0.0f;
  float param3 = 0.0f;
  float param4 = 0.0f;
  float param5 = 0.0f;
  float param6 = 0.0f;
  float param7 = 0.0f;
  uint16_t command = 0;
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  uint8_t confirmation = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.param1); io(m.param2); io(m.param3); io(m.param4); io(m.param5); io(m.param6); io(m.param7);
    io(m.command); io(m.target_system); io(m.target_component); io(m.confirmation);
  }
};

// COMMAND_ACK (77): the result (MAV_RESULT) of a command.
struct CommandAck {
  static constexpr uint32_t kId = 77;
  static constexpr uint8_t kCrcExtra = 143;
  static constexpr uint8_t kBaseLength = 3;
  static constexpr uint8_t kLength = 10;
  static constexpr const char* kName = "COMMAND_ACK";
  uint16_t command = 0;
  uint8_t result = 0;
  // extensions
  uint8_t progress = 0;
  int32_t result_param2 = 0;
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.command); io(m.result);
    io.extensions();
    io(m.progress); io(m.result_param2); io(m.target_system); io(m.target_component);
  }
};

// SET_POSITION_TARGET_LOCAL_NED (84): a setpoint in the local NED frame; type_mask bits ignore fields.
struct SetPositionTargetLocalNed {
  static constexpr uint32_t kId = 84;
  static constexpr uint8_t kCrcExtra = 143;
  static constexpr uint8_t kBaseLength = 53;
  static constexpr uint8_t kLength = 53;
  static constexpr const char* kName = "SET_POSITION_TARGET_LOCAL_NED";
  uint32_t time_boot_ms = 0;
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;
  float vx = 0.0f;
  float vy = 0.0f;
  float vz = 0.0f;
  float afx = 0.0f;
  float afy = 0.0f;
  float afz = 0.0f;
  float yaw = 0.0f;
  float yaw_rate = 0.0f;
  uint16_t type_mask = 0;
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  uint8_t coordinate_frame = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_boot_ms); io(m.x); io(m.y); io(m.z); io(m.vx); io(m.vy); io(m.vz); io(m.afx);
    io(m.afy); io(m.afz); io(m.yaw); io(m.yaw_rate); io(m.type_mask); io(m.target_system);
    io(m.target_component); io(m.coordinate_frame);
  }
};

// HIL_ACTUATOR_CONTROLS (93): motor commands from the autopilot to the simulator.
struct HilActuatorControls {
  static constexpr uint32_t kId = 93;
  static constexpr uint8_t kCrcExtra = 47;
  static constexpr uint8_t kBaseLength = 81;
  static constexpr uint8_t kLength = 81;
  static constexpr const char* kName = "HIL_ACTUATOR_CONTROLS";
  uint64_t time_usec = 0;
  uint64_t flags = 0;
  float controls[16] = {};
  uint8_t mode = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_usec); io(m.flags); io(m.controls); io(m.mode);
  }
};

// VISION_POSITION_ESTIMATE (102): the vehicle's position from an external system, at capture time usec.
struct VisionPositionEstimate {
  static constexpr uint32_t kId = 102;
  static constexpr uint8_t kCrcExtra = 158;
  static constexpr uint8_t kBaseLength = 32;
  static constexpr uint8_t kLength = 117;
  static constexpr const char* kName = "VISION_POSITION_ESTIMATE";
  uint64_t usec = 0;
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;
  float roll = 0.0f;
  float pitch = 0.0f;
  float yaw = 0.0f;
  // extensions
  float covariance[21] = {};
  uint8_t reset_counter = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.usec); io(m.x); io(m.y); io(m.z); io(m.roll); io(m.pitch); io(m.yaw);
    io.extensions();
    io(m.covariance); io(m.reset_counter);
  }
};

// HIL_SENSOR (107): IMU and magnetometer samples from the simulator, in the body frame (FRD).
struct HilSensor {
  static constexpr uint32_t kId = 107;
  static constexpr uint8_t kCrcExtra = 108;
  static constexpr uint8_t kBaseLength = 64;
  static constexpr uint8_t kLength = 65;
  static constexpr const char* kName = "HIL_SENSOR";
  uint64_t time_usec = 0;
  float xacc = 0.0f;
  float yacc = 0.0f;
  float zacc = 0.0f;
  float xgyro = 0.0f;
  float ygyro = 0.0f;
  float zgyro = 0.0f;
  float xmag = 0.0f;
  float ymag = 0.0f;
  float zmag = 0.0f;
  float abs_pressure = 0.0f;
  float diff_pressure = 0.0f;
  float pressure_alt = 0.0f;
  float temperature = 0.0f;
  uint32_t fields_updated = 0;
  // extensions
  uint8_t id = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_usec); io(m.xacc); io(m.yacc); io(m.zacc); io(m.xgyro); io(m.ygyro); io(m.zgyro);
    io(m.xmag); io(m.ymag); io(m.zmag); io(m.abs_pressure); io(m.diff_pressure); io(m.pressure_alt);
    io(m.temperature); io(m.fields_updated);
    io.extensions();
    io(m.id);
  }
};

// TIMESYNC (111): clock synchronisation; tc1 = 0 in a request, the responder's time in the answer.
struct Timesync {
  static constexpr uint32_t kId = 111;
  static constexpr uint8_t kCrcExtra = 34;
  static constexpr uint8_t kBaseLength = 16;
  static constexpr uint8_t kLength = 18;
  static constexpr const char* kName = "TIMESYNC";
  int64_t tc1 = 0;
  int64_t ts1 = 0;
  // extensions
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.tc1); io(m.ts1);
    io.extensions();
    io(m.target_system); io(m.target_component);
  }
};

// HIL_STATE_QUATERNION (115): the simulator's ground truth (attitude_quaternion w, x, y, z).
struct HilStateQuaternion {
  static constexpr uint32_t kId = 115;
  static constexpr uint8_t kCrcExtra = 4;
  static constexpr uint8_t kBaseLength = 64;
  static constexpr uint8_t kLength = 64;
  static constexpr const char* kName = "HIL_STATE_QUATERNION";
  uint64_t time_usec = 0;
  float attitude_quaternion[4] = {};
  float rollspeed = 0.0f;
  float pitchspeed = 0.0f;
  float yawspeed = 0.0f;
  int32_t lat = 0;
  int32_t lon = 0;
  int32_t alt = 0;
  int16_t vx = 0;
  int16_t vy = 0;
  int16_t vz = 0;
  uint16_t ind_airspeed = 0;
  uint16_t true_airspeed = 0;
  int16_t xacc = 0;
  int16_t yacc = 0;
  int16_t zacc = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_usec); io(m.attitude_quaternion); io(m.rollspeed); io(m.pitchspeed); io(m.yawspeed);
    io(m.lat); io(m.lon); io(m.alt); io(m.vx); io(m.vy); io(m.vz); io(m.ind_airspeed);
    io(m.true_airspeed); io(m.xacc); io(m.yacc); io(m.zacc);
  }
};

// LOG_REQUEST_LIST (117): ask for the LOG_ENTRY of logs start..end (0xFFFF: to the last).
struct LogRequestList {
  static constexpr uint32_t kId = 117;
  static constexpr uint8_t kCrcExtra = 128;
  static constexpr uint8_t kBaseLength = 6;
  static constexpr uint8_t kLength = 6;
  static constexpr const char* kName = "LOG_REQUEST_LIST";
  uint16_t start = 0;
  uint16_t end = 0;
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.start); io(m.end); io(m.target_system); io(m.target_component);
  }
};

// LOG_ENTRY (118): one log held by the vehicle (id 1..num_logs; num_logs 0: none).
struct LogEntry {
  static constexpr uint32_t kId = 118;
  static constexpr uint8_t kCrcExtra = 56;
  static constexpr uint8_t kBaseLength = 14;
  static constexpr uint8_t kLength = 14;
  static constexpr const char* kName = "LOG_ENTRY";
  uint32_t time_utc = 0;  // s since 1970, 0 when unknown
  uint32_t size = 0;      // bytes
  uint16_t id = 0;
  uint16_t num_logs = 0;
  uint16_t last_log_num = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_utc); io(m.size); io(m.id); io(m.num_logs); io(m.last_log_num);
  }
};

// LOG_REQUEST_DATA (119): ask for count bytes of log id from ofs (0xFFFFFFFF: to its end).
struct LogRequestData {
  static constexpr uint32_t kId = 119;
  static constexpr uint8_t kCrcExtra = 116;
  static constexpr uint8_t kBaseLength = 12;
  static constexpr uint8_t kLength = 12;
  static constexpr const char* kName = "LOG_REQUEST_DATA";
  uint32_t ofs = 0;
  uint32_t count = 0;
  uint16_t id = 0;
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.ofs); io(m.count); io(m.id); io(m.target_system); io(m.target_component);
  }
};

// LOG_DATA (120): count bytes of log id at ofs (count 0: ofs is at or past the end).
struct LogData {
  static constexpr uint32_t kId = 120;
  static constexpr uint8_t kCrcExtra = 134;
  static constexpr uint8_t kBaseLength = 97;
  static constexpr uint8_t kLength = 97;
  static constexpr const char* kName = "LOG_DATA";
  static constexpr uint8_t kDataLength = 90;
  uint32_t ofs = 0;
  uint16_t id = 0;
  uint8_t count = 0;
  uint8_t data[kDataLength] = {};
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.ofs); io(m.id); io(m.count); io(m.data);
  }
};

// LOG_ERASE (121): erase every log.
struct LogErase {
  static constexpr uint32_t kId = 121;
  static constexpr uint8_t kCrcExtra = 237;
  static constexpr uint8_t kBaseLength = 2;
  static constexpr uint8_t kLength = 2;
  static constexpr const char* kName = "LOG_ERASE";
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.target_system); io(m.target_component);
  }
};

// LOG_REQUEST_END (122): stop sending LOG_DATA.
struct LogRequestEnd {
  static constexpr uint32_t kId = 122;
  static constexpr uint8_t kCrcExtra = 203;
  static constexpr uint8_t kBaseLength = 2;
  static constexpr uint8_t kLength = 2;
  static constexpr const char* kName = "LOG_REQUEST_END";
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.target_system); io(m.target_component);
  }
};

// ATT_POS_MOCAP (138): a motion-capture system's pose of the vehicle: q body FRD to NED (w first), x y z
// NED, at time_usec; covariance the 6x6 pose covariance's upper triangle by rows (x y z roll pitch yaw),
// NaN in its first element when unknown.
struct AttPosMocap {
  static constexpr uint32_t kId = 138;
  static constexpr uint8_t kCrcExtra = 109;
  static constexpr uint8_t kBaseLength = 36;
  static constexpr uint8_t kLength = 120;
  static constexpr const char* kName = "ATT_POS_MOCAP";
  uint64_t time_usec = 0;
  float q[4] = {};
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;
  // extensions
  float covariance[21] = {};
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_usec); io(m.q); io(m.x); io(m.y); io(m.z);
    io.extensions();
    io(m.covariance);
  }
};

// LANDING_TARGET (149): a target seen from the vehicle; here the star, x/y/z in body FRD (frame 12).
struct LandingTarget {
  static constexpr uint32_t kId = 149;
  static constexpr uint8_t kCrcExtra = 200;
  static constexpr uint8_t kBaseLength = 30;
  static constexpr uint8_t kLength = 60;
  static constexpr const char* kName = "LANDING_TARGET";
  uint64_t time_usec = 0;
  float angle_x = 0.0f;
  float angle_y = 0.0f;
  float distance = 0.0f;
  float size_x = 0.0f;
  float size_y = 0.0f;
  uint8_t target_num = 0;
  uint8_t frame = 0;
  // extensions
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;
  float q[4] = {};
  uint8_t type = 0;
  uint8_t position_valid = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_usec); io(m.angle_x); io(m.angle_y); io(m.distance); io(m.size_x); io(m.size_y);
    io(m.target_num); io(m.frame);
    io.extensions();
    io(m.x); io(m.y); io(m.z); io(m.q); io(m.type); io(m.position_valid);
  }
};

// ESTIMATOR_STATUS (230): the estimator's health: innovation test ratios (NIS over the gate: above 1 a
// measurement is refused), accuracies (1 sigma) and ESTIMATOR_STATUS_FLAGS (enums.h).
struct EstimatorStatus {
  static constexpr uint32_t kId = 230;
  static constexpr uint8_t kCrcExtra = 163;
  static constexpr uint8_t kBaseLength = 42;
  static constexpr uint8_t kLength = 42;
  static constexpr const char* kName = "ESTIMATOR_STATUS";
  uint64_t time_usec = 0;
  float vel_ratio = 0.0f;
  float pos_horiz_ratio = 0.0f;
  float pos_vert_ratio = 0.0f;
  float mag_ratio = 0.0f;
  float hagl_ratio = 0.0f;
  float tas_ratio = 0.0f;
  float pos_horiz_accuracy = 0.0f;
  float pos_vert_accuracy = 0.0f;
  uint16_t flags = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.time_usec); io(m.vel_ratio); io(m.pos_horiz_ratio); io(m.pos_vert_ratio); io(m.mag_ratio);
    io(m.hagl_ratio); io(m.tas_ratio); io(m.pos_horiz_accuracy); io(m.pos_vert_accuracy); io(m.flags);
  }
};

// EXTENDED_SYS_STATE (245): VTOL state and landed state (MAV_LANDED_STATE: on ground, in air, landing).
struct ExtendedSysState {
  static constexpr uint32_t kId = 245;
  static constexpr uint8_t kCrcExtra = 130;
  static constexpr uint8_t kBaseLength = 2;
  static constexpr uint8_t kLength = 2;
  static constexpr const char* kName = "EXTENDED_SYS_STATE";
  uint8_t vtol_state = 0;
  uint8_t landed_state = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.vtol_state); io(m.landed_state);
  }
};

// STATUSTEXT (253): a human-readable status line (severity = MAV_SEVERITY).
struct Statustext {
  static constexpr uint32_t kId = 253;
  static constexpr uint8_t kCrcExtra = 83;
  static constexpr uint8_t kBaseLength = 51;
  static constexpr uint8_t kLength = 54;
  static constexpr const char* kName = "STATUSTEXT";
  uint8_t severity = 0;
  char text[50] = {};
  // extensions
  uint16_t id = 0;
  uint8_t chunk_seq = 0;
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.severity); io(m.text);
    io.extensions();
    io(m.id); io(m.chunk_seq);
  }
};

// Calls f(Msg{}) once for every message type above, so tests and dispatch code can cover every message
// without repeating the list.
template <class F>
void for_each_message_type(F&& f) {
  f(Heartbeat{}); f(SysStatus{}); f(ParamRequestRead{}); f(ParamRequestList{}); f(ParamValue{});
  f(ParamSet{}); f(AttitudeQuaternion{}); f(LocalPositionNed{}); f(ManualControl{}); f(CommandLong{});
  f(CommandAck{}); f(SetPositionTargetLocalNed{}); f(HilActuatorControls{}); f(VisionPositionEstimate{});
  f(HilSensor{}); f(Timesync{}); f(HilStateQuaternion{}); f(LogRequestList{}); f(LogEntry{});
  f(LogRequestData{}); f(LogData{}); f(LogErase{}); f(LogRequestEnd{}); f(AttPosMocap{}); f(LandingTarget{});
  f(EstimatorStatus{});
  f(ExtendedSysState{});
  f(Statustext{});
}

// The declared lengths must equal the sum of the declared fields: a missing or mistyped field fails to
// compile rather than shifting every later field on the wire.
template <class Msg>
constexpr bool lengths_match_fields() {
  return wire::count_fields<Msg>().length == Msg::kLength &&
         wire::count_fields<Msg>().base_length == Msg::kBaseLength;
}
static_assert(lengths_match_fields<Heartbeat>(), "HEARTBEAT layout");
static_assert(lengths_match_fields<SysStatus>(), "SYS_STATUS layout");
static_assert(lengths_match_fields<ParamRequestRead>(), "PARAM_REQUEST_READ layout");
static_assert(lengths_match_fields<ParamRequestList>(), "PARAM_REQUEST_LIST layout");
static_assert(lengths_match_fields<ParamValue>(), "PARAM_VALUE layout");
static_assert(lengths_match_fields<ParamSet>(), "PARAM_SET layout");
static_assert(lengths_match_fields<AttitudeQuaternion>(), "ATTITUDE_QUATERNION layout");
static_assert(lengths_match_fields<LocalPositionNed>(), "LOCAL_POSITION_NED layout");
static_assert(lengths_match_fields<ManualControl>(), "MANUAL_CONTROL layout");
static_assert(lengths_match_fields<CommandLong>(), "COMMAND_LONG layout");
static_assert(lengths_match_fields<CommandAck>(), "COMMAND_ACK layout");
static_assert(lengths_match_fields<SetPositionTargetLocalNed>(), "SET_POSITION_TARGET_LOCAL_NED layout");
static_assert(lengths_match_fields<HilActuatorControls>(), "HIL_ACTUATOR_CONTROLS layout");
static_assert(lengths_match_fields<VisionPositionEstimate>(), "VISION_POSITION_ESTIMATE layout");
static_assert(lengths_match_fields<HilSensor>(), "HIL_SENSOR layout");
static_assert(lengths_match_fields<Timesync>(), "TIMESYNC layout");
static_assert(lengths_match_fields<HilStateQuaternion>(), "HIL_STATE_QUATERNION layout");
static_assert(lengths_match_fields<LogRequestList>(), "LOG_REQUEST_LIST layout");
static_assert(lengths_match_fields<LogEntry>(), "LOG_ENTRY layout");
static_assert(lengths_match_fields<LogRequestData>(), "LOG_REQUEST_DATA layout");
static_assert(lengths_match_fields<LogData>(), "LOG_DATA layout");
static_assert(lengths_match_fields<LogErase>(), "LOG_ERASE layout");
static_assert(lengths_match_fields<LogRequestEnd>(), "LOG_REQUEST_END layout");
static_assert(lengths_match_fields<AttPosMocap>(), "ATT_POS_MOCAP layout");
static_assert(lengths_match_fields<LandingTarget>(), "LANDING_TARGET layout");
static_assert(lengths_match_fields<EstimatorStatus>(), "ESTIMATOR_STATUS layout");
static_assert(lengths_match_fields<ExtendedSysState>(), "EXTENDED_SYS_STATE layout");
static_assert(lengths_match_fields<Statustext>(), "STATUSTEXT layout");

}  // namespace mavlink
}  // namespace quad
