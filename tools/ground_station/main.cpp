// quad_gs: a small ground station on the command line, to drive a HIL flight (or the vehicle) by hand
// over a serial port: arm, disarm, switch mode, send a position setpoint, list / read / set parameters,
// and watch the telemetry. It speaks MAVLink v2 as system 255, component 190 (docs/hil-protocol.md).
//
//   quad_gs --port PATH [--baud N] [--key SECRET] [--tlog FILE] COMMAND [ARGS]
//     arm | disarm [force] | mode manual|auto|land | land
//     setpoint NORTH EAST DOWN [YAW_DEG]
//     params                      every parameter as "NAME VALUE" (the quad_firmware --params format)
//     get NAME | set NAME VALUE
//     watch [SECONDS]             print STATUSTEXT, mode changes and the position estimate
//     signing-setup               send the --key to the vehicle (SETUP_SIGNING; the vehicle takes it on
//                                 its USB port only); signing-off removes it
//     logs list                   the vehicle's flight logs: id, bytes, start time
//     logs download ID FILE       log ID into FILE, asking again for the ranges lost on the way; an
//                                 interrupted download resumes from FILE.part and FILE.part.ranges
//     logs erase                  erase every log (LOG_ERASE), then check that none is left
//
// --key SECRET signs every frame sent (MAVLink v2 signing, timestamps from the wall clock) and drops
// received frames whose signature is wrong. SECRET is 64 hex digits (the 32-byte key) or a passphrase,
// whose SHA-256 is the key (MAVProxy's "signing setup" convention).
//
// --tlog FILE records the session as a .tlog (docs/logging.md): every frame sent and received, each
// with its wall-clock time, the format MAVProxy writes and MAVExplorer reads.
//
// Exit status: 0 done, 1 refused or no answer, 2 usage error or the port cannot be opened.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/time.h>

#include "quad/link/dialect.h"
#include "quad/hal/host.h"
#include "quad/link/mavlink.h"
#include "quad/link/sha256.h"
#include "quad/link/signing.h"
#include "quad/link/tlog.h"

