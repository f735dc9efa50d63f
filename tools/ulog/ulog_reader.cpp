#include "ulog_reader.h"

#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

namespace quad::ulog {

namespace {

constexpr uint8_t kMagic[7] = {'U', 'L', 'o', 'g', 0x01, 0x12, 0x35};
constexpr uint8_t kSyncMagic[8] = {0x2f, 0x73, 0x13, 0x20, 0x25, 0x0c, 0xbb, 0x12};
constexpr uint8_t kIncompatDataAppended = 0x01;  // incompat_flags[0], bit 0

size_t basic_size(const std::string& type) {
  static const std::map<std::string, size_t> sizes = {
      {"int8_t", 1},  {"uint8_t", 1},  {"int16_t", 2}, {"uint16_t", 2}, {"int32_t", 4}, {"uint32_t", 4},
      {"int64_t", 8}, {"uint64_t", 8}, {"float", 4},   {"double", 8},   {"bool", 1},    {"char", 1}};
  const auto it = sizes.find(type);
  return it == sizes.end() ? 0 : it->second;
}

template <class T>
T load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);  // the host is little-endian, as ULog is
  return v;
}

// "float[3]" -> ("float", 3); "float" -> ("float", 0).
bool split_type(const std::string& text, std::string* base, int* count) {
  const auto open = text.find('[');
  if (open == std::string::npos) {
    *base = text;
    *count = 0;
    return !text.empty();
  }
  if (text.back() != ']') return false;
  *base = text.substr(0, open);
  const std::string digits = text.substr(open + 1, text.size() - open - 2);
  if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) return false;
  *count = std::stoi(digits);
  return !base->empty();
}

double basic_number(const std::string& type, const uint8_t* p) {
  if (type == "float") return load<float>(p);
  if (type == "double") return load<double>(p);
  if (type == "int8_t") return load<int8_t>(p);
  if (type == "uint8_t" || type == "bool" || type == "char") return load<uint8_t>(p);
  if (type == "int16_t") return load<int16_t>(p);
  if (type == "uint16_t") return load<uint16_t>(p);
  if (type == "int32_t") return load<int32_t>(p);
  if (type == "uint32_t") return load<uint32_t>(p);
  if (type == "int64_t") return static_cast<double>(load<int64_t>(p));
  return static_cast<double>(load<uint64_t>(p));
}

}  // namespace

// ---- Layout --------------------------------------------------------------------------------------

Layout::Layout(const std::string& name, const std::map<std::string, std::vector<FormatField>>& formats) : name_(name) {
  add("", name, formats, 0);
  const auto& top = formats.at(name);
  for (auto it = top.rbegin(); it != top.rend() && it->name.rfind("_padding", 0) == 0; ++it) {
    trailing_padding_ += basic_size(it->type) * static_cast<size_t>(it->array > 0 ? it->array : 1);
  }
}

void Layout::add(const std::string& prefix, const std::string& type,
                 const std::map<std::string, std::vector<FormatField>>& formats, int depth) {
  const auto it = formats.find(type);
  if (it == formats.end()) throw Error("type '" + type + "' (in '" + name_ + "') has no format ('F')");
  if (depth > 32) throw Error("type '" + name_ + "': nested types too deep (a cycle?)");
  for (const FormatField& f : it->second) {
    const std::string path = prefix + f.name;
    const size_t elem = basic_size(f.type);
    const int n = f.array > 0 ? f.array : 1;
    if (elem != 0) {
      fields_[path] = FieldRef{f.type, size_, n};
      if (f.array > 0) {
        for (int i = 0; i < n; ++i) fields_[path + "[" + std::to_string(i) + "]"] = FieldRef{f.type, size_ + elem * i, 1};
      }
      size_ += elem * static_cast<size_t>(n);
    } else if (f.array > 0) {
      for (int i = 0; i < n; ++i) add(path + "[" + std::to_string(i) + "].", f.type, formats, depth + 1);
    } else {
      add(path + ".", f.type, formats, depth + 1);
    }
  }
}

const FieldRef& Layout::field(const std::string& field) const {
  const auto it = fields_.find(field);
  if (it == fields_.end()) throw Error("topic '" + name_ + "' has no field '" + field + "'");
  return it->second;
}

// ---- File ----------------------------------------------------------------------------------------

void File::fail(size_t offset, const std::string& what) const {
  throw Error(path_ + ": byte " + std::to_string(offset) + ": " + what);
}

