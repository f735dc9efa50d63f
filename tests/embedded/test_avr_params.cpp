// avr_pil --params: the file's values reach the firmware running on the simulated ATmega2560.
//
// build_param_storage (shared with param_image) must write what the firmware's own params_save_all
// writes, and refuse a bad file naming it. End to end, the HIL image on avr_pil must answer
// PARAM_REQUEST_READ with the file's values and not report an empty store: a blob at the wrong EEPROM
// offset (or in the wrong format) would boot with the defaults and say "params: store empty".
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "raw_pty.h"

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "param_file.h"
#include "quad/firmware/params.h"
#include "quad/firmware/storage_layout.h"
#include "quad/link/mavlink.h"
#include "command_output.h"

namespace {

namespace fw = quad::fw;
namespace mav = quad::mavlink;

std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/avr_params_" + std::to_string(getpid()) + "_" + name;
  std::ofstream(path) << text;
  return path;
}

// The firmware's own save of `params` into erased storage of `size` bytes.
std::vector<uint8_t> g_expected;
bool expected_read(uint16_t offset, void* dst, uint16_t length) {
  if (static_cast<size_t>(offset) + length > g_expected.size()) return false;
  std::memcpy(dst, g_expected.data() + offset, length);
  return true;
}
bool expected_write(uint16_t offset, const void* src, uint16_t length) {
  if (static_cast<size_t>(offset) + length > g_expected.size()) return false;
  std::memcpy(g_expected.data() + offset, src, length);
  return true;
}

TEST(BuildParamStorage, WritesWhatTheFirmwareSaves) {
  const std::string path = write_file("good.txt", "SYS_LOOP_HZ 400\nCAL_TIME 3.5  # longer\n");
  std::vector<uint8_t> blob;
  std::string error;
  ASSERT_TRUE(fw::build_param_storage(path, fw::kEepromSize, &blob, &error)) << error;

  fw::Params params;
  ASSERT_EQ(params.set(fw::kLoopHz, 400.0f), fw::ParamError::kNone);
  ASSERT_EQ(params.set(fw::kCalTime, 3.5f), fw::ParamError::kNone);
  g_expected.assign(fw::kEepromSize, 0xFF);
  ASSERT_TRUE(fw::params_save_all(fw::StorageIo{expected_read, expected_write}, params));
  EXPECT_TRUE(blob == g_expected) << "build_param_storage differs from params_save_all";

  // And the firmware's load reads it back: every value, the rest of the storage erased.
  fw::Params loaded;
  EXPECT_EQ(fw::params_load(fw::StorageIo{expected_read, expected_write}, loaded), fw::StoreStatus::kLoaded);
  EXPECT_FLOAT_EQ(loaded.get(fw::kLoopHz), 400.0f);
  EXPECT_FLOAT_EQ(loaded.get(fw::kCalTime), 3.5f);
  for (size_t i = fw::kParamsStoreOffset + fw::params_store_size(); i < blob.size(); ++i) {
    ASSERT_EQ(blob[i], 0xFF) << "byte " << i << " outside the parameter store was written";
  }
  std::remove(path.c_str());
}

TEST(BuildParamStorage, RefusesABadFileNamingIt) {
  const struct {
    const char* name;
    const char* text;
    const char* field;
  } cases[] = {
      {"range.txt", "SYS_LOOP_HZ 4000\n", "SYS_LOOP_HZ"},
      {"unknown.txt", "NO_SUCH_PARAM 1\n", "NO_SUCH_PARAM"},
      {"number.txt", "CAL_TIME fast\n", "CAL_TIME"},
  };
  for (const auto& c : cases) {
    const std::string path = write_file(c.name, c.text);
    std::vector<uint8_t> blob;
    std::string error;
    EXPECT_FALSE(fw::build_param_storage(path, fw::kEepromSize, &blob, &error)) << c.name;
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find(c.field), std::string::npos) << error;
    EXPECT_TRUE(blob.empty());
    std::remove(path.c_str());
  }
  std::vector<uint8_t> blob;
  std::string error;
  const std::string missing = ::testing::TempDir() + "/avr_params_no_such_file.txt";
  EXPECT_FALSE(fw::build_param_storage(missing, fw::kEepromSize, &blob, &error));
  EXPECT_NE(error.find(missing), std::string::npos) << error;
  // Storage too small for the record (the size is the board's, not the file's fault).
  const std::string path = write_file("small.txt", "SYS_LOOP_HZ 400\n");
  EXPECT_FALSE(fw::build_param_storage(path, 16, &blob, &error));
  EXPECT_NE(error.find("do not fit in 16 bytes"), std::string::npos) << error;
  std::remove(path.c_str());
}

TEST(AvrPilParams, ABadFileStopsItBeforeTheEmulation) {
  ASSERT_EQ(access(HIL_ELF, R_OK), 0) << HIL_ELF << " missing: run `make avr` first";
  const std::string path = write_file("bad.txt", "SYS_LOOP_HZ 4000\n");
  // --max-seconds bounds the run should the file be ignored.
  const quad::test::CommandOutput bad =
      quad::test::run_command(std::string(AVR_PIL_PATH) + " --elf " + HIL_ELF + " --params " + path + " --max-seconds 1");
  EXPECT_GT(bad.status, 0) << bad.out;
  EXPECT_NE(bad.out.find(path), std::string::npos) << bad.out;
  EXPECT_NE(bad.out.find("SYS_LOOP_HZ"), std::string::npos) << bad.out;
  EXPECT_EQ(bad.out.find("UART0 on"), std::string::npos) << "the emulation started: " << bad.out;
  const std::string missing = ::testing::TempDir() + "/avr_params_no_such_file.txt";
  const quad::test::CommandOutput absent =
      quad::test::run_command(std::string(AVR_PIL_PATH) + " --elf " + HIL_ELF + " --params " + missing + " --max-seconds 1");
  EXPECT_GT(absent.status, 0) << absent.out;
  EXPECT_NE(absent.out.find(missing), std::string::npos) << absent.out;
  std::remove(path.c_str());
}