namespace {

namespace mav = quad::mavlink;

constexpr uint8_t kVehicleSystem = 1;
constexpr uint8_t kVehicleComponent = 1;
constexpr uint32_t kModeManual = 1, kModeAuto = 2, kModeLanding = 3;
const char* const kModeNames[] = {"DISARMED", "MANUAL", "AUTO", "LANDING"};

const char kUsage[] =
    "usage: quad_gs --port PATH [--baud N] [--key SECRET] [--tlog FILE] COMMAND [ARGS]\n"
    "  arm | disarm [force] | mode manual|auto|land | land\n"
    "  setpoint NORTH EAST DOWN [YAW_DEG]   position setpoint in NED metres (AUTO)\n"
    "  params                               list every parameter as 'NAME VALUE'\n"
    "  get NAME | set NAME VALUE            read or set one parameter\n"
    "  watch [SECONDS]                      print status text, mode and position (default 10 s)\n"
    "  signing-setup | signing-off          provision (over USB) or remove the --key on the vehicle\n"
    "  logs list | logs download ID FILE | logs erase   the vehicle's flight logs (MAVLink log protocol)\n"
    "  --key SECRET: sign with this key: 64 hex digits, or a passphrase (key = its SHA-256)\n"
    "  --tlog FILE: record every frame sent and received (.tlog, as MAVProxy writes it)\n";

// The link id of this tool's signatures (the vehicle tracks streams per link, system and component).
constexpr uint8_t kSigningLinkId = 0;

// The signing timestamp of now (10 us since 2015-01-01, MAVLink's epoch).
uint64_t signing_now() {
  timeval tv;
  gettimeofday(&tv, nullptr);
  return mav::signing_timestamp_from_unix_microseconds(static_cast<uint64_t>(tv.tv_sec) * 1000000u +
                                                       static_cast<uint64_t>(tv.tv_usec));
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// 64 hex digits are the key itself; anything else is a passphrase.
bool key_from_secret(const std::string& secret, mav::SigningKey* key) {
  if (secret.empty()) return false;
  bool hex = secret.size() == 2 * mav::kSigningKeyLength;
  for (size_t i = 0; hex && i < secret.size(); ++i) hex = hex_digit(secret[i]) >= 0;
  if (hex) {
    for (size_t i = 0; i < mav::kSigningKeyLength; ++i) {
      key->bytes[i] = static_cast<uint8_t>(hex_digit(secret[2 * i]) * 16 + hex_digit(secret[2 * i + 1]));
    }
  } else {
    mav::sha256(reinterpret_cast<const uint8_t*>(secret.data()), secret.size(), key->bytes);
  }
  return true;
}

// The session's record (--tlog): one stream per direction, so each record is one whole frame.
struct Record {
  explicit Record(const std::string& path) : file(path), to_vehicle(file), from_vehicle(file) {}
  quad::tlog::TlogWriter file;
  quad::tlog::TlogStream to_vehicle, from_vehicle;
};

// The link to the vehicle: the host HAL's UART0 on the given device, a parser and our identity.
class Link {
 public:
  // With a key every frame is signed and vehicle frames with a wrong signature are dropped. With a
  // record every byte sent and read is recorded.
  Link(const mav::SigningKey* key, Record* record)
      : record_(record),
        sender_(255, mav::kCompIdMissionPlanner),
        key_(key != nullptr ? *key : mav::SigningKey{}),
        clock_(signing_now()),
        signer_(key_, clock_, kSigningLinkId),
        verifier_(key_, clock_),
        signing_(key != nullptr) {}

  template <class Msg>
  void send(const Msg& msg) {
    uint8_t buf[mav::max_frame_length<Msg>(true)];
    clock_.advance_to(signing_now());
    const size_t n = signing_ ? mav::encode_signed(sender_, signer_, msg, buf, sizeof buf) : sender_.encode(msg, buf, sizeof buf);
    if (record_) record_->to_vehicle.feed(buf, n, quad::tlog::unix_micros_now());
    size_t done = 0;
    while (done < n) {
      const uint16_t w = quad::hal::serial_write(quad::hal::kUart0, buf + done, static_cast<uint16_t>(n - done));
      if (w == 0) quad::hal::idle(1000);
      done += w;
      if (quad::hal::host::port_hung_up(quad::hal::kUart0)) return;
    }
  }

  // Receives for up to timeout_ms, calling on_frame for each vehicle frame until it returns true.
  // Returns whether it did.
  template <class OnFrame>
  bool receive(int timeout_ms, OnFrame&& on_frame) {
    const uint32_t start = quad::hal::micros();
    bool done = false;
    while (!done && static_cast<int32_t>(quad::hal::micros() - start) < timeout_ms * 1000) {
      quad::hal::idle(20000);
      uint8_t buf[512];
      uint16_t n;
      while ((n = quad::hal::serial_read(quad::hal::kUart0, buf, sizeof buf)) > 0) {
        if (record_) record_->from_vehicle.feed(buf, n, quad::tlog::unix_micros_now());
        parser_.feed(buf, n, [&](const mav::Frame& f) {
          if (f.system_id != kVehicleSystem) return;
          if (signing_ && !mav::accepted(verifier_.check(f))) {
            ++rejected_;
            return;
          }
          // Status text is always shown, also when it follows the awaited frame in the same read.
          print_statustext(f);
          if (!done) done = on_frame(f);
        });
      }
      if (quad::hal::host::port_hung_up(quad::hal::kUart0)) break;
    }
    return done;
  }

 private:
  static void print_statustext(const mav::Frame& f) {
    mav::Statustext text;
    if (mav::decode(f, text)) {
      std::fprintf(stderr, "vehicle: %.*s\n", static_cast<int>(strnlen(text.text, sizeof text.text)), text.text);
    }
  }

  Record* record_;
  mav::Sender sender_;
  mav::Parser parser_;
  mav::SigningKey key_;
  mav::SigningClock clock_;
  mav::Signer signer_;
  mav::SignatureVerifier verifier_;
  bool signing_;
  uint32_t rejected_ = 0;

 public:
  uint32_t rejected() const { return rejected_; }
};

// SETUP_SIGNING carries no acknowledgement: the vehicle's STATUSTEXT says whether it took the key.
int setup_signing(Link& link, const mav::SigningKey& key, bool off) {
  quad::mavlink::SetupSigning msg;
  msg.target_system = kVehicleSystem;
  msg.target_component = kVehicleComponent;
  if (!off) {
    msg.initial_timestamp = signing_now();
    std::memcpy(msg.secret_key, key.bytes, sizeof msg.secret_key);
  }
  for (int attempt = 0; attempt < 3; ++attempt) {
    link.send(msg);
    bool refused = false;
    const bool answered = link.receive(1500, [&](const mav::Frame& f) {
      mav::Statustext text;
      if (!mav::decode(f, text)) return false;
      const std::string line(text.text, strnlen(text.text, sizeof text.text));
      refused = line.find("signing: key refused") != std::string::npos || line.find("not stored") != std::string::npos;
      return refused || line.find("signing: key set") != std::string::npos ||
             line.find("signing: key removed") != std::string::npos;
    });
    if (!answered) continue;
    std::printf(refused ? "refused\n" : "accepted\n");
    return refused ? 1 : 0;
  }
  std::fprintf(stderr, "quad_gs: no answer from the vehicle (SETUP_SIGNING is taken on its USB port only)\n");
  return 1;
}

void set_name(char (&dst)[16], const std::string& name) {
  std::memset(dst, 0, sizeof dst);
  std::memcpy(dst, name.data(), std::min<size_t>(name.size(), sizeof dst));
}

std::string name_of(const char (&id)[16]) { return std::string(id, strnlen(id, sizeof id)); }

// COMMAND_LONG with retries; prints the outcome. 0 accepted, 1 otherwise.
int command(Link& link, uint16_t cmd, float p1, float p2) {
  mav::CommandLong msg;
  msg.command = cmd;
  msg.param1 = p1;
  msg.param2 = p2;
  msg.target_system = kVehicleSystem;
  msg.target_component = kVehicleComponent;
  for (uint8_t attempt = 0; attempt < 3; ++attempt) {
    msg.confirmation = attempt;
    link.send(msg);
    mav::CommandAck ack;
    const bool answered = link.receive(1500, [&](const mav::Frame& f) { return mav::decode(f, ack) && ack.command == cmd; });
    if (!answered) continue;
    // Let the STATUSTEXT that explains the outcome arrive too.
    link.receive(200, [](const mav::Frame&) { return false; });
    if (ack.result == mav::kResultAccepted) {
      std::printf("accepted\n");
      return 0;
    }
    std::printf("refused (MAV_RESULT %u)\n", ack.result);
    return 1;
  }
  std::fprintf(stderr, "quad_gs: no answer from the vehicle\n");
  return 1;
}

int list_params(Link& link) {
  mav::ParamRequestList req;
  req.target_system = kVehicleSystem;
  req.target_component = kVehicleComponent;
  std::map<uint16_t, mav::ParamValue> got;
  int count = -1;
  for (int attempt = 0; attempt < 3 && (count < 0 || static_cast<int>(got.size()) < count); ++attempt) {
    if (attempt == 0 || count < 0) {
      link.send(req);
    } else {
      // Ask for the missing ones by index.
      for (int i = 0; i < count; ++i) {
        if (got.count(static_cast<uint16_t>(i))) continue;
        mav::ParamRequestRead read;
        read.target_system = kVehicleSystem;
        read.target_component = kVehicleComponent;
        read.param_index = static_cast<int16_t>(i);
        link.send(read);
      }
    }
    link.receive(3000, [&](const mav::Frame& f) {
      mav::ParamValue v;
      if (!mav::decode(f, v)) return false;
      count = v.param_count;
      got[v.param_index] = v;
      return static_cast<int>(got.size()) >= count;
    });
  }
  for (const auto& entry : got) std::printf("%-16s %.9g\n", name_of(entry.second.param_id).c_str(), entry.second.param_value);
  if (count < 0 || static_cast<int>(got.size()) < count) {
    std::fprintf(stderr, "quad_gs: received %zu of %d parameters\n", got.size(), count);
    return 1;
  }
  return 0;
}

int get_param(Link& link, const std::string& name) {
  mav::ParamRequestRead read;
  read.target_system = kVehicleSystem;
  read.target_component = kVehicleComponent;
  read.param_index = -1;
  set_name(read.param_id, name);
  for (int attempt = 0; attempt < 3; ++attempt) {
    link.send(read);
    mav::ParamValue v;
    if (link.receive(1500, [&](const mav::Frame& f) { return mav::decode(f, v) && name_of(v.param_id) == name; })) {
      std::printf("%-16s %.9g\n", name.c_str(), v.param_value);
      return 0;
    }
  }
  std::fprintf(stderr, "quad_gs: no value for '%s' (unknown parameter?)\n", name.c_str());
  return 1;
}

int set_param(Link& link, const std::string& name, float value) {
  mav::ParamSet set;
  set.target_system = kVehicleSystem;
  set.target_component = kVehicleComponent;
  set_name(set.param_id, name);
  set.param_value = value;
  set.param_type = mav::kParamTypeReal32;
  for (int attempt = 0; attempt < 3; ++attempt) {
    link.send(set);
    mav::ParamValue v;
    if (link.receive(1500, [&](const mav::Frame& f) { return mav::decode(f, v) && name_of(v.param_id) == name; })) {
      std::printf("%-16s %.9g\n", name.c_str(), v.param_value);
      if (v.param_value == value) return 0;
      std::fprintf(stderr, "quad_gs: the vehicle kept %.9g\n", v.param_value);
      return 1;
    }
  }
  std::fprintf(stderr, "quad_gs: no answer for '%s' (unknown parameter?)\n", name.c_str());
  return 1;
}

int send_setpoint(Link& link, float n, float e, float d, bool has_yaw, float yaw_deg) {
  mav::SetPositionTargetLocalNed sp;
  sp.target_system = kVehicleSystem;
  sp.target_component = kVehicleComponent;
  sp.coordinate_frame = mav::kFrameLocalNed;
  // Use the position (and the yaw when given); ignore velocity, acceleration and yaw rate.
  sp.type_mask = 0x38 | 0x1C0 | 0x800 | (has_yaw ? 0 : 0x400);
  sp.x = n;
  sp.y = e;
  sp.z = d;
  sp.yaw = yaw_deg * 3.14159265f / 180.0f;
  link.send(sp);
  std::printf("setpoint sent: N %.3f E %.3f D %.3f\n", n, e, d);
  return 0;
}

int watch(Link& link, double seconds) {
  int32_t last_mode = -1;
  uint32_t last_print_ms = 0;
  link.receive(static_cast<int>(seconds * 1000.0), [&](const mav::Frame& f) {
    mav::Heartbeat hb;
    mav::LocalPositionNed pos;
    if (mav::decode(f, hb) && static_cast<int32_t>(hb.custom_mode) != last_mode) {
      last_mode = static_cast<int32_t>(hb.custom_mode);
      std::printf("mode %s%s\n", hb.custom_mode < 4 ? kModeNames[hb.custom_mode] : "?",
                  (hb.base_mode & mav::kModeFlagSafetyArmed) ? " (armed)" : "");
    } else if (mav::decode(f, pos) && pos.time_boot_ms - last_print_ms >= 1000) {
      last_print_ms = pos.time_boot_ms;
      std::printf("t %.1f s  p (%.2f, %.2f, %.2f) m  v (%.2f, %.2f, %.2f) m/s\n", pos.time_boot_ms / 1000.0, pos.x,
                  pos.y, pos.z, pos.vx, pos.vy, pos.vz);
    }
    std::fflush(stdout);
    return false;
  });
  return 0;
}

// ---------------------------------------------------------------------------------------------------
// The log protocol

template <class Msg>
Msg addressed() {
  Msg m;
  m.target_system = kVehicleSystem;
  m.target_component = kVehicleComponent;
  return m;
}

// LOG_ENTRY of logs first..last (0xFFFF: to the last); empty with num_logs 0 when there are none.
bool request_entries(Link& link, uint16_t first, uint16_t last, std::map<uint16_t, mav::LogEntry>* entries) {
  mav::LogRequestList req = addressed<mav::LogRequestList>();
  req.start = first;
  req.end = last;
  int expected = -1;
  for (int attempt = 0; attempt < 3; ++attempt) {
    link.send(req);
    const bool done = link.receive(2000, [&](const mav::Frame& f) {
      mav::LogEntry e;
      if (!mav::decode(f, e)) return false;
      if (e.num_logs == 0) {
        expected = 0;
        return true;
      }
      (*entries)[e.id] = e;
      const int top = std::min<int>(last, e.last_log_num);
      expected = top - first + 1;
      return static_cast<int>(entries->size()) >= expected;
    });
    if (done) return true;
  }
  return expected == 0 || (expected > 0 && static_cast<int>(entries->size()) >= expected);
}

int list_logs(Link& link) {
  std::map<uint16_t, mav::LogEntry> entries;
  if (!request_entries(link, 1, 0xFFFF, &entries)) {
    std::fprintf(stderr, "quad_gs: no complete log list from the vehicle\n");
    return 1;
  }
  if (entries.empty()) std::printf("no logs\n");
  for (const auto& kv : entries) {
    char when[32] = "unknown time";
    const time_t t = static_cast<time_t>(kv.second.time_utc);
    if (kv.second.time_utc != 0) std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&t));
    std::printf("%3u %10u bytes  %s\n", kv.first, kv.second.size, when);
  }
  return 0;
}