File::File(const std::string& path) : path_(path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open");
  const std::vector<uint8_t> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (b.size() < 16) fail(0, "not a ULog file: " + std::to_string(b.size()) + " bytes, shorter than the 16-byte header");
  if (std::memcmp(b.data(), kMagic, sizeof kMagic) != 0) fail(0, "not a ULog file: bad magic (expected 'ULog' 01 12 35)");
  header_timestamp_ = load<uint64_t>(&b[8]);
  size_t pos = 16;
  bool in_definitions = true, first = true;
  while (pos < b.size()) {
    if (pos + 3 > b.size()) {
      fail(pos, "truncated: a message header needs 3 bytes, the file ends after " + std::to_string(b.size() - pos));
    }
    const size_t size = load<uint16_t>(&b[pos]);
    const char kind = static_cast<char>(b[pos + 2]);
    const size_t body = pos + 3;
    size_t stop = 0;  // the next appended block after pos, if any
    for (uint64_t o : appended_offsets_) {
      if (o > pos && (stop == 0 || o < stop)) stop = static_cast<size_t>(o);
    }
    if (stop != 0 && body + size > stop) {
      pos = stop;  // the regular data ends before the appended block: a message cut there is not data
      continue;
    }
    if (body + size > b.size()) {
      fail(pos, std::string("truncated: message '") + kind + "' needs " + std::to_string(size) +
                    " bytes, the file ends after " + std::to_string(b.size() - body));
    }
    if (first && kind == 'B') flag_bits(pos, &b[body], size);
    first = false;
    if (std::strchr("ADLCSOR", kind) != nullptr) in_definitions = false;
    read_message(pos, kind, &b[body], size, in_definitions);
    pos = body + size;
  }
}

void File::flag_bits(size_t offset, const uint8_t* p, size_t n) {
  if (n < 40) fail(offset, "message 'B' has " + std::to_string(n) + " bytes, needs 40");
  bool unknown = (p[8] & ~kIncompatDataAppended) != 0;
  for (int i = 9; i < 16; ++i) unknown = unknown || p[i] != 0;
  if (unknown) fail(offset, "message 'B': unknown incompatible flags");
  if ((p[8] & kIncompatDataAppended) != 0) {
    for (int i = 0; i < 3; ++i) {
      const uint64_t o = load<uint64_t>(p + 16 + 8 * i);
      if (o != 0) appended_offsets_.push_back(o);
    }
  }
}

void File::key_value(size_t offset, char kind, const uint8_t* p, size_t n, size_t start, std::string* name,
                     std::string* text, double* number, bool* numeric) const {
  const std::string what = std::string("message '") + kind + "'";
  if (n < start + 1 || n < start + 1 + p[start]) fail(offset, what + ": key longer than the message");
  const std::string key(reinterpret_cast<const char*>(p + start + 1), p[start]);
  const size_t value_at = start + 1 + p[start];
  const auto space = key.find(' ');
  std::string base;
  int count = 0;
  if (space == std::string::npos || !split_type(key.substr(0, space), &base, &count)) {
    fail(offset, what + ": key '" + key + "' is not 'type name'");
  }
  *name = key.substr(space + 1);
  *numeric = false;
  if (base == "char") {
    *text = std::string(reinterpret_cast<const char*>(p + value_at), n - value_at);
    while (!text->empty() && text->back() == '\0') text->pop_back();
    return;
  }
  const size_t elem = basic_size(base);
  if (elem == 0) fail(offset, what + " key '" + key + "': unknown type '" + base + "'");
  const size_t want = elem * static_cast<size_t>(count > 0 ? count : 1);
  if (n - value_at != want) {
    fail(offset, what + " key '" + key + "': value of " + std::to_string(n - value_at) + " bytes, the type has " +
                     std::to_string(want));
  }
  *number = basic_number(base, p + value_at);
  *numeric = count == 0;
  std::ostringstream s;
  s.precision(17);
  s << *number;
  *text = s.str();
}

void File::read_message(size_t offset, char kind, const uint8_t* p, size_t n, bool in_definitions) {
  std::string name, text;
  double value = 0.0;
  bool numeric = false;
  const auto need = [&](size_t k) {
    if (n < k) fail(offset, std::string("message '") + kind + "' has " + std::to_string(n) + " bytes, needs " + std::to_string(k));
  };
  switch (kind) {
    case 'B':
      return;
    case 'F':
      format(offset, p, n);
      return;
    case 'I':
      key_value(offset, kind, p, n, 0, &name, &text, &value, &numeric);
      info_[name] = text;
      if (!in_definitions) records_.push_back(Record{Record::Kind::kInfo, offset, 0, {}, name, value, last_timestamp_});
      return;
    case 'M': {
      need(1);
      key_value(offset, kind, p, n, 1, &name, &text, &value, &numeric);
      std::vector<std::string>& parts = info_multiple_[name];
      if (p[0] != 0 && !parts.empty()) {
        parts.back() += text;  // is_continued: the next part of the same value
      } else {
        parts.push_back(text);
      }
      return;
    }
    case 'P':
      key_value(offset, kind, p, n, 0, &name, &text, &value, &numeric);
      if (!numeric) fail(offset, "message 'P' '" + name + "': not a number");
      if (in_definitions) {
        params_[name] = value;
      } else {
        records_.push_back(Record{Record::Kind::kParameter, offset, 0, {}, name, value, last_timestamp_});
      }
      return;
    case 'Q':
      need(1);
      key_value(offset, kind, p, n, 1, &name, &text, &value, &numeric);
      return;
    case 'A': {
      need(4);
      Subscription s;
      s.multi_id = p[0];
      s.name = std::string(reinterpret_cast<const char*>(p + 3), n - 3);
      if (formats_.count(s.name) == 0) fail(offset, "message 'A': topic '" + s.name + "' has no format ('F') before it");
      auto it = layouts_.find(s.name);
      if (it == layouts_.end()) {
        try {
          it = layouts_.emplace(s.name, Layout(s.name, formats_)).first;
        } catch (const Error& e) {
          fail(offset, std::string("message 'A': ") + e.what());
        }
      }
      s.layout = &it->second;
      subscriptions_[load<uint16_t>(p + 1)] = s;
      return;
    }
    case 'R':
      need(2);
      return;
    case 'D':
      data(offset, p, n);
      return;
    case 'L':
    case 'C': {
      const size_t head = kind == 'C' ? 11 : 9;
      need(head);
      text = std::string(reinterpret_cast<const char*>(p + head), n - head);
      while (!text.empty() && text.back() == '\0') text.pop_back();
      const double level = p[0] >= '0' ? p[0] - '0' : p[0];
      records_.push_back(Record{Record::Kind::kLoggedString, offset, 0, {}, text, level, load<uint64_t>(p + head - 8)});
      return;
    }
    case 'S':
      if (n < 8 || std::memcmp(p, kSyncMagic, 8) != 0) fail(offset, "message 'S': bad sync magic");
      ++syncs_;
      return;
    case 'O':
      need(2);
      records_.push_back(Record{Record::Kind::kDropout, offset, 0, {}, {}, static_cast<double>(load<uint16_t>(p)), last_timestamp_});
      return;
    default:
      return;  // unknown message types are skipped, as the format asks of readers
  }
}

