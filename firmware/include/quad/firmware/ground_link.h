// The ground link: the MAVLink side of the vehicle on its two serial ports (UART0: USB, or the HIL link;
// UART2: the radio to the ground station and the vision station).
//
// It owns the parsers and senders, the radio's signing, the one check that a message is addressed to this
// vehicle, the parameter protocol's wire side, the translation of commands and RC frames, TIMESYNC and key
// provisioning, and the log protocol's wire side (LOG_REQUEST_LIST .. LOG_REQUEST_END, served from the
// LogStore in Io). What the messages ask of the vehicle goes to a handler (the flight application) through
// plain member calls resolved at compile time (receive() is a template): no virtual dispatch.
//
// The handler provides:
//   void hil_frame(const mavlink::Frame&)                   HIL_SENSOR (the HIL bridge decodes it)
//   Transition mode_command(Command)                         a command for the mode machine
//   void report_transition(const Transition&)                after the command's ACK
//   void rc_input(const ctrl::RcSticks&, uint32_t, const RcSwitches*)
//   void position_target(const Vec3&, const float* yaw)      SET_POSITION_TARGET_LOCAL_NED
//   void star_fix(const mavlink::LandingTarget&)             LANDING_TARGET from the vision station
//   void star_covariance(const mavlink::LandingTargetCovariance&)   its covariances (the project's dialect)
//   void external_pose(const ExternalPose&)                  ATT_POS_MOCAP, VISION_POSITION_ESTIMATE, and
//                                                            EXTERNAL_POSE_TARGETED addressed to this vehicle
//   ParamUpdate set_param(uint8_t index, float value)        PARAM_SET, found by name
//   uint32_t now_us() const, uint64_t timesync_us() const    the vehicle clock
#pragma once

#include <stdint.h>

#include "quad/firmware/external_pose.h"
#include "quad/firmware/flight_control.h"
#include "quad/firmware/log_store.h"
#include "quad/firmware/params.h"
#include "quad/firmware/radio_signing.h"
#include "quad/firmware/status_text.h"
#include "quad/hal/hal.h"
#include "quad/link/dialect.h"
#include "quad/link/mavlink.h"

namespace quad {
namespace fw {

// The outcome of a PARAM_SET the handler applied.
struct ParamUpdate {
  enum class Status : uint8_t { kApplied, kNotFinite, kOutOfRange, kRefused, kNotStored };
  Status status = Status::kApplied;
  const char* field = nullptr;  // kRefused: the parameter a component refused
};

struct LinkCounters {
  uint32_t commands = 0;          // COMMAND_LONG addressed to this vehicle
  uint32_t tx_dropped_bytes = 0;  // bytes the ports did not take
};

class GroundLink {
 public:
  struct Io {
    StorageIo storage;
    // Queues bytes on a serial port; frames that do not fit are dropped.
    uint16_t (*write)(uint8_t port, const uint8_t* data, uint16_t length);
    // Optional: every STATUSTEXT line also goes here (the host prints it on stderr).
    void (*console)(uint8_t severity, const char* text, uint8_t length);
    // Optional: every STATUSTEXT message also goes here, with its context (the flight log).
    void (*statustext)(void* context, const mavlink::Statustext& msg);
    void* statustext_context;
    // Optional: the flight logs served by the log protocol (null: the vehicle holds none).
    const LogStore* log_store;
    // Optional: bytes a port's transmit queue takes now (null: as many as offered); LOG_DATA waits for
    // room for a whole frame.
    uint16_t (*tx_free)(uint8_t port);
  };

  // params: the table in force, read by the parameter protocol.
  void init(const Io& io, const Params* params);
  // False when the key store is corrupt.
  const StorageIo& storage() const { return io_.storage; }
  bool load_signing_key() { return radio_.load(io_.storage); }
  void configure(const Params& p) { radio_.set_enabled(p.get(kSignEnable) >= 0.5f); }