int erase_logs(Link& link) {
  link.send(addressed<mav::LogErase>());
  std::map<uint16_t, mav::LogEntry> entries;
  link.receive(500, [](const mav::Frame&) { return false; });  // the vehicle's answer, if any (STATUSTEXT)
  if (!request_entries(link, 1, 0xFFFF, &entries)) {
    std::fprintf(stderr, "quad_gs: no log list after the erase\n");
    return 1;
  }
  if (!entries.empty()) {
    std::fprintf(stderr, "quad_gs: %zu logs still on the vehicle\n", entries.size());
    return 1;
  }
  std::printf("logs erased\n");
  return 0;
}

// The byte ranges of a download received so far, merged.
class Ranges {
 public:
  void add(uint32_t begin, uint32_t end) {
    if (begin >= end) return;
    auto it = r_.upper_bound(begin);
    if (it != r_.begin() && std::prev(it)->second >= begin) --it;
    while (it != r_.end() && it->first <= end) {
      begin = std::min(begin, it->first);
      end = std::max(end, it->second);
      it = r_.erase(it);
    }
    r_[begin] = end;
  }
  // The first range in [0, size) not received: false when there is none.
  bool first_gap(uint32_t size, uint32_t* begin, uint32_t* end) const {
    uint32_t at = 0;
    for (const auto& kv : r_) {
      if (kv.first > at) break;
      at = std::max(at, kv.second);
    }
    if (at >= size) return false;
    *begin = at;
    auto next = r_.upper_bound(at);
    *end = next == r_.end() ? size : std::min(size, next->first);
    return true;
  }
  uint64_t bytes() const {
    uint64_t n = 0;
    for (const auto& kv : r_) n += kv.second - kv.first;
    return n;
  }
  const std::map<uint32_t, uint32_t>& all() const { return r_; }

