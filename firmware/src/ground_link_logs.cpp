// The ground link's log protocol (MAVLink common: LOG_REQUEST_LIST, LOG_ENTRY, LOG_REQUEST_DATA, LOG_DATA,
// LOG_ERASE, LOG_REQUEST_END), served from the LogStore in Io on the port that asked.
//
// Answers are streamed as the parameters are: one LOG_ENTRY or LOG_DATA per loop iteration that has room
// for it (FlightApp::step), a LOG_DATA only when its port takes the whole frame, so a download never
// drops frames in the vehicle's own queue and never lengthens the iteration by more than one read of
// 90 bytes and one frame. A request replaces the one before it: the ground station re-requests the
// ranges it missed (a LOG_DATA lost on the radio) and the stream continues from there.
#include "quad/firmware/ground_link.h"

#include <string.h>

namespace quad {
namespace fw {
namespace mav = ::quad::mavlink;

namespace {

uint8_t* put_le(uint8_t* p, uint32_t v, uint8_t bytes) {
  for (uint8_t i = 0; i < bytes; ++i) *p++ = static_cast<uint8_t>(v >> (8 * i));
  return p;
}

}  // namespace

void GroundLink::dispatch_log(uint8_t port, const mav::Frame& frame) {
  switch (frame.message_id) {
    case mav::LogRequestList::kId: {
      mav::LogRequestList msg;
      if (mav::decode(frame, msg) && addressed_to_vehicle(msg.target_system)) on_log_request_list(port, msg);
      break;
    }
    case mav::LogRequestData::kId: {
      mav::LogRequestData msg;
      if (mav::decode(frame, msg) && addressed_to_vehicle(msg.target_system)) on_log_request_data(port, msg);
      break;
    }
    case mav::LogErase::kId: {
      mav::LogErase msg;
      if (mav::decode(frame, msg) && addressed_to_vehicle(msg.target_system)) on_log_erase();
      break;
    }
    case mav::LogRequestEnd::kId: {
      mav::LogRequestEnd msg;
      if (mav::decode(frame, msg) && addressed_to_vehicle(msg.target_system)) data_id_ = 0;
      break;
    }
    default:
      break;
  }
}

void GroundLink::on_log_request_list(uint8_t port, const mav::LogRequestList& msg) {
  const LogStore* store = io_.log_store;
  const uint16_t count = store != nullptr ? store->count(store->context) : 0;
  if (count == 0) {
    // MAVLink: an empty LOG_ENTRY (id 0, num_logs 0) says there are none.
    send_log_entry(port, 0);
    return;
  }
  list_next_ = msg.start == 0 ? 1 : msg.start;
  list_last_ = msg.end > count ? count : msg.end;
  list_port_ = port;
  if (list_next_ > list_last_) list_next_ = 0;
}

void GroundLink::on_log_request_data(uint8_t port, const mav::LogRequestData& msg) {
  if (io_.log_store == nullptr || msg.id == 0) return;
  data_id_ = msg.id;
  data_port_ = port;
  data_ofs_ = msg.ofs;
  data_end_ = msg.count > UINT32_MAX - msg.ofs ? UINT32_MAX : msg.ofs + msg.count;
}

void GroundLink::on_log_erase() {
  const LogStore* store = io_.log_store;
  if (store == nullptr) return;
  list_next_ = 0;
  data_id_ = 0;
  if (!store->erase_all(store->context)) send_statustext(mav::kSeverityWarning, QUAD_TEXT("logs: not erased, a log is open"));
}

bool GroundLink::stream_logs() {
  if (list_next_ != 0) {
    send_log_entry(list_port_, list_next_);
    return true;
  }
  if (data_id_ == 0) return false;
  constexpr uint16_t kFrame = mav::max_frame_length<mav::LogData>(true);
  if (io_.tx_free != nullptr && io_.tx_free(data_port_) < kFrame) return false;
  send_log_data();
  return true;
}

void GroundLink::send_log_entry(uint8_t port, uint16_t id) {
  const LogStore* store = io_.log_store;
  mav::LogEntry msg;
  if (id != 0) {
    LogEntry e;
    // The store may be busy (a page being programmed): the same entry goes next time.
    if (!store->entry(store->context, id, &e)) return;
    msg.num_logs = store->count(store->context);
    msg.last_log_num = msg.num_logs;
    msg.time_utc = e.time_utc_s;
    msg.size = e.size_bytes;
    list_next_ = id < list_last_ ? static_cast<uint16_t>(id + 1) : 0;
  }
  msg.id = id;
  send(port, msg);
}

void GroundLink::send_log_data() {
  const LogStore* store = io_.log_store;
  // The payload is written in place (no LogData on the stack beside the frame: the AVR's peak stack).
  uint8_t buffer[mav::max_frame_length<mav::LogData>(true)];
  uint8_t* payload = buffer + mav::kHeaderLength;
  uint8_t* data = payload + 7;  // after ofs u32, id u16, count u8
  const uint32_t left = data_end_ - data_ofs_;
  const uint16_t want = left < mav::LogData::kDataLength ? static_cast<uint16_t>(left) : mav::LogData::kDataLength;
  const uint16_t got = store->read(store->context, data_id_, data_ofs_, data, want);
  if (got == 0) {
    // Busy: again next time. Past the end (or an unknown log): one LOG_DATA with count 0 ends the stream.
    LogEntry e;
    const bool known = data_id_ <= store->count(store->context);
    if (known && !(store->entry(store->context, data_id_, &e) && data_ofs_ >= e.size_bytes)) return;
    data_end_ = data_ofs_;
  }
  memset(data + got, 0, mav::LogData::kDataLength - got);
  put_le(put_le(put_le(payload, data_ofs_, 4), data_id_, 2), got, 1);
  transmit(data_port_, mav::LogData::kId, mav::LogData::kCrcExtra, mav::LogData::kLength, buffer);
  data_ofs_ += got;
  if (data_ofs_ >= data_end_) data_id_ = 0;
}

}  // namespace fw
}  // namespace quad
