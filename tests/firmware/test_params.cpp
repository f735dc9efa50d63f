// Parameter table and persistent store: names, ranges, round trip, and every way a store can be bad.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "quad/firmware/params.h"

namespace {

using quad::fw::ParamError;
using quad::fw::Params;
using quad::fw::StoreStatus;

// An EEPROM in memory (erased = 0xFF) with a switch to make the device fail.
struct FakeEeprom {
  std::vector<uint8_t> bytes = std::vector<uint8_t>(4096, 0xFF);
  bool fail = false;
  int writes = 0;
};
FakeEeprom* g_eeprom = nullptr;

bool eeprom_read(uint16_t offset, void* dst, uint16_t length) {
  if (g_eeprom->fail || offset + length > g_eeprom->bytes.size()) return false;
  std::memcpy(dst, g_eeprom->bytes.data() + offset, length);
  return true;
}
bool eeprom_write(uint16_t offset, const void* src, uint16_t length) {
  if (g_eeprom->fail || offset + length > g_eeprom->bytes.size()) return false;
  std::memcpy(g_eeprom->bytes.data() + offset, src, length);
  g_eeprom->writes += length;
  return true;
}
constexpr quad::fw::StorageIo kIo{eeprom_read, eeprom_write};

class ParamStore : public ::testing::Test {
 protected:
  void SetUp() override { g_eeprom = &eeprom_; }
  void TearDown() override { g_eeprom = nullptr; }
  FakeEeprom eeprom_;
};

TEST(ParamTable, NamesAreUniqueMavlinkIdsAndDefaultsWithinRange) {
  std::set<std::string> names;
  for (uint8_t i = 0; i < quad::fw::kParamCount; ++i) {
    const quad::fw::ParamInfo info = quad::fw::param_info(i);
    const std::string name(info.name);
    EXPECT_FALSE(name.empty());
    EXPECT_LE(name.size(), 16u) << name;
    for (char c : name) EXPECT_TRUE((c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_') << name;
    EXPECT_TRUE(names.insert(name).second) << "duplicate " << name;
    EXPECT_LE(info.min, info.default_value) << name;
    EXPECT_LE(info.default_value, info.max) << name;
    EXPECT_EQ(quad::fw::param_find(info.name), i) << name;
  }
}

TEST(ParamTable, ThesisTable81Defaults) {
  const Params p;
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsK1), 1.0f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsK2), 0.2f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsK3), 0.03125f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsK4), 0.00625f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsKb), 16.0f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsDelta), 0.03f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kAttAlpha), 3.0f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kAttGammaXY), 0.625f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kAttGammaZ), 0.5f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kPosKpXY), 3.625f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kPosKvXY), 11.875f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kPosKvZ), 3.5f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kLoopHz), 100.0f);
}

TEST(ParamTable, FindMatchesSixteenCharactersWithoutTerminator) {
  // MAVLink's param_id is exactly 16 bytes, NUL-terminated only when shorter.
  char id[16];
  std::memset(id, 0, sizeof id);
  std::memcpy(id, "FS_VIS_TIMEOUT", 14);
  EXPECT_EQ(quad::fw::param_find(id), quad::fw::kFsVisTimeout);
  EXPECT_EQ(quad::fw::param_find("NO_SUCH_PARAM"), -1);
  EXPECT_EQ(quad::fw::param_find("FS_VIS"), -1) << "prefixes must not match";
}

TEST(ParamTable, SetChecksRangeAndFiniteness) {
  Params p;
  const uint16_t generation = p.generation();
  EXPECT_EQ(p.set(quad::fw::kLoopHz, 400.0f), ParamError::kNone);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kLoopHz), 400.0f);
  EXPECT_NE(p.generation(), generation);
  EXPECT_EQ(p.set(quad::fw::kLoopHz, 2000.0f), ParamError::kOutOfRange);
  EXPECT_EQ(p.set(quad::fw::kLoopHz, 10.0f), ParamError::kOutOfRange);
  EXPECT_EQ(p.set(quad::fw::kLoopHz, NAN), ParamError::kNotFinite);
  EXPECT_EQ(p.set(quad::fw::kLoopHz, INFINITY), ParamError::kNotFinite);
  EXPECT_EQ(p.set(quad::fw::kParamCount, 1.0f), ParamError::kUnknownName);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kLoopHz), 400.0f) << "a refused value leaves the old one";
}

TEST_F(ParamStore, ErasedStorageGivesDefaults) {
  Params p;
  p.set(quad::fw::kLoopHz, 400.0f);
  EXPECT_EQ(quad::fw::params_load(kIo, p), StoreStatus::kEmpty);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kLoopHz), 100.0f);
}