 private:
  std::map<uint32_t, uint32_t> r_;
};

// FILE.part holds the bytes, FILE.part.ranges the ranges received ("BEGIN END" per line) of log `id`
// of `size` bytes (first line "log ID SIZE"): a later run with the same log resumes from them.
void load_partial(const std::string& file, uint16_t id, uint32_t size, std::vector<uint8_t>* data, Ranges* have) {
  std::ifstream meta(file + ".part.ranges");
  std::string word;
  unsigned meta_id = 0, meta_size = 0;
  if (!(meta >> word >> meta_id >> meta_size) || word != "log" || meta_id != id || meta_size != size) return;
  std::ifstream part(file + ".part", std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(part)), std::istreambuf_iterator<char>());
  if (bytes.size() != size) return;
  *data = bytes;
  uint32_t b, e;
  while (meta >> b >> e) have->add(b, std::min(e, size));
}

bool save_partial(const std::string& file, uint16_t id, const std::vector<uint8_t>& data, const Ranges& have) {
  std::ofstream part(file + ".part", std::ios::binary | std::ios::trunc);
  part.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
  std::ofstream meta(file + ".part.ranges", std::ios::trunc);
  meta << "log " << id << ' ' << data.size() << '\n';
  for (const auto& kv : have.all()) meta << kv.first << ' ' << kv.second << '\n';
  return part.good() && meta.good();
}

