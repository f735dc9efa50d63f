// A reader of PX4 ULog files (https://docs.px4.io/main/en/dev_log/ulog_file_format.html), version 1.
//
// Generic: formats ('F', nested types, arrays), info ('I', 'M'), parameters ('P'; 'Q' defaults),
// subscriptions ('A', 'R'), data ('D'), logged strings ('L', 'C'), sync ('S'), dropouts ('O') and the
// appended-data flag. The data section is kept in file order (records(), each with its kind), so a
// replay sees a parameter change between the samples it came between. A file that does not follow the
// format throws ulog::Error naming the file, the byte offset and the message.
#pragma once

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace quad::ulog {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct FormatField {
  std::string type;  // a basic type ("float") or another format's name
  int array = 0;     // element count, 0 for a scalar
  std::string name;
};

// Where a basic-typed field (or a field of a nested type, "a.b", or an element of an array, "q[2]") sits
// in a topic's record.
struct FieldRef {
  std::string type;  // basic type
  size_t offset = 0;
  int count = 1;     // elements from offset (an array, or 1)
};

// One topic as the log defines it: its fields flattened to byte offsets.
class Layout {
 public:
  Layout() = default;
  Layout(const std::string& name, const std::map<std::string, std::vector<FormatField>>& formats);
  const std::string& name() const { return name_; }
  size_t size() const { return size_; }
  size_t trailing_padding() const { return trailing_padding_; }
  bool has(const std::string& field) const { return fields_.count(field) != 0; }
  // Throws Error naming the topic when it has no such field.
  const FieldRef& field(const std::string& field) const;

 private:
  void add(const std::string& prefix, const std::string& type,
           const std::map<std::string, std::vector<FormatField>>& formats, int depth);
  std::string name_;
  size_t size_ = 0;
  size_t trailing_padding_ = 0;
  std::map<std::string, FieldRef> fields_;
};

struct Subscription {
  std::string name;
  uint8_t multi_id = 0;
  const Layout* layout = nullptr;
};

// One message of the data section, in file order.
struct Record {
  enum class Kind { kData, kParameter, kLoggedString, kDropout, kInfo };
  Kind kind = Kind::kData;
  size_t offset = 0;           // of the message header in the file
  uint16_t msg_id = 0;         // kData
  std::vector<uint8_t> bytes;  // kData: the topic's record (padding filled back)
  std::string key;             // kParameter / kInfo: the name; kLoggedString: the text
  double value = 0.0;          // kParameter: the value; kLoggedString: the level (0..7); kDropout: ms
  uint64_t timestamp = 0;      // kLoggedString: its own; otherwise the last data timestamp before it
};

class File {
 public:
  // Reads and checks the whole file; throws Error.
  explicit File(const std::string& path);

  const std::string& path() const { return path_; }
  uint64_t header_timestamp() const { return header_timestamp_; }
  bool data_appended() const { return !appended_offsets_.empty(); }
  const std::map<std::string, std::vector<FormatField>>& formats() const { return formats_; }
  // 'I' values: text for char arrays, else the number as text (std::stod gives it back exactly).
  const std::map<std::string, std::string>& info() const { return info_; }
  // 'M' values: each value's parts joined (is_continued), in file order.
  const std::map<std::string, std::vector<std::string>>& info_multiple() const { return info_multiple_; }
  // Numeric 'P' values at log start (the definitions section).
  const std::map<std::string, double>& initial_params() const { return params_; }
  const std::map<uint16_t, Subscription>& subscriptions() const { return subscriptions_; }
  const std::vector<Record>& records() const { return records_; }
  int syncs() const { return syncs_; }

  // The msg_ids of a topic's instance (usually one); empty when it was not subscribed.
  std::vector<uint16_t> ids_of(const std::string& topic, uint8_t multi_id = 0) const;
  // The topic's layout; throws Error naming the file when the log has no such topic.
  const Layout& layout(const std::string& topic) const;

 private:
  [[noreturn]] void fail(size_t offset, const std::string& what) const;
  void read_message(size_t offset, char kind, const uint8_t* p, size_t n, bool in_definitions);
  void flag_bits(size_t offset, const uint8_t* p, size_t n);
  void format(size_t offset, const uint8_t* p, size_t n);
  void data(size_t offset, const uint8_t* p, size_t n);
  // 'type name' key and value of an 'I', 'M', 'P' or 'Q' message (from `start`).
  void key_value(size_t offset, char kind, const uint8_t* p, size_t n, size_t start, std::string* name,
                 std::string* text, double* number, bool* numeric) const;

  std::string path_;
  uint64_t header_timestamp_ = 0;
  std::vector<uint64_t> appended_offsets_;
  std::map<std::string, std::vector<FormatField>> formats_;
  std::map<std::string, Layout> layouts_;
  std::map<std::string, std::string> info_;
  std::map<std::string, std::vector<std::string>> info_multiple_;
  std::map<std::string, double> params_;
  std::map<uint16_t, Subscription> subscriptions_;
  std::vector<Record> records_;
  uint64_t last_timestamp_ = 0;
  int syncs_ = 0;
};

// A basic-typed value of a record, converted to double (every ULog number type), or a float exactly.
double number(const Record& r, const FieldRef& f, int index = 0);
float float_value(const Record& r, const FieldRef& f, int index = 0);  // the field must be "float"
uint64_t timestamp(const Record& r, const Layout& l);                  // the record's uint64 timestamp

}  // namespace quad::ulog