  // The bytes a port received: every complete frame that passes the radio's signature check is handed
  // to the handler (h).
  template <class Handler>
  void receive(uint8_t port, const uint8_t* data, uint16_t length, Handler& h);

  // Work spread over the loop's iterations: the next parameter of a PARAM_REQUEST_LIST being answered.
  // Returns whether it sent one.
  bool stream_params();
  // The next LOG_ENTRY of a LOG_REQUEST_LIST, else the next LOG_DATA of a LOG_REQUEST_DATA when its port
  // has room for it (ground_link_logs.cpp). Returns whether it sent one.
  bool stream_logs();
  // Whether a parameter list, a log list or a log download is being answered.
  bool streaming() const { return param_stream_next_ >= 0 || list_next_ != 0 || data_id_ != 0; }
  // A storage write blocks the AVR's loop for milliseconds: the signing clock is saved on the ground,
  // at most every few seconds, and at once with force.
  void persist_signing_clock(uint32_t now_us, bool force) { radio_.persist_clock(io_.storage, now_us, force); }

  template <class Msg>
  void send(uint8_t port, const Msg& msg);
  template <class Msg>
  void broadcast(const Msg& msg);
  void send_statustext(uint8_t severity, FlashText text);
  void send_statustext(const mavlink::Statustext& msg);

  const mavlink::Parser& parser(uint8_t port) const { return parsers_[port]; }
  const RadioSigning& radio_signing() const { return radio_; }
  const LinkCounters& counters() const { return counters_; }

 private:
  // The codec's messages plus the dialect's (the radio's parser then refuses SETUP_SIGNING explicitly).
  struct DialectParser : mavlink::Parser {
    DialectParser() : mavlink::Parser(mavlink::dialect_message_info) {}
  };

  template <class Handler>
  void dispatch(uint8_t port, const mavlink::Frame& frame, Handler& h);
  // The external poses, read from the frame where it lies (external_pose.h).
  template <class Handler>
  void on_external_pose(const mavlink::Frame& frame, Handler& h);
  template <class Handler>
  void on_command(uint8_t port, const mavlink::CommandLong& cmd, Handler& h);
  template <class Handler>
  void on_param_set(uint8_t port, const mavlink::ParamSet& msg, Handler& h);
  // The mode-machine command a COMMAND_LONG asks for; false (after its ACK) when it asks for none.
  bool to_mode_command(uint8_t port, const mavlink::CommandLong& cmd, Command* c);
  void on_setup_signing(uint8_t port, const mavlink::SetupSigning& msg);
  void on_timesync(uint8_t port, const mavlink::Timesync& msg, uint64_t now_us);
  // The log protocol's messages (ground_link_logs.cpp); other frames are ignored.
  void dispatch_log(uint8_t port, const mavlink::Frame& frame);
  void on_log_request_list(uint8_t port, const mavlink::LogRequestList& msg);
  void on_log_request_data(uint8_t port, const mavlink::LogRequestData& msg);
  void on_log_erase();
  void send_log_entry(uint8_t port, uint16_t id);
  void send_log_data();
  void report_param_update(ParamUpdate u, uint8_t index);
  void send_param(uint8_t port, uint8_t index);
  void send_ack(uint8_t port, uint16_t command, uint8_t result);
  // Finishes (and on the radio signs) a frame whose payload send() wrote into `buffer`, and queues it.
  void transmit(uint8_t port, uint32_t message_id, uint8_t crc_extra, uint8_t full_length, uint8_t* buffer);

