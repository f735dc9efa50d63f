#include "quad/sim/log_download.h"

#include <algorithm>
#include <sstream>

#include "quad/sim/hil_messages.h"

namespace quad::sim {
namespace mav = quad::mavlink;

void LogDownload::start(double t, const LogDownloadRequest& request) {
  Link link = std::move(link_);
  *this = LogDownload(std::move(link));  // a second command starts afresh
  request_ = request;
  state_ = State::kListing;
  start_t_ = t;
  request_list(t);
}

void LogDownload::request_list(double t) {
  if (++list_requests_ > kMaxIdleRequests) return fail(t, "no complete LOG_ENTRY list after " + std::to_string(kMaxIdleRequests) + " requests");
  entries_.clear();
  mav::LogRequestList m;
  m.start = 0;
  m.end = 0xFFFF;
  m.target_system = kVehicleSys;
  m.target_component = mav::kCompIdAutopilot1;
  link_.list(m, t);
  last_heard_t_ = t;
}

void LogDownload::request_missing(double t) {
  if (data_requests_ > 0 && !progress_since_request_ && ++idle_requests_ >= kMaxIdleRequests) {
    return fail(t, std::to_string(kMaxIdleRequests) + " requests in a row brought no data");
  }
  if (progress_since_request_) idle_requests_ = 0;
  uint32_t end = first_missing_;
  while (end < wanted_ && !have_[end]) ++end;
  mav::LogRequestData m;
  m.id = id_;
  m.ofs = first_missing_;
  m.count = end - first_missing_;
  m.target_system = kVehicleSys;
  m.target_component = mav::kCompIdAutopilot1;
  link_.data(m, t);
  ++data_requests_;
  progress_since_request_ = false;
  last_heard_t_ = t;
}

void LogDownload::on_frame(const mav::Frame& f, double t) {
  if (state_ == State::kListing && f.message_id == mav::LogEntry::kId) {
    mav::LogEntry e;
    if (!mav::decode(f, e)) return;
    last_heard_t_ = t;
    if (e.num_logs == 0) return fail(t, "the vehicle holds no log");
    num_logs_ = e.num_logs;
    if (std::none_of(entries_.begin(), entries_.end(), [&](const auto& x) { return x.first == e.id; }))
      entries_.emplace_back(e.id, e.size);
    if (entries_.size() < num_logs_) return;
    const uint16_t want_id = request_.id ? *request_.id : std::max_element(entries_.begin(), entries_.end())->first;
    const auto it = std::find_if(entries_.begin(), entries_.end(), [&](const auto& x) { return x.first == want_id; });
    if (it == entries_.end()) return fail(t, "no log " + std::to_string(want_id) + " in the vehicle's list");
    id_ = want_id;
    listed_size_ = it->second;
    wanted_ = request_.max_bytes ? std::min(*request_.max_bytes, listed_size_) : listed_size_;
    data_.assign(wanted_, 0);
    have_.assign(wanted_, false);
    state_ = State::kData;
    data_start_t_ = t;
    if (wanted_ == 0) return finish(t);
    request_missing(t);
    return;
  }
  if (state_ != State::kData || f.message_id != mav::LogData::kId) return;
  mav::LogData d;
  if (!mav::decode(f, d) || d.id != id_) return;
  last_heard_t_ = t;
  ++frames_;
  for (uint32_t i = 0; i < d.count && i < mav::LogData::kDataLength; ++i) {
    const uint32_t at = d.ofs + i;
    if (at >= wanted_ || have_[at]) continue;
    data_[at] = d.data[i];
    have_[at] = true;
    ++bytes_received_;
    progress_since_request_ = true;
    last_byte_t_ = t;
  }
  while (first_missing_ < wanted_ && have_[first_missing_]) ++first_missing_;
  if (first_missing_ >= wanted_) return finish(t);
  // count 0: the vehicle's stream ended (past the end of what it holds); ask for what is still missing.
  if (d.count == 0) request_missing(t);
}

void LogDownload::poll(double t) {
  if (t - last_heard_t_ < kQuietS) return;
  if (state_ == State::kListing) request_list(t);
  else if (state_ == State::kData) request_missing(t);
}

void LogDownload::finish(double t) {
  state_ = State::kDone;
  end_t_ = t;
  mav::LogRequestEnd m;
  m.target_system = kVehicleSys;
  m.target_component = mav::kCompIdAutopilot1;
  link_.end(m, t);
}

void LogDownload::fail(double t, const std::string& why) {
  state_ = State::kFailed;
  end_t_ = t;
  failure_ = why;
}

double LogDownload::rate_bytes_s() const {
  const double span = last_byte_t_ - data_start_t_;
  return span > 0.0 ? static_cast<double>(bytes_received_) / span : 0.0;
}

std::vector<uint8_t> LogDownload::contiguous() const {
  return std::vector<uint8_t>(data_.begin(), data_.begin() + first_missing_);
}

std::string LogDownload::describe() const {
  std::ostringstream s;
  s << "log download: log " << id_ << " (" << listed_size_ << " bytes listed), " << bytes_received_ << " of "
    << wanted_ << " bytes in " << frames_ << " LOG_DATA, " << data_requests_ << " data requests, "
    << static_cast<long>(rate_bytes_s() + 0.5) << " bytes/s";
  if (state_ == State::kDone) s << ", complete";
  else if (state_ == State::kFailed) s << ", failed: " << failure_;
  else s << ", not finished";
  return s.str();
}

}  // namespace quad::sim