struct Boot {
  std::map<uint16_t, float> values;  // PARAM_VALUE answers by index
  std::vector<std::string> texts;    // STATUSTEXT
  bool said(const char* s) const {
    for (const std::string& t : texts)
      if (t.find(s) != std::string::npos) return true;
    return false;
  }
};

// Boots the HIL image on avr_pil (with `params_path` unless empty) and asks on UART0 for the
// parameters `wanted`, until all are answered or the deadline passes.
Boot boot_and_read(const std::string& params_path, const std::vector<uint8_t>& wanted) {
  Boot boot;
  quad_test::RawPty p0(true), p2(true);
  if (p0.path.empty() || p2.path.empty()) return boot;
  const pid_t pid = fork();
  if (pid < 0) return boot;
  if (pid == 0) {
    const int null = open("/dev/null", O_WRONLY);
    dup2(null, 1);  // simavr's loader chatter and the pty lines
    std::vector<const char*> args = {AVR_PIL_PATH, "--elf", HIL_ELF, "--uart0", p0.path.c_str(),
                                     "--uart2", p2.path.c_str(), "--max-seconds", "60"};
    if (!params_path.empty()) {
      args.push_back("--params");
      args.push_back(params_path.c_str());
    }
    args.push_back(nullptr);
    execv(AVR_PIL_PATH, const_cast<char* const*>(args.data()));
    _exit(127);
  }
  mav::Sender gcs(255, 190);
  mav::Parser parser;
  const auto start = std::chrono::steady_clock::now();
  auto last_ask = start - std::chrono::seconds(1);
  while (std::chrono::steady_clock::now() - start < std::chrono::seconds(60)) {
    bool all = true;
    for (uint8_t i : wanted) all = all && boot.values.count(i) != 0;
    // Wait a little past the answers so the boot messages (sent before them) are in too.
    if (all && boot.said("calibrating")) break;
    if (std::chrono::steady_clock::now() - last_ask > std::chrono::milliseconds(300)) {
      last_ask = std::chrono::steady_clock::now();
      for (uint8_t i : wanted) {
        if (boot.values.count(i)) continue;
        mav::ParamRequestRead read;
        read.target_system = 1;
        read.target_component = 1;
        read.param_index = i;
        uint8_t buf[mav::max_frame_length<mav::ParamRequestRead>()];
        const size_t n = gcs.encode(read, buf, sizeof buf);
        if (write(p0.master, buf, n) != static_cast<ssize_t>(n)) break;
      }
    }
    pollfd p{p0.master, POLLIN, 0};
    poll(&p, 1, 20);
    uint8_t buf[1024];
    while (read(p2.master, buf, sizeof buf) > 0) {
    }  // the radio's copy of the broadcasts: drained so avr_pil never waits on a full pty
    const ssize_t n = read(p0.master, buf, sizeof buf);
    if (n <= 0) continue;
    parser.feed(buf, static_cast<size_t>(n), [&](const mav::Frame& frame) {
      if (frame.message_id == mav::ParamValue::kId) {
        mav::ParamValue v;
        if (mav::decode(frame, v)) boot.values[v.param_index] = v.param_value;
      } else if (frame.message_id == mav::Statustext::kId) {
        mav::Statustext t;
        if (mav::decode(frame, t)) boot.texts.emplace_back(t.text, strnlen(t.text, sizeof t.text));
      }
    });
  }
  kill(pid, SIGTERM);
  int status = 0;
  waitpid(pid, &status, 0);
  return boot;
}

std::string joined(const std::vector<std::string>& texts) {
  std::string s;
  for (const std::string& t : texts) s += "\n  " + t;
  return s;
}

TEST(AvrPilParams, TheFileReachesTheFirmwareInItsEeprom) {
  ASSERT_EQ(access(HIL_ELF, R_OK), 0) << HIL_ELF << " missing: run `make avr` first";
  const std::vector<uint8_t> wanted = {fw::kLoopHz, fw::kCalTime};

  // Without --params: erased EEPROM, defaults, and the firmware says so (the test can tell).
  const Boot erased = boot_and_read("", wanted);
  for (uint8_t i : wanted) ASSERT_EQ(erased.values.count(i), 1u) << "no PARAM_VALUE for " << fw::param_info(i).name;
  EXPECT_FLOAT_EQ(erased.values.at(fw::kLoopHz), fw::param_info(fw::kLoopHz).default_value);
  EXPECT_TRUE(erased.said("params: store empty")) << joined(erased.texts);

  const std::string path = write_file("boot.txt", "SYS_LOOP_HZ 400\nCAL_TIME 3.5\n");
  const Boot set = boot_and_read(path, wanted);
  for (uint8_t i : wanted) ASSERT_EQ(set.values.count(i), 1u) << "no PARAM_VALUE for " << fw::param_info(i).name;
  EXPECT_FLOAT_EQ(set.values.at(fw::kLoopHz), 400.0f);
  EXPECT_FLOAT_EQ(set.values.at(fw::kCalTime), 3.5f);
  EXPECT_TRUE(set.said("calibrating")) << "boot messages missing:" << joined(set.texts);
  EXPECT_FALSE(set.said("params")) << "the store was not accepted:" << joined(set.texts);
  std::remove(path.c_str());
}

}  // namespace
