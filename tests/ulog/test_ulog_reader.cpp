// The C++ ULog reader (tools/ulog/ulog_reader.h) on logs composed here byte by byte from the format's
// specification (docs.px4.io "ULog File Format"): nested types, arrays, info, parameters at the start and
// in flight, logged strings, sync, dropout, trailing padding left out, appended data, unknown messages;
// and the errors, each naming the byte offset and the message.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "ulog_reader.h"

namespace fs = std::filesystem;
using quad::ulog::Error;
using quad::ulog::File;
using quad::ulog::Record;

namespace {

struct Bytes {
  std::vector<uint8_t> b;
  template <class T>
  Bytes& put(T v) {
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    b.insert(b.end(), p, p + sizeof v);
    return *this;
  }
  Bytes& text(const std::string& s) {
    b.insert(b.end(), s.begin(), s.end());
    return *this;
  }
  Bytes& message(char type, const Bytes& payload) {
    put<uint16_t>(static_cast<uint16_t>(payload.b.size())).put<uint8_t>(static_cast<uint8_t>(type));
    b.insert(b.end(), payload.b.begin(), payload.b.end());
    return *this;
  }
};

Bytes header() {
  Bytes h;
  h.text("ULog").put<uint8_t>(0x01).put<uint8_t>(0x12).put<uint8_t>(0x35).put<uint8_t>(1).put<uint64_t>(1234);
  return h;
}

Bytes key_value(const std::string& key, const Bytes& value) {
  Bytes p;
  p.put<uint8_t>(static_cast<uint8_t>(key.size())).text(key);
  p.b.insert(p.b.end(), value.b.begin(), value.b.end());
  return p;
}

Bytes flags(uint8_t incompat0, uint64_t appended_offset) {
  Bytes p;
  for (int i = 0; i < 8; ++i) p.put<uint8_t>(0);
  p.put<uint8_t>(incompat0);
  for (int i = 0; i < 7; ++i) p.put<uint8_t>(0);
  p.put<uint64_t>(appended_offset).put<uint64_t>(0).put<uint64_t>(0);
  return p;
}

// Definitions of a topic with a nested type in an array, and its subscription as msg_id 7.
Bytes definitions() {
  Bytes d = header();
  d.message('B', flags(0, 0));
  d.message('F', Bytes().text("pair:float a;int16_t b;"));
  d.message('F', Bytes().text("sample:uint64_t timestamp;float[3] v;pair[2] p;uint8_t flag;uint8_t[3] _padding0;"));
  d.message('I', key_value("char[11] sys_name", Bytes().text("quad-stereo")));
  d.message('I', key_value("uint32_t loop_hz", Bytes().put<uint32_t>(400)));
  d.message('P', key_value("float SYS_LOOP_HZ", Bytes().put<float>(400.0f)));
  d.message('A', Bytes().put<uint8_t>(0).put<uint16_t>(7).text("sample"));
  return d;
}

// One record of "sample" (without its 3 padding bytes: a logger may leave them out).
Bytes sample(uint64_t t, float v0) {
  Bytes p;
  p.put<uint16_t>(7).put<uint64_t>(t).put<float>(v0).put<float>(2.0f).put<float>(3.0f);
  p.put<float>(0.5f).put<int16_t>(-3).put<float>(1.5f).put<int16_t>(4).put<uint8_t>(1);
  return p;
}

fs::path write(const std::string& name, const std::vector<uint8_t>& b) {
  const fs::path p = fs::path(::testing::TempDir()) / ("ulog_reader_" + name + "_" + std::to_string(getpid()) + ".ulg");
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
  return p;
}

std::string error_of(const std::vector<uint8_t>& b, const std::string& name) {
  const fs::path p = write(name, b);
  try {
    File f(p.string());
  } catch (const Error& e) {
    fs::remove(p);
    return e.what();
  }
  fs::remove(p);
  return "";
}

}  // namespace