int download_log(Link& link, uint16_t id, const std::string& file) {
  std::map<uint16_t, mav::LogEntry> entries;
  if (!request_entries(link, id, id, &entries) || entries.count(id) == 0) {
    std::fprintf(stderr, "quad_gs: the vehicle has no log %u\n", id);
    return 1;
  }
  const uint32_t size = entries[id].size;
  std::vector<uint8_t> data(size, 0);
  Ranges have;
  load_partial(file, id, size, &data, &have);
  if (have.bytes() > 0) std::fprintf(stderr, "quad_gs: resuming log %u at %llu of %u bytes\n", id, static_cast<unsigned long long>(have.bytes()), size);
  const uint32_t start_us = quad::hal::micros();
  const uint64_t start_bytes = have.bytes();
  uint32_t last_print_us = start_us;
  int silent_requests = 0;
  uint32_t gap_begin, gap_end;
  // Each round asks for the first missing range (the vehicle streams it to its end, or to the next range
  // it already sent) and takes LOG_DATA until the line has been quiet for 1 s.
  while (have.first_gap(size, &gap_begin, &gap_end) && silent_requests < 10) {
    mav::LogRequestData req = addressed<mav::LogRequestData>();
    req.id = id;
    req.ofs = gap_begin;
    req.count = gap_end - gap_begin;
    link.send(req);
    bool any = false;
    for (bool more = true; more;) {
      more = link.receive(1000, [&](const mav::Frame& f) {
        mav::LogData d;
        if (!mav::decode(f, d) || d.id != id) return false;
        const uint32_t n = std::min<uint32_t>(d.count, mav::LogData::kDataLength);
        if (d.ofs < size && n > 0) {
          const uint32_t end = std::min(size, d.ofs + n);
          std::copy(d.data, d.data + (end - d.ofs), data.begin() + d.ofs);
          have.add(d.ofs, end);
          any = true;
        }
        const uint32_t now = quad::hal::micros();
        if (now - last_print_us > 500000u) {
          last_print_us = now;
          const double s = (now - start_us) * 1e-6;
          std::fprintf(stderr, "\rlog %u: %llu / %u bytes (%.0f %%), %.2f kB/s   ", id, static_cast<unsigned long long>(have.bytes()), size,
                       100.0 * have.bytes() / std::max<uint32_t>(size, 1), (have.bytes() - start_bytes) / 1000.0 / std::max(s, 1e-3));
        }
        // This round is over when its range is complete (or the stream ended: count 0).
        uint32_t b, e;
        return d.count == 0 || !have.first_gap(size, &b, &e) || b != gap_begin;
      });
    }
    silent_requests = any ? 0 : silent_requests + 1;
  }
  link.send(addressed<mav::LogRequestEnd>());
  const double seconds = (quad::hal::micros() - start_us) * 1e-6;
  std::fprintf(stderr, "\rlog %u: %llu / %u bytes in %.1f s, %.2f kB/s\n", id, static_cast<unsigned long long>(have.bytes()), size,
               seconds, (have.bytes() - start_bytes) / 1000.0 / std::max(seconds, 1e-3));
  if (have.first_gap(size, &gap_begin, &gap_end)) {
    save_partial(file, id, data, have);
    std::fprintf(stderr, "quad_gs: incomplete (no data for 10 requests); run the same command again to resume\n");
    return 1;
  }
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
  if (!out.good()) {
    std::fprintf(stderr, "quad_gs: cannot write %s\n", file.c_str());
    return 1;
  }
  std::remove((file + ".part").c_str());
  std::remove((file + ".part.ranges").c_str());
  return 0;
}