TEST_F(ParamStore, RoundTripKeepsEveryValue) {
  Params p;
  for (uint8_t i = 0; i < quad::fw::kParamCount; ++i) {
    const quad::fw::ParamInfo info = quad::fw::param_info(i);
    ASSERT_EQ(p.set(i, info.min + 0.37f * (info.max - info.min)), ParamError::kNone);
  }
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));
  Params loaded;
  EXPECT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kLoaded);
  for (uint8_t i = 0; i < quad::fw::kParamCount; ++i) EXPECT_EQ(loaded.get(i), p.get(i)) << int(i);
  EXPECT_LE(quad::fw::params_store_size(), 512u) << "keep the store small for the 4 KiB EEPROM";
}

TEST_F(ParamStore, SaveOneWritesOnlyTheValueAndCrc) {
  Params p;
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));
  eeprom_.writes = 0;
  p.set(quad::fw::kPosKpZ, 2.0f);
  ASSERT_TRUE(quad::fw::params_save_one(kIo, p, quad::fw::kPosKpZ));
  EXPECT_EQ(eeprom_.writes, 6) << "4 value bytes + 2 CRC bytes";
  Params loaded;
  EXPECT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kLoaded);
  EXPECT_FLOAT_EQ(loaded.get(quad::fw::kPosKpZ), 2.0f);
}

TEST_F(ParamStore, SaveOneOnAForeignStoreWritesEverything) {
  Params p;
  p.set(quad::fw::kPosKpZ, 2.0f);
  ASSERT_TRUE(quad::fw::params_save_one(kIo, p, quad::fw::kPosKpZ));
  Params loaded;
  EXPECT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kLoaded);
  EXPECT_FLOAT_EQ(loaded.get(quad::fw::kPosKpZ), 2.0f);
}

TEST_F(ParamStore, EverySingleBitFlipIsDetected) {
  Params p;
  p.set(quad::fw::kVehMass, 1.7f);
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));
  const std::vector<uint8_t> good = eeprom_.bytes;
  for (uint16_t byte = 0; byte < quad::fw::params_store_size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      eeprom_.bytes = good;
      eeprom_.bytes[byte] ^= static_cast<uint8_t>(1u << bit);
      Params loaded;
      loaded.set(quad::fw::kVehMass, 3.0f);
      const StoreStatus status = quad::fw::params_load(kIo, loaded);
      ASSERT_NE(status, StoreStatus::kLoaded) << "byte " << byte << " bit " << bit;
      ASSERT_FLOAT_EQ(loaded.get(quad::fw::kVehMass), 1.4f) << "a bad store must leave the defaults";
    }
  }
}

TEST_F(ParamStore, OutOfRangeValueWithValidCrcIsCorrupt) {
  // A store written by a buggy tool: right CRC, impossible value.
  Params p;
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));
  // Find the loop rate's slot by saving a recognisable value.
  p.set(quad::fw::kLoopHz, 123.0f);
  ASSERT_TRUE(quad::fw::params_save_one(kIo, p, quad::fw::kLoopHz));
  const float marker = 123.0f;
  auto it = std::search(eeprom_.bytes.begin(), eeprom_.bytes.end(), reinterpret_cast<const uint8_t*>(&marker),
                        reinterpret_cast<const uint8_t*>(&marker) + 4);
  ASSERT_NE(it, eeprom_.bytes.end());
  const float bad = 5000.0f;
  std::memcpy(&*it, &bad, 4);
  // Recompute a valid CRC by re-saving through a Params that cannot hold 5000 ... impossible, so patch
  // the CRC by hand with the MAVLink X.25 CRC the store uses.
  uint16_t crc = 0xFFFF;
  const size_t values = 8;  // header size
  for (size_t i = values; i < quad::fw::params_store_size() - 2u; ++i) {
    uint8_t tmp = static_cast<uint8_t>(eeprom_.bytes[i] ^ (crc & 0xFF));
    tmp ^= static_cast<uint8_t>(tmp << 4);
    crc = static_cast<uint16_t>((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4));
  }
  std::memcpy(&eeprom_.bytes[quad::fw::params_store_size() - 2u], &crc, 2);
  Params loaded;
  EXPECT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kCorrupt);
  EXPECT_FLOAT_EQ(loaded.get(quad::fw::kLoopHz), 100.0f);
}

TEST_F(ParamStore, DeviceFailureFallsBackToDefaults) {
  Params p;
  p.set(quad::fw::kLoopHz, 400.0f);
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));
  eeprom_.fail = true;
  Params loaded;
  EXPECT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kIoError);
  EXPECT_FLOAT_EQ(loaded.get(quad::fw::kLoopHz), 100.0f);
  EXPECT_FALSE(quad::fw::params_save_all(kIo, p));
}

TEST_F(ParamStore, DifferentSchemaIsNotLoaded) {
  Params p;
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));
  // The schema hash sits after magic and version.
  eeprom_.bytes[4] ^= 0x5A;
  Params loaded;
  EXPECT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kSchemaChanged);
  EXPECT_STRNE(quad::fw::store_status_text(StoreStatus::kSchemaChanged).p, "");
}

}  // namespace
