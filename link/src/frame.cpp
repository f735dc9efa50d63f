// MAVLink v2 frame assembly and the message table of this project.
#include "quad/link/frame.h"

#include <string.h>

#include "quad/link/crc.h"
#include "quad/link/messages.h"

namespace quad {
namespace mavlink {

namespace {

template <class Msg>
bool found(MessageInfo* info) {
  *info = message_info<Msg>();
  return true;
}

}  // namespace

// A switch rather than a table: it costs flash, not the AVR's scarce SRAM.
bool find_message_info(uint32_t message_id, MessageInfo* info) {
  switch (message_id) {
    case Heartbeat::kId: return found<Heartbeat>(info);
    case SysStatus::kId: return found<SysStatus>(info);
    case ParamRequestRead::kId: return found<ParamRequestRead>(info);
    case ParamRequestList::kId: return found<ParamRequestList>(info);
    case ParamValue::kId: return found<ParamValue>(info);
    case ParamSet::kId: return found<ParamSet>(info);
    case AttitudeQuaternion::kId: return found<AttitudeQuaternion>(info);
    case LocalPositionNed::kId: return found<LocalPositionNed>(info);
    case ManualControl::kId: return found<ManualControl>(info);
    case CommandLong::kId: return found<CommandLong>(info);
    case CommandAck::kId: return found<CommandAck>(info);
    case SetPositionTargetLocalNed::kId: return found<SetPositionTargetLocalNed>(info);
    case HilActuatorControls::kId: return found<HilActuatorControls>(info);
    case VisionPositionEstimate::kId: return found<VisionPositionEstimate>(info);
    case HilSensor::kId: return found<HilSensor>(info);
    case Timesync::kId: return found<Timesync>(info);
    case HilStateQuaternion::kId: return found<HilStateQuaternion>(info);
    case LogRequestList::kId: return found<LogRequestList>(info);
    case LogEntry::kId: return found<LogEntry>(info);
    case LogRequestData::kId: return found<LogRequestData>(info);
    case LogData::kId: return found<LogData>(info);
    case LogErase::kId: return found<LogErase>(info);
    case LogRequestEnd::kId: return found<LogRequestEnd>(info);
    case AttPosMocap::kId: return found<AttPosMocap>(info);
    case LandingTarget::kId: return found<LandingTarget>(info);
    case EstimatorStatus::kId: return found<EstimatorStatus>(info);
    case ExtendedSysState::kId: return found<ExtendedSysState>(info);
    case Statustext::kId: return found<Statustext>(info);
    default: return false;
  }
}

size_t finish_frame(const FrameHeader& header, uint32_t message_id, uint8_t crc_extra, size_t full_length,
                    uint8_t* out) {
  // MAVLink v2 drops trailing zero bytes of the payload but keeps the first byte even when it is zero
  // (as the reference C library does; receivers accept an empty payload as well).
  size_t length = full_length;
  while (length > 1 && out[kHeaderLength + length - 1] == 0) --length;

  out[0] = kStx;
  out[1] = static_cast<uint8_t>(length);
  out[2] = header.incompat_flags;
  out[3] = header.compat_flags;
  out[4] = header.sequence;
  out[5] = header.system_id;
  out[6] = header.component_id;
  out[7] = static_cast<uint8_t>(message_id & 0xFF);
  out[8] = static_cast<uint8_t>((message_id >> 8) & 0xFF);
  out[9] = static_cast<uint8_t>((message_id >> 16) & 0xFF);

  uint16_t crc = crc_accumulate(out + 1, kHeaderLength - 1 + length, kCrcInit);
  crc = crc_accumulate(crc_extra, crc);
  size_t size = kHeaderLength + length;
  out[size++] = static_cast<uint8_t>(crc & 0xFF);
  out[size++] = static_cast<uint8_t>(crc >> 8);

  if ((header.incompat_flags & kIncompatFlagSigned) != 0) {
    memset(out + size, 0, kSignatureLength);
    size += kSignatureLength;
  }
  return size;
}

size_t Sender::finish(uint32_t message_id, uint8_t crc_extra, size_t full_length, uint8_t* out,
                      uint8_t incompat_flags) {
  if ((incompat_flags & static_cast<uint8_t>(~kSupportedIncompatFlags)) != 0) return 0;
  FrameHeader header;
  header.system_id = system_id_;
  header.component_id = component_id_;
  header.sequence = sequence_;
  header.incompat_flags = incompat_flags;
  const size_t length = finish_frame(header, message_id, crc_extra, full_length, out);
  ++sequence_;
  return length;
}

}  // namespace mavlink
}  // namespace quad