bool parse_float(const char* s, float* out) {
  char* end = nullptr;
  const double v = std::strtod(s, &end);
  if (end == s || *end != '\0' || !std::isfinite(v)) return false;
  *out = static_cast<float>(v);
  return true;
}

// The command of the command line (checked by main()). 0 done, 1 refused or no answer.
int run_command(Link& link, const std::vector<std::string>& args, const float* f, const mav::SigningKey& key) {
  const std::string& cmd = args[0];
  if (cmd == "arm") return command(link, mav::kCmdComponentArmDisarm, 1.0f, 0.0f);
  if (cmd == "disarm") return command(link, mav::kCmdComponentArmDisarm, 0.0f, args.size() == 2 ? 21196.0f : 0.0f);
  if (cmd == "land") return command(link, mav::kCmdNavLand, 0.0f, 0.0f);
  if (cmd == "mode") {
    const uint32_t mode = args[1] == "manual" ? kModeManual : (args[1] == "auto" ? kModeAuto : kModeLanding);
    return command(link, mav::kCmdDoSetMode, static_cast<float>(mav::kModeFlagCustomModeEnabled), static_cast<float>(mode));
  }
  if (cmd == "setpoint") return send_setpoint(link, f[0], f[1], f[2], args.size() == 5, f[3]);
  if (cmd == "params") return list_params(link);
  if (cmd == "get") return get_param(link, args[1]);
  if (cmd == "set") return set_param(link, args[1], f[0]);
  if (cmd == "watch") return watch(link, args.size() == 2 ? f[0] : 10.0);
  if (cmd == "signing-setup" || cmd == "signing-off") return setup_signing(link, key, cmd == "signing-off");
  if (cmd == "logs" && args[1] == "list") return list_logs(link);
  if (cmd == "logs" && args[1] == "erase") return erase_logs(link);
  if (cmd == "logs") return download_log(link, static_cast<uint16_t>(f[0]), args[3]);
  return 1;
}

