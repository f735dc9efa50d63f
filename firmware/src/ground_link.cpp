#include "quad/firmware/ground_link.h"

#include <string.h>

namespace quad {
namespace fw {
namespace mav = ::quad::mavlink;

namespace {

// MANUAL_CONTROL axis (-1000..1000) to a 1000..2000 us pulse.
uint16_t axis_to_pulse(int16_t v, bool reverse) {
  const int32_t axis = reverse ? -static_cast<int32_t>(v) : static_cast<int32_t>(v);
  int32_t p = 1500 + axis / 2;
  if (p < 1000) p = 1000;
  if (p > 2000) p = 2000;
  return static_cast<uint16_t>(p);
}

void copy_name(char (&dst)[16], const char* src) {
  memset(dst, 0, sizeof dst);
  for (uint8_t i = 0; i < 16 && src[i] != '\0'; ++i) dst[i] = src[i];
}

// MAV_CMD_DO_SET_MODE's param2 as a flight mode: only the exact values of the dialect's modes are modes
// (and a NaN or huge float must not reach the int cast).
bool custom_mode(float param2, FlightMode* mode) {
  if (!(param2 >= 0.0f && param2 < static_cast<float>(mav::kFlightModeCount))) return false;
  const int n = static_cast<int>(param2);
  if (param2 != static_cast<float>(n)) return false;
  *mode = static_cast<FlightMode>(n);
  return true;
}

}  // namespace

void manual_control_to_rc(const mav::ManualControl& msg, ctrl::RcSticks* sticks, RcSwitches* switches) {
  // docs/hil-protocol.md: x pitch (forward +), y roll (right +), z throttle 0..1000, r yaw (right +).
  // A forward stick is a pulse below 1500 on the pitch channel (nose down, control/manual.h).
  sticks->roll = axis_to_pulse(msg.y, false);
  sticks->pitch = axis_to_pulse(msg.x, true);
  sticks->yaw = axis_to_pulse(msg.r, false);
  const int32_t throttle = 1000 + (msg.z < 0 ? 0 : static_cast<int32_t>(msg.z));
  sticks->throttle = static_cast<uint16_t>(throttle > 2000 ? 2000 : throttle);
  // Buttons bit 0: motor-enable switch, bit 1: manual/auto switch (used with RC_SWITCHES only).
  switches->motors_enabled = (msg.buttons & 0x1u) != 0;
  switches->auto_mode = (msg.buttons & 0x2u) != 0;
}

void GroundLink::init(const Io& io, const Params* params) {
  io_ = io;
  params_ = params;
}

bool GroundLink::to_mode_command(uint8_t port, const mav::CommandLong& cmd, Command* c) {
  switch (cmd.command) {
    case mav::kCmdComponentArmDisarm:
      *c = cmd.param1 >= 0.5f ? Command::kArm
                              : (cmd.param2 == mav::kForceDisarmMagic ? Command::kForceDisarm : Command::kDisarm);
      return true;
    case mav::kCmdNavLand:
      *c = Command::kLand;
      return true;
    case mav::kCmdDoSetMode: {
      FlightMode mode;
      if (!custom_mode(cmd.param2, &mode)) {
        send_ack(port, cmd.command, mav::kResultDenied);
        send_statustext(mav::kSeverityWarning, QUAD_TEXT("unknown custom mode"));
        return false;
      }
      *c = command_for(mode);
      return true;
    }
    default:
      send_ack(port, cmd.command, mav::kResultUnsupported);
      return false;
  }
}

void GroundLink::on_timesync(uint8_t port, const mav::Timesync& msg, uint64_t now_us) {
  if (msg.tc1 != 0) return;  // an answer to someone else's request
  // TIMESYNC answer: our clock in tc1 (ns), the request's ts1 echoed, so the peer can map its capture
  // times onto the vehicle clock.
  mav::Timesync reply;
  reply.tc1 = static_cast<int64_t>(now_us) * 1000;
  reply.ts1 = msg.ts1;
  send(port, reply);
}

void GroundLink::on_setup_signing(uint8_t port, const mav::SetupSigning& msg) {
  if (port != hal::kUart0) {
    // Keys are provisioned over the USB cable only, even by someone who holds the current key.
    radio_.refuse_provisioning();
    send_statustext(mav::kSeverityWarning, QUAD_TEXT("signing: key refused on radio"));
    return;
  }
  switch (radio_.provision(io_.storage, msg)) {
    case RadioSigning::Provisioned::kKeySet:
      send_statustext(mav::kSeverityInfo, QUAD_TEXT("signing: key set"));
      break;
    case RadioSigning::Provisioned::kSigningOff:
      send_statustext(mav::kSeverityWarning, QUAD_TEXT("signing: key removed"));
      break;
    case RadioSigning::Provisioned::kStorageFailed:
      send_statustext(mav::kSeverityError, QUAD_TEXT("signing: key in use, not stored"));
      break;
  }
}

void GroundLink::report_param_update(ParamUpdate u, uint8_t index) {
  switch (u.status) {
    case ParamUpdate::Status::kApplied:
      return;
    case ParamUpdate::Status::kNotFinite:
    case ParamUpdate::Status::kOutOfRange: {
      const ParamInfo info = param_info(index);
      send_statustext((StatusLine(mav::kSeverityWarning)
                       << (u.status == ParamUpdate::Status::kNotFinite ? QUAD_TEXT("param not finite: ")
                                                                       : QUAD_TEXT("param out of range: "))
                       << info.name)
                          .message());
      return;
    }
    case ParamUpdate::Status::kRefused:
      send_statustext((StatusLine(mav::kSeverityWarning) << QUAD_TEXT("param refused: ") << u.field).message());
      return;
    case ParamUpdate::Status::kNotStored:
      send_statustext(mav::kSeverityError, QUAD_TEXT("param storage write failed"));
      return;
  }
}

bool GroundLink::stream_params() {
  if (param_stream_next_ < 0) return false;
  send_param(param_stream_port_, static_cast<uint8_t>(param_stream_next_));
  if (++param_stream_next_ >= kParamCount) param_stream_next_ = -1;
  return true;
}

void GroundLink::send_param(uint8_t port, uint8_t index) {
  const ParamInfo info = param_info(index);
  mav::ParamValue msg;
  msg.param_value = params_->get(index);
  msg.param_count = kParamCount;
  msg.param_index = index;
  copy_name(msg.param_id, info.name);
  msg.param_type = mav::kParamTypeReal32;
  send(port, msg);
}

void GroundLink::send_ack(uint8_t port, uint16_t command, uint8_t result) {
  mav::CommandAck ack;
  ack.command = command;
  ack.result = result;
  send(port, ack);
}

void GroundLink::transmit(uint8_t port, uint32_t message_id, uint8_t crc_extra, uint8_t full_length, uint8_t* buffer) {
  const size_t n = port == hal::kUart2 ? radio_.finish(senders_[port], message_id, crc_extra, full_length, buffer)
                                       : senders_[port].finish(message_id, crc_extra, full_length, buffer);
  if (n == 0) return;
  const uint16_t written = io_.write(port, buffer, static_cast<uint16_t>(n));
  counters_.tx_dropped_bytes += static_cast<uint32_t>(n - written);
}

void GroundLink::send_statustext(uint8_t severity, FlashText text) { send_statustext((StatusLine(severity) << text).message()); }

void GroundLink::send_statustext(const mav::Statustext& msg) {
  broadcast(msg);
  if (io_.console != nullptr) io_.console(msg.severity, msg.text, static_cast<uint8_t>(strnlen(msg.text, sizeof msg.text)));
  if (io_.statustext != nullptr) io_.statustext(io_.statustext_context, msg);
}

}  // namespace fw
}  // namespace quad
