#include "quad/sim/ground_ids.h"

#include <cstring>

#include "quad/link/crc.h"
#include "quad/link/dialect.h"

namespace quad::sim {
namespace mav = quad::mavlink;

namespace {

constexpr uint8_t kFirmwareSystem = mav::kVehicleSystemId;

size_t copy(const mav::Frame& f, uint8_t* out, size_t capacity) {
  if (capacity < f.size) return 0;
  std::memcpy(out, f.bytes, f.size);
  return f.size;
}

enum class Route { kUnchanged, kReaddressed, kDropped };

// A message with a target: readdressed from `id` to the firmware's system, re-encoded with the sender's
// header (ids, sequence, compat flags).
template <class Msg, class Target>
Route retarget(const mav::Frame& f, uint8_t id, Target target, uint8_t* out, size_t capacity, size_t* size) {
  Msg m;
  if (!mav::decode(f, m)) return Route::kUnchanged;
  uint8_t& t = target(m);
  if (t == 0 || (t == kFirmwareSystem && id == kFirmwareSystem)) return Route::kUnchanged;
  if (t != id) return Route::kDropped;
  t = kFirmwareSystem;
  mav::FrameHeader h;
  h.system_id = f.system_id;
  h.component_id = f.component_id;
  h.sequence = f.sequence;
  h.compat_flags = f.compat_flags;
  *size = mav::encode(m, h, out, capacity);
  return Route::kReaddressed;
}

Route route(const mav::Frame& f, uint8_t id, uint8_t* out, size_t capacity, size_t* size) {
  auto ts = [](auto& m) -> uint8_t& { return m.target_system; };
  switch (f.message_id) {
    case mav::CommandLong::kId: return retarget<mav::CommandLong>(f, id, ts, out, capacity, size);
    case mav::SetPositionTargetLocalNed::kId: return retarget<mav::SetPositionTargetLocalNed>(f, id, ts, out, capacity, size);
    case mav::ParamRequestRead::kId: return retarget<mav::ParamRequestRead>(f, id, ts, out, capacity, size);
    case mav::ParamRequestList::kId: return retarget<mav::ParamRequestList>(f, id, ts, out, capacity, size);
    case mav::ParamSet::kId: return retarget<mav::ParamSet>(f, id, ts, out, capacity, size);
    case mav::LogRequestList::kId: return retarget<mav::LogRequestList>(f, id, ts, out, capacity, size);
    case mav::LogRequestData::kId: return retarget<mav::LogRequestData>(f, id, ts, out, capacity, size);
    case mav::LogErase::kId: return retarget<mav::LogErase>(f, id, ts, out, capacity, size);
    case mav::LogRequestEnd::kId: return retarget<mav::LogRequestEnd>(f, id, ts, out, capacity, size);
    case mav::Timesync::kId: return retarget<mav::Timesync>(f, id, ts, out, capacity, size);
    case mav::SetupSigning::kId: return retarget<mav::SetupSigning>(f, id, ts, out, capacity, size);
    case mav::ManualControl::kId:
      return retarget<mav::ManualControl>(f, id, [](auto& m) -> uint8_t& { return m.target; }, out, capacity, size);
    default: return Route::kUnchanged;
  }
}

}  // namespace

size_t GroundIds::to_ground(const mav::Frame& f, uint8_t* out, size_t capacity) {
  const size_t n = copy(f, out, capacity);
  if (n == 0 || id_ == f.system_id || f.system_id != kFirmwareSystem) return n;
  if (f.is_signed()) {
    ++stats_.signed_passed;
    return n;
  }
  mav::MessageInfo info{};
  if (!mav::dialect_message_info(f.message_id, &info)) return n;  // the parser knew it: cannot happen
  out[5] = id_;  // v2 header: STX, len, incompat, compat, seq, sysid, compid, msgid[3]
  const size_t body = mav::kHeaderLength + f.payload_length;
  uint16_t crc = mav::crc_accumulate(out + 1, body - 1, mav::kCrcInit);
  crc = mav::crc_accumulate(info.crc_extra, crc);
  out[body] = static_cast<uint8_t>(crc & 0xFF);
  out[body + 1] = static_cast<uint8_t>(crc >> 8);
  ++stats_.restamped;
  return n;
}

size_t GroundIds::to_vehicle(const mav::Frame& f, uint8_t* out, size_t capacity) {
  if (f.is_signed()) {
    ++stats_.signed_passed;
    return copy(f, out, capacity);
  }
  size_t size = 0;
  switch (route(f, id_, out, capacity, &size)) {
    case Route::kUnchanged: return copy(f, out, capacity);
    case Route::kReaddressed: ++stats_.readdressed; return size;
    case Route::kDropped: ++stats_.dropped; return 0;
  }
  return 0;
}

}  // namespace quad::sim