int usage(const char* why) {
  std::fprintf(stderr, "quad_gs: %s\n%s", why, kUsage);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  quad::hal::host::Config config;
  config.ports[quad::hal::kUart0].baud = 57600;
  std::vector<std::string> args;
  std::string key_secret, tlog_path;
  bool has_key = false;
  mav::SigningKey key{};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (a == "--key") {
      if (i + 1 >= argc) return usage("--key: missing value");
      key_secret = argv[++i];
      has_key = true;
      if (!key_from_secret(key_secret, &key)) return usage("--key: empty secret");
      continue;
    }
    if (a == "--tlog") {
      if (i + 1 >= argc) return usage("--tlog: missing value");
      tlog_path = argv[++i];
      continue;
    }
    if (a == "--port" || a == "--baud") {
      if (i + 1 >= argc) return usage((a + ": missing value").c_str());
      const char* v = argv[++i];
      if (a == "--port") {
        config.ports[quad::hal::kUart0].path = v;
      } else {
        char* end = nullptr;
        config.ports[quad::hal::kUart0].baud = static_cast<uint32_t>(std::strtoul(v, &end, 10));
        if (end == v || *end != '\0' || !quad::hal::host::baud_supported(config.ports[quad::hal::kUart0].baud)) {
          return usage((std::string("--baud: '") + v + "' is not a supported baud rate").c_str());
        }
      }
      continue;
    }
    args.push_back(a);
  }
  if (config.ports[quad::hal::kUart0].path.empty()) return usage("--port is required");
  if (args.empty()) return usage("no command");

  // Check the command line before opening the port.
  const std::string& cmd = args[0];
  float f[4] = {0, 0, 0, 0};
  if (cmd == "arm" || cmd == "land" || cmd == "params") {
    if (args.size() != 1) return usage((cmd + " takes no arguments").c_str());
  } else if (cmd == "disarm") {
    if (args.size() > 2 || (args.size() == 2 && args[1] != "force")) return usage("disarm [force]");
  } else if (cmd == "mode") {
    if (args.size() != 2 || (args[1] != "manual" && args[1] != "auto" && args[1] != "land")) {
      return usage("mode manual|auto|land");
    }
  } else if (cmd == "setpoint") {
    if (args.size() != 4 && args.size() != 5) return usage("setpoint NORTH EAST DOWN [YAW_DEG]");
    for (size_t i = 1; i < args.size(); ++i) {
      if (!parse_float(args[i].c_str(), &f[i - 1])) return usage(("not a number: '" + args[i] + "'").c_str());
    }
  } else if (cmd == "get") {
    if (args.size() != 2 || args[1].size() > 16) return usage("get NAME (at most 16 characters)");
  } else if (cmd == "set") {
    if (args.size() != 3 || args[1].size() > 16) return usage("set NAME VALUE (name at most 16 characters)");
    if (!parse_float(args[2].c_str(), &f[0])) return usage(("not a number: '" + args[2] + "'").c_str());
  } else if (cmd == "watch") {
    if (args.size() > 2 || (args.size() == 2 && !parse_float(args[1].c_str(), &f[0]))) return usage("watch [SECONDS]");
  } else if (cmd == "logs") {
    const bool list_or_erase = args.size() == 2 && (args[1] == "list" || args[1] == "erase");
    const bool download = args.size() == 4 && args[1] == "download" && parse_float(args[2].c_str(), &f[0]) &&
                          f[0] >= 1.0f && f[0] <= 65535.0f && f[0] == std::floor(f[0]);
    if (!list_or_erase && !download) return usage("logs list | logs download ID FILE (ID 1..65535) | logs erase");
  } else if (cmd == "signing-setup" || cmd == "signing-off") {
    if (args.size() != 1) return usage((cmd + " takes no arguments").c_str());
    if (cmd == "signing-setup" && !has_key) return usage("signing-setup needs --key SECRET");
  } else {
    return usage(("unknown command '" + cmd + "'").c_str());
  }

  std::unique_ptr<Record> record;
  if (!tlog_path.empty()) {
    try {
      record = std::make_unique<Record>(tlog_path);
    } catch (const std::runtime_error& e) {
      std::fprintf(stderr, "quad_gs: --tlog %s\n", e.what());
      return 2;
    }
  }
  std::string error;
  if (!quad::hal::host::open(config, &error)) {
    std::fprintf(stderr, "quad_gs: %s\n", error.c_str());
    return 2;
  }
  Link link(has_key && cmd != "signing-setup" ? &key : nullptr, record.get());
  int status = 0;
  try {
    status = run_command(link, args, f, key);
  } catch (const std::runtime_error& e) {  // the record could not be written
    std::fprintf(stderr, "quad_gs: %s\n", e.what());
    status = 1;
  }
  if (link.rejected() > 0) std::fprintf(stderr, "quad_gs: %u frames with a wrong signature dropped\n", link.rejected());
  if (record) {
    record->file.flush();
    std::fprintf(stderr, "quad_gs: %llu frames recorded in %s\n",
                 static_cast<unsigned long long>(record->file.records()), tlog_path.c_str());
  }
  quad::hal::host::close();
  return status;
}