TEST(UlogReader, ReadsEveryKindOfMessageInFileOrder) {
  Bytes b = definitions();
  b.message('D', sample(1000, 1.0f));
  b.message('P', key_value("float SYS_LOOP_HZ", Bytes().put<float>(200.0f)));
  b.message('L', Bytes().put<uint8_t>('4').put<uint64_t>(1500).text("mode: AUTO"));
  b.message('S', Bytes().put<uint8_t>(0x2f).put<uint8_t>(0x73).put<uint8_t>(0x13).put<uint8_t>(0x20)
                     .put<uint8_t>(0x25).put<uint8_t>(0x0c).put<uint8_t>(0xbb).put<uint8_t>(0x12));
  b.message('O', Bytes().put<uint16_t>(25));
  b.message('Z', Bytes().text("a message type the reader does not know"));
  b.message('D', sample(2000, -1.0f));
  const fs::path p = write("all", b.b);
  const File f(p.string());
  fs::remove(p);

  EXPECT_EQ(f.header_timestamp(), 1234u);
  EXPECT_EQ(f.info().at("sys_name"), "quad-stereo");
  EXPECT_EQ(std::stod(f.info().at("loop_hz")), 400.0);
  EXPECT_EQ(f.initial_params().at("SYS_LOOP_HZ"), 400.0);
  EXPECT_EQ(f.syncs(), 1);
  const auto& l = f.layout("sample");
  EXPECT_EQ(l.size(), 8u + 12u + 2u * 6u + 1u + 3u);
  ASSERT_EQ(f.records().size(), 5u);
  const Record& first = f.records()[0];
  EXPECT_EQ(first.kind, Record::Kind::kData);
  EXPECT_EQ(first.timestamp, 1000u);
  EXPECT_EQ(quad::ulog::float_value(first, l.field("v"), 0), 1.0f);
  EXPECT_EQ(quad::ulog::float_value(first, l.field("v[2]")), 3.0f);
  EXPECT_EQ(quad::ulog::float_value(first, l.field("p[1].a")), 1.5f);
  EXPECT_EQ(quad::ulog::number(first, l.field("p[0].b")), -3.0);
  EXPECT_EQ(quad::ulog::number(first, l.field("p[1].b")), 4.0);
  EXPECT_EQ(quad::ulog::number(first, l.field("flag")), 1.0);
  EXPECT_EQ(f.records()[1].kind, Record::Kind::kParameter);
  EXPECT_EQ(f.records()[1].key, "SYS_LOOP_HZ");
  EXPECT_EQ(f.records()[1].value, 200.0);
  EXPECT_EQ(f.records()[1].timestamp, 1000u) << "a change is stamped with the data before it";
  EXPECT_EQ(f.records()[2].kind, Record::Kind::kLoggedString);
  EXPECT_EQ(f.records()[2].key, "mode: AUTO");
  EXPECT_EQ(f.records()[2].value, 4.0);
  EXPECT_EQ(f.records()[2].timestamp, 1500u);
  EXPECT_EQ(f.records()[3].kind, Record::Kind::kDropout);
  EXPECT_EQ(f.records()[3].value, 25.0);
  EXPECT_EQ(quad::ulog::float_value(f.records()[4], l.field("v")), -1.0f);
  EXPECT_THROW(l.field("w"), Error);
}

TEST(UlogReader, SkipsToTheAppendedDataPastACutMessage) {
  Bytes b = definitions();
  b.message('D', sample(1000, 1.0f));
  // The regular data ends in the middle of a record; the appended block starts after it.
  Bytes cut;
  cut.message('D', sample(2000, 2.0f));
  cut.b.resize(10);
  b.b.insert(b.b.end(), cut.b.begin(), cut.b.end());
  const uint64_t appended = b.b.size();
  b.message('D', sample(3000, 3.0f));
  // The flag bits are the first message after the header: rewrite them with the offset.
  Bytes flagged = flags(1, appended);
  std::memcpy(&b.b[16 + 3], flagged.b.data(), flagged.b.size());
  const fs::path p = write("appended", b.b);
  const File f(p.string());
  fs::remove(p);
  EXPECT_TRUE(f.data_appended());
  ASSERT_EQ(f.records().size(), 2u);
  EXPECT_EQ(f.records()[1].timestamp, 3000u);
}

TEST(UlogReader, ErrorsNameTheByteOffsetAndTheMessage) {
  Bytes good = definitions();
  const size_t d_at = good.b.size();
  good.message('D', sample(1000, 1.0f));

  std::vector<uint8_t> truncated(good.b.begin(), good.b.end() - 5);
  std::string e = error_of(truncated, "truncated");
  EXPECT_NE(e.find("byte " + std::to_string(d_at)), std::string::npos) << e;
  EXPECT_NE(e.find("truncated: message 'D'"), std::string::npos) << e;

  std::vector<uint8_t> bad_magic = good.b;
  bad_magic[1] = 'X';
  e = error_of(bad_magic, "magic");
  EXPECT_NE(e.find("byte 0: not a ULog file"), std::string::npos) << e;

  Bytes orphan = definitions();
  const size_t orphan_at = orphan.b.size();
  Bytes payload = sample(1000, 1.0f);
  payload.b[0] = 9;  // msg_id 9: never subscribed
  orphan.message('D', payload);
  e = error_of(orphan.b, "orphan");
  EXPECT_NE(e.find("byte " + std::to_string(orphan_at) + ": message 'D': msg_id 9 has no subscription"), std::string::npos) << e;

  Bytes too_long = definitions();
  Bytes long_payload = sample(1000, 1.0f);
  for (int i = 0; i < 8; ++i) long_payload.put<uint8_t>(0);
  too_long.message('D', long_payload);
  e = error_of(too_long.b, "long");
  EXPECT_NE(e.find("message 'D' of 'sample': 41 bytes of data, the format has 36"), std::string::npos) << e;

  Bytes incompat = header();
  incompat.message('B', flags(2, 0));
  e = error_of(incompat.b, "incompat");
  EXPECT_NE(e.find("byte 16: message 'B': unknown incompatible flags"), std::string::npos) << e;

  Bytes no_format = header();
  no_format.message('A', Bytes().put<uint8_t>(0).put<uint16_t>(1).text("missing"));
  e = error_of(no_format.b, "noformat");
  EXPECT_NE(e.find("byte 16: message 'A': topic 'missing' has no format"), std::string::npos) << e;

  EXPECT_NE(error_of({}, "empty").find("shorter than the 16-byte header"), std::string::npos);
}