void File::format(size_t offset, const uint8_t* p, size_t n) {
  std::string text(reinterpret_cast<const char*>(p), n);
  while (!text.empty() && text.back() == '\0') text.pop_back();
  const auto colon = text.find(':');
  if (colon == std::string::npos || colon == 0) fail(offset, "message 'F': '" + text.substr(0, 60) + "' is not 'name:type field;...'");
  std::vector<FormatField> fields;
  std::stringstream rest(text.substr(colon + 1));
  std::string item;
  while (std::getline(rest, item, ';')) {
    if (item.empty()) continue;
    const auto space = item.find(' ');
    FormatField f;
    if (space == std::string::npos || !split_type(item.substr(0, space), &f.type, &f.array)) {
      fail(offset, "message 'F' of '" + text.substr(0, colon) + "': field '" + item + "' is not 'type name'");
    }
    f.name = item.substr(space + 1);
    fields.push_back(f);
  }
  formats_[text.substr(0, colon)] = fields;
}

void File::data(size_t offset, const uint8_t* p, size_t n) {
  if (n < 2) fail(offset, "message 'D' has " + std::to_string(n) + " bytes, needs at least 2");
  const uint16_t id = load<uint16_t>(p);
  const auto it = subscriptions_.find(id);
  if (it == subscriptions_.end()) fail(offset, "message 'D': msg_id " + std::to_string(id) + " has no subscription ('A') before it");
  const Layout& l = *it->second.layout;
  const size_t size = n - 2;
  // A logger may leave out the padding at the end of a topic (PX4 does): fill it back.
  if (size > l.size() || l.size() - size > l.trailing_padding()) {
    fail(offset, "message 'D' of '" + l.name() + "': " + std::to_string(size) + " bytes of data, the format has " +
                     std::to_string(l.size()));
  }
  Record r{Record::Kind::kData, offset, id, std::vector<uint8_t>(p + 2, p + n), {}, 0.0, 0};
  r.bytes.resize(l.size(), 0);
  if (l.has("timestamp") && l.field("timestamp").type == "uint64_t") {
    r.timestamp = timestamp(r, l);
    if (r.timestamp > last_timestamp_) last_timestamp_ = r.timestamp;
  }
  records_.push_back(std::move(r));
}

std::vector<uint16_t> File::ids_of(const std::string& topic, uint8_t multi_id) const {
  std::vector<uint16_t> ids;
  for (const auto& [id, s] : subscriptions_) {
    if (s.name == topic && s.multi_id == multi_id) ids.push_back(id);
  }
  return ids;
}

const Layout& File::layout(const std::string& topic) const {
  const auto it = layouts_.find(topic);
  if (it == layouts_.end()) throw Error(path_ + ": the log has no topic '" + topic + "'");
  return it->second;
}

double number(const Record& r, const FieldRef& f, int index) {
  return basic_number(f.type, r.bytes.data() + f.offset + basic_size(f.type) * static_cast<size_t>(index));
}

float float_value(const Record& r, const FieldRef& f, int index) {
  if (f.type != "float") throw Error("field of type '" + f.type + "' read as float");
  return load<float>(r.bytes.data() + f.offset + 4u * static_cast<size_t>(index));
}

uint64_t timestamp(const Record& r, const Layout& l) { return load<uint64_t>(r.bytes.data() + l.field("timestamp").offset); }

}  // namespace quad::ulog
