// ulog_dump: a ULog file as text, through the C++ reader (ulog_reader.h).
//
//   ulog_dump LOG.ulg            topics with their record counts, info, parameters, logged strings
//   ulog_dump --records LOG.ulg  and every record, one line each (the canonical form ulog.py --records
//                                prints too: floats as the hex of their bits, so readers compare exactly)
#include <cstdio>
#include <cstring>
#include <iostream>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "ulog_reader.h"

namespace {

using quad::ulog::File;
using quad::ulog::FormatField;

size_t type_size(const std::string& t) {
  if (t == "double" || t == "int64_t" || t == "uint64_t") return 8;
  if (t == "float" || t == "int32_t" || t == "uint32_t") return 4;
  if (t == "int16_t" || t == "uint16_t") return 2;
  return 1;
}

void print_value(const std::string& type, const uint8_t* p) {
  if (type == "float" || type == "double") {
    const size_t n = type == "float" ? 4 : 8;
    uint64_t bits = 0;
    std::memcpy(&bits, p, n);
    std::printf(" %0*llx", static_cast<int>(2 * n), static_cast<unsigned long long>(bits));
    return;
  }
  quad::ulog::Record r;
  r.bytes.assign(8, 0);  // the field's own bytes only: it may end the record
  std::memcpy(r.bytes.data(), p, type_size(type));
  const double v = quad::ulog::number(r, quad::ulog::FieldRef{type, 0, 1});
  if (type == "uint64_t") {
    uint64_t u;
    std::memcpy(&u, p, 8);
    std::printf(" %llu", static_cast<unsigned long long>(u));
  } else if (type == "int64_t") {
    int64_t i;
    std::memcpy(&i, p, 8);
    std::printf(" %lld", static_cast<long long>(i));
  } else {
    std::printf(" %.0f", v);
  }
}

bool basic(const std::string& t) {
  return t == "double" || t == "int64_t" || t == "uint64_t" || t == "float" || t == "int32_t" || t == "uint32_t" ||
         t == "int16_t" || t == "uint16_t" || t == "int8_t" || t == "uint8_t" || t == "bool" || t == "char";
}

// The fields of `type` in order, padding left out; char arrays as text. Returns the bytes consumed.
size_t print_fields(const File& log, const std::string& type, const uint8_t* p) {
  size_t at = 0;
  for (const FormatField& f : log.formats().at(type)) {
    const int n = f.array > 0 ? f.array : 1;
    const bool padding = f.name.rfind("_padding", 0) == 0;
    if (basic(f.type) && f.type == "char" && f.array > 0) {
      if (!padding) {
        std::string text(reinterpret_cast<const char*>(p + at), static_cast<size_t>(n));
        text = text.substr(0, text.find('\0'));
        std::printf(" \"%s\"", text.c_str());
      }
      at += static_cast<size_t>(n);
    } else if (basic(f.type)) {
      for (int i = 0; i < n; ++i) {
        if (!padding) print_value(f.type, p + at);
        at += type_size(f.type);
      }
    } else {
      for (int i = 0; i < n; ++i) at += print_fields(log, f.type, p + at);
    }
  }
  return at;
}

}  // namespace

int main(int argc, char** argv) {
  bool records = false;
  std::string path;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--records") {
      records = true;
    } else if (a == "-h" || a == "--help" || a[0] == '-' || !path.empty()) {
      std::cerr << "usage: ulog_dump [--records] LOG.ulg\n";
      return a == "-h" || a == "--help" ? 0 : 2;
    } else {
      path = a;
    }
  }
  if (path.empty()) {
    std::cerr << "usage: ulog_dump [--records] LOG.ulg\n";
    return 2;
  }
  try {
    const File log(path);
    std::map<std::tuple<std::string, int>, std::vector<const quad::ulog::Record*>> by_topic;
    for (const auto& r : log.records()) {
      if (r.kind != quad::ulog::Record::Kind::kData) continue;
      const auto& s = log.subscriptions().at(r.msg_id);
      by_topic[{s.name, s.multi_id}].push_back(&r);
    }
    for (const auto& [key, list] : by_topic) {
      std::printf("topic %s %d %zu\n", std::get<0>(key).c_str(), std::get<1>(key), list.size());
    }
    for (const auto& [k, v] : log.info()) std::printf("info %s %s\n", k.c_str(), v.c_str());
    for (const auto& [k, v] : log.initial_params()) std::printf("param %s %.9g\n", k.c_str(), v);
    for (const auto& r : log.records()) {
      if (r.kind == quad::ulog::Record::Kind::kParameter) std::printf("param_change %s %.9g\n", r.key.c_str(), r.value);
    }
    for (const auto& r : log.records()) {
      if (r.kind == quad::ulog::Record::Kind::kLoggedString) {
        std::printf("string %llu %d %s\n", static_cast<unsigned long long>(r.timestamp), static_cast<int>(r.value), r.key.c_str());
      }
    }
    if (records) {
      for (const auto& [key, list] : by_topic) {
        for (const quad::ulog::Record* r : list) {
          std::printf("%s %d:", std::get<0>(key).c_str(), std::get<1>(key));
          print_fields(log, std::get<0>(key), r->bytes.data());
          std::printf("\n");
        }
      }
    }
  } catch (const quad::ulog::Error& e) {
    std::cerr << "ulog_dump: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