  Io io_{};
  const Params* params_ = nullptr;
  DialectParser parsers_[hal::kPortCount];
  RadioSigning radio_;
  mavlink::Sender senders_[hal::kPortCount] = {
      mavlink::Sender(mavlink::kVehicleSystemId, mavlink::kVehicleComponentId),
      mavlink::Sender(mavlink::kVehicleSystemId, mavlink::kVehicleComponentId)};
  int16_t param_stream_next_ = -1;  // next index of a PARAM_REQUEST_LIST being answered, -1 when idle
  uint8_t param_stream_port_ = 0;
  // The log protocol's streams: LOG_ENTRY list_next..list_last (list_next 0: idle), LOG_DATA of log
  // data_id (0: idle) from data_ofs up to data_end (exclusive).
  uint16_t list_next_ = 0, list_last_ = 0;
  uint8_t list_port_ = 0, data_port_ = 0;
  uint16_t data_id_ = 0;
  uint32_t data_ofs_ = 0, data_end_ = 0;
  LinkCounters counters_;
};

// A message is for this vehicle when it names it or no one.
inline bool addressed_to_vehicle(uint8_t target_system) {
  return target_system == mavlink::kVehicleSystemId || target_system == 0;
}

// MANUAL_CONTROL (docs/hil-protocol.md) as the receiver's pulses and the two toggle switches.
void manual_control_to_rc(const mavlink::ManualControl& msg, ctrl::RcSticks* sticks, RcSwitches* switches);

// ---------------------------------------------------------------------------------------------------

template <class Handler>
void GroundLink::receive(uint8_t port, const uint8_t* data, uint16_t length, Handler& h) {
  if (port >= hal::kPortCount) return;
  parsers_[port].feed(data, length, [this, port, &h](const mavlink::Frame& frame) {
    // The radio is where strangers can talk: its frames pass the signature check first (counted).
    if (port == hal::kUart2 && !mavlink::accepted(radio_.check(frame))) return;
    // HIL_SENSOR runs a whole iteration: outside dispatch(), so its message locals are not on the stack
    // under it (the ATmega2560's RAM budget counts the peak stack).
    if (frame.message_id == mavlink::HilSensor::kId) {
      h.hil_frame(frame);
      return;
    }
    dispatch(port, frame, h);
  });
}

template <class Handler>
void GroundLink::dispatch(uint8_t port, const mavlink::Frame& frame, Handler& h) {
  namespace mav = ::quad::mavlink;
  switch (frame.message_id) {
    case mav::CommandLong::kId: {
      mav::CommandLong msg;
      if (mav::decode(frame, msg) && addressed_to_vehicle(msg.target_system)) on_command(port, msg, h);
      break;
    }
    case mav::ManualControl::kId: {
      mav::ManualControl msg;
      if (!mav::decode(frame, msg)) break;
      ctrl::RcSticks sticks;
      RcSwitches switches;
      manual_control_to_rc(msg, &sticks, &switches);
      h.rc_input(sticks, h.now_us(), &switches);
      break;
    }
    case mav::SetPositionTargetLocalNed::kId: {
      mav::SetPositionTargetLocalNed msg;
      constexpr uint16_t kIgnorePosition = 0x7u, kIgnoreYaw = 0x400u;  // type_mask bits
      if (!mav::decode(frame, msg) || !addressed_to_vehicle(msg.target_system)) break;
      if (msg.coordinate_frame != mav::kFrameLocalNed || (msg.type_mask & kIgnorePosition) != 0) break;
      const bool with_yaw = (msg.type_mask & kIgnoreYaw) == 0;
      h.position_target(Vec3{msg.x, msg.y, msg.z}, with_yaw ? &msg.yaw : nullptr);
      break;
    }
    case mav::LandingTarget::kId: {
      mav::LandingTarget msg;
      if (mav::decode(frame, msg)) h.star_fix(msg);
      break;
    }
    case mav::LandingTargetCovariance::kId: {
      mav::LandingTargetCovariance msg;
      if (mav::decode(frame, msg)) h.star_covariance(msg);
      break;
    }
    case mav::VisionPositionEstimate::kId:
    case mav::AttPosMocap::kId:
    case mav::ExternalPoseTargeted::kId:
      on_external_pose(frame, h);
      break;
    case mav::ParamRequestList::kId: {
      mav::ParamRequestList msg;
      if (mav::decode(frame, msg) && addressed_to_vehicle(msg.target_system)) {
        param_stream_next_ = 0;
        param_stream_port_ = port;
      }
      break;
    }
    case mav::ParamRequestRead::kId: {
      mav::ParamRequestRead msg;
      if (!mav::decode(frame, msg) || !addressed_to_vehicle(msg.target_system)) break;
      const int16_t index = msg.param_index >= 0 ? msg.param_index : param_find(msg.param_id);
      // MAVLink: unknown parameters get no answer.
      if (index >= 0 && index < kParamCount) send_param(port, static_cast<uint8_t>(index));
      break;
    }
    case mav::ParamSet::kId: {
      mav::ParamSet msg;
      if (mav::decode(frame, msg) && addressed_to_vehicle(msg.target_system)) on_param_set(port, msg, h);
      break;
    }
    case mav::Timesync::kId: {
      mav::Timesync msg;
      if (mav::decode(frame, msg)) on_timesync(port, msg, h.timesync_us());
      break;
    }
    case mav::SetupSigning::kId: {
      mav::SetupSigning msg;
      if (mav::decode(frame, msg) && addressed_to_vehicle(msg.target_system)) on_setup_signing(port, msg);
      break;
    }
    default:
      dispatch_log(port, frame);
      break;
  }
}

template <class Handler>
void GroundLink::on_external_pose(const mavlink::Frame& frame, Handler& h) {
  ExternalPose pose;
  if (frame.message_id == mavlink::AttPosMocap::kId) {
    decode_att_pos_mocap(frame, &pose);
  } else if (frame.message_id == mavlink::VisionPositionEstimate::kId) {
    decode_vision_position_estimate(frame, &pose);
  } else if (decode_external_pose_targeted(frame, &pose) != mavlink::kVehicleSystemId) {
    return;  // another vehicle's on a shared channel (0, everyone, means nothing for a pose)
  }
  h.external_pose(pose);
}

template <class Handler>
void GroundLink::on_command(uint8_t port, const mavlink::CommandLong& cmd, Handler& h) {
  ++counters_.commands;
  Command c;
  if (!to_mode_command(port, cmd, &c)) return;
  const Transition t = h.mode_command(c);
  send_ack(port, cmd.command, t.accepted ? mavlink::kResultAccepted : mavlink::kResultDenied);
  h.report_transition(t);
}

template <class Handler>
void GroundLink::on_param_set(uint8_t port, const mavlink::ParamSet& msg, Handler& h) {
  const int16_t index = param_find(msg.param_id);
  if (index < 0) {
    char name[kParamNameLength + 1];
    memcpy(name, msg.param_id, kParamNameLength);
    name[kParamNameLength] = '\0';
    send_statustext((StatusLine(mavlink::kSeverityWarning) << QUAD_TEXT("no such param: ") << name).message());
    return;
  }
  const uint8_t i = static_cast<uint8_t>(index);
  report_param_update(h.set_param(i, msg.param_value), i);
  // Always answer with the value now in force, so the sender sees whether its value was taken.
  send_param(port, i);
}

// Only the payload depends on the message type; the frame is finished, signed and written by transmit()
// (one copy of that code, not one per message type: AVR flash).
template <class Msg>
void GroundLink::send(uint8_t port, const Msg& msg) {
  uint8_t buffer[mavlink::max_frame_length<Msg>(true)];
  mavlink::write_payload(msg, buffer);
  transmit(port, Msg::kId, Msg::kCrcExtra, Msg::kLength, buffer);
}

template <class Msg>
void GroundLink::broadcast(const Msg& msg) {
  for (uint8_t port = 0; port < hal::kPortCount; ++port) send(port, msg);
}

}  // namespace fw
}  // namespace quad
