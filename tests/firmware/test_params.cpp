// Parameter table and persistent store: names, ranges, round trip, and every way a store can be bad.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "quad/firmware/param_fields.h"
#include "quad/firmware/params.h"
#include "quad/firmware/storage_layout.h"

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

// Table 8.1 but for OBS_DELTA, raised to cover the in-flight gyro bias drift (docs/firmware.md).
TEST(ParamTable, ThesisTable81Defaults) {
  const Params p;
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsK1), 1.0f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsK2), 0.2f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsK3), 0.03125f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsK4), 0.00625f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsKb), 16.0f);
  EXPECT_FLOAT_EQ(p.get(quad::fw::kObsDelta), 0.05f);
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
  EXPECT_LE(quad::fw::params_store_size(), 1024u) << "two copies: keep the store a quarter of the 4 KiB EEPROM";
}

// A set that differs from the defaults in every value.
Params distinct_set(float fraction) {
  Params p;
  for (uint8_t i = 0; i < quad::fw::kParamCount; ++i) {
    const quad::fw::ParamInfo info = quad::fw::param_info(i);
    EXPECT_EQ(p.set(i, info.min + fraction * (info.max - info.min)), ParamError::kNone);
  }
  return p;
}

bool same_values(const Params& a, const Params& b) {
  for (uint8_t i = 0; i < quad::fw::kParamCount; ++i) {
    if (std::memcmp(&a.values()[i], &b.values()[i], sizeof(float)) != 0) return false;
  }
  return true;
}

TEST_F(ParamStore, ChangingOneValueWritesOnlyThatValueSequenceAndCrc) {
  Params p;
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));  // slot 0
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));  // slot 1, identical values
  eeprom_.writes = 0;
  p.set(quad::fw::kPosKpZ, 2.0f);
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));  // back into slot 0
  // 4 value bytes (fewer if some happen to agree), 1-2 sequence bytes, 2 CRC bytes (fewer by chance).
  EXPECT_LE(eeprom_.writes, 8);
  EXPECT_GE(eeprom_.writes, 3);
  Params loaded;
  EXPECT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kLoaded);
  EXPECT_FLOAT_EQ(loaded.get(quad::fw::kPosKpZ), 2.0f);
}

TEST_F(ParamStore, SavesAlternateSlotsAndTheNewestWins) {
  for (int k = 0; k < 6; ++k) {
    const Params p = distinct_set(0.1f * static_cast<float>(k + 1));
    ASSERT_TRUE(quad::fw::params_save_all(kIo, p));
    Params loaded;
    ASSERT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kLoaded);
    ASSERT_TRUE(same_values(loaded, p)) << "save " << k;
  }
  EXPECT_EQ(quad::fw::params_store_size(), 2u * (quad::fw::kParamCount * 4u + 6u));
}

TEST_F(ParamStore, SequenceNumbersWrapAround) {
  // 70 000 saves pass the 16-bit sequence's wrap; the newest set must still win after it.
  Params a = distinct_set(0.2f), b = distinct_set(0.7f);
  for (uint32_t k = 0; k < 70000u; ++k) ASSERT_TRUE(quad::fw::params_save_all(kIo, (k & 1u) ? b : a));
  Params loaded;
  ASSERT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kLoaded);
  EXPECT_TRUE(same_values(loaded, b));
}

TEST_F(ParamStore, EverySingleBitFlipOfTheOnlyCopyIsDetected) {
  Params p;
  p.set(quad::fw::kVehMass, 1.7f);
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));
  const std::vector<uint8_t> good = eeprom_.bytes;
  for (uint16_t byte = 0; byte < quad::fw::params_store_size() / 2; ++byte) {
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

TEST_F(ParamStore, ABitFlipInEitherCopyFallsBackToTheOtherCopy) {
  const Params older = distinct_set(0.3f), newer = distinct_set(0.6f);
  ASSERT_TRUE(quad::fw::params_save_all(kIo, older));
  ASSERT_TRUE(quad::fw::params_save_all(kIo, newer));
  const std::vector<uint8_t> good = eeprom_.bytes;
  const uint16_t slot = quad::fw::params_store_size() / 2;
  for (uint16_t byte = 0; byte < 2 * slot; ++byte) {
    for (int bit = 0; bit < 8; bit += 3) {
      eeprom_.bytes = good;
      eeprom_.bytes[byte] ^= static_cast<uint8_t>(1u << bit);
      Params loaded;
      ASSERT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kLoaded) << "byte " << byte;
      // Slot 0 holds the older set, slot 1 the newer: damage to one leaves the other.
      ASSERT_TRUE(same_values(loaded, byte < slot ? newer : older)) << "byte " << byte << " bit " << bit;
    }
  }
}

// Storage that loses power after `budget` more bytes: the write in progress stops there.
struct PowerCut {
  static long budget;
  static bool write(uint16_t offset, const void* src, uint16_t length) {
    const uint8_t* bytes = static_cast<const uint8_t*>(src);
    for (uint16_t i = 0; i < length; ++i) {
      if (budget <= 0) return false;
      --budget;
      g_eeprom->bytes[offset + i] = bytes[i];
      ++g_eeprom->writes;
    }
    return true;
  }
};
long PowerCut::budget = 0;
constexpr quad::fw::StorageIo kCutIo{eeprom_read, PowerCut::write};

// Saves `next` over the current store, cut after every possible byte count; each time the store must
// load as `before` (or defaults when it held no valid copy) or as `next`, never a mix.
void expect_atomic_save(FakeEeprom& eeprom, const Params& next, const Params* before, int* outcomes_old,
                        int* outcomes_new) {
  const std::vector<uint8_t> start = eeprom.bytes;
  eeprom.writes = 0;
  ASSERT_TRUE(quad::fw::params_save_all(kIo, next));
  const int full = eeprom.writes;
  ASSERT_GT(full, 0);
  for (int n = 0; n <= full; ++n) {
    eeprom.bytes = start;
    PowerCut::budget = n;
    const bool completed = quad::fw::params_save_all(kCutIo, next);
    ASSERT_EQ(completed, n == full) << n;
    Params loaded;
    const StoreStatus status = quad::fw::params_load(kIo, loaded);
    if (status == StoreStatus::kLoaded && same_values(loaded, next)) {
      ++*outcomes_new;
      continue;
    }
    ASSERT_LT(n, full) << "a completed save must load the new set";
    if (before != nullptr) {
      ASSERT_EQ(status, StoreStatus::kLoaded) << "cut after " << n << " of " << full << " bytes lost the valid copy";
      ASSERT_TRUE(same_values(loaded, *before)) << "cut after " << n << " of " << full << " bytes: a mix";
    } else {
      ASSERT_NE(status, StoreStatus::kLoaded) << n;
      ASSERT_TRUE(same_values(loaded, Params())) << "no valid copy: defaults";
    }
    ++*outcomes_old;
  }
}

TEST_F(ParamStore, PowerLossAtEveryByteOfASaveKeepsTheOldOrTheNewSet) {
  const Params a = distinct_set(0.25f), b = distinct_set(0.5f), c = distinct_set(0.75f);
  int old_count = 0, new_count = 0;
  // First save on erased storage: nothing to keep yet.
  expect_atomic_save(eeprom_, a, nullptr, &old_count, &new_count);
  ASSERT_TRUE(quad::fw::params_save_all(kIo, a));
  // Second save (into the erased slot 1), third save (over the older copy in slot 0).
  expect_atomic_save(eeprom_, b, &a, &old_count, &new_count);
  ASSERT_TRUE(quad::fw::params_save_all(kIo, b));
  expect_atomic_save(eeprom_, c, &b, &old_count, &new_count);
  // A one-value change over a store whose two copies differ in that value.
  ASSERT_TRUE(quad::fw::params_save_all(kIo, c));
  Params d = c;
  d.set(quad::fw::kVehMass, 2.5f);
  expect_atomic_save(eeprom_, d, &c, &old_count, &new_count);
  // The new set appears only once the last byte (the CRC's) has landed: one cut point per save.
  EXPECT_EQ(new_count, 4);
  EXPECT_GT(old_count, static_cast<int>(quad::fw::params_store_size() / 2)) << "the first save alone writes a whole slot";
  std::printf("power-loss cuts: %d kept the old set, %d the new one\n", old_count, new_count);
}

TEST_F(ParamStore, RandomChangesWithRandomPowerCutsNeverMixSets) {
  std::srand(7);
  Params current;  // what the store holds (defaults = nothing yet)
  bool stored = false;
  for (int k = 0; k < 300; ++k) {
    Params next = current;
    for (int j = 0; j < 1 + std::rand() % 4; ++j) {
      const uint8_t i = static_cast<uint8_t>(std::rand() % quad::fw::kParamCount);
      const quad::fw::ParamInfo info = quad::fw::param_info(i);
      next.set(i, info.min + static_cast<float>(std::rand() % 1000) / 1000.0f * (info.max - info.min));
    }
    PowerCut::budget = std::rand() % 12;  // most saves of a few values are cut
    const bool completed = quad::fw::params_save_all(kCutIo, next);
    Params loaded;
    const StoreStatus status = quad::fw::params_load(kIo, loaded);
    if (completed) {
      ASSERT_EQ(status, StoreStatus::kLoaded);
      ASSERT_TRUE(same_values(loaded, next)) << k;
    } else if (status == StoreStatus::kLoaded && same_values(loaded, next)) {
      // The cut came after the last byte that differed.
    } else {
      ASSERT_EQ(status == StoreStatus::kLoaded, stored) << k;
      ASSERT_TRUE(same_values(loaded, current)) << k;
      continue;
    }
    current = next;
    stored = true;
  }
}

TEST_F(ParamStore, OutOfRangeValueWithValidCrcIsCorrupt) {
  // A store written by a buggy tool: right CRC, impossible value.
  Params p;
  p.set(quad::fw::kLoopHz, 123.0f);
  ASSERT_TRUE(quad::fw::params_save_all(kIo, p));
  const float bad = 5000.0f;
  std::memcpy(&eeprom_.bytes[quad::fw::kLoopHz * 4], &bad, 4);
  // Recompute the slot's CRC (CRC-16/MCRF4XX over payload, sequence and tag).
  const size_t crc_at = quad::fw::params_store_size() / 2 - 2u;
  uint16_t crc = 0xFFFF;
  for (size_t i = 0; i < crc_at; ++i) {
    uint8_t tmp = static_cast<uint8_t>(eeprom_.bytes[i] ^ (crc & 0xFF));
    tmp ^= static_cast<uint8_t>(tmp << 4);
    crc = static_cast<uint16_t>((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4));
  }
  std::memcpy(&eeprom_.bytes[crc_at], &crc, 2);
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

TEST_F(ParamStore, ARecordOfAnotherTableIsNotLoaded) {
  // Another firmware's complete record: valid CRC, another tag.
  const quad::fw::RecordLayout foreign{0, quad::fw::kParamCount * 4u, 0x1234};
  const Params p = distinct_set(0.5f);
  ASSERT_TRUE(quad::fw::record_save(kIo, foreign, p.values()));
  Params loaded;
  EXPECT_EQ(quad::fw::params_load(kIo, loaded), StoreStatus::kSchemaChanged);
  EXPECT_TRUE(same_values(loaded, Params()));
  EXPECT_STRNE(quad::fw::store_status_text(StoreStatus::kSchemaChanged).p, "");
}

TEST_F(ParamStore, EverythingFitsTheAvrEeprom) {
  EXPECT_LE(quad::fw::kStorageUsed, 4096u);
  EXPECT_EQ(quad::fw::kSigningKeyOffset, quad::fw::params_store_size());
}

// The table is stored as a pool of distinct values and packed names (params.cpp): every entry must
// still give exactly the name, default, minimum and maximum that QUAD_PARAM_TABLE says.
TEST(ParamTable, EveryEntryIsExactlyTheTableRow) {
  struct Row {
    const char* name;
    float def, lo, hi;
  };
  const Row rows[] = {
#define QUAD_PARAM_ROW(id, name, def, lo, hi) {name, def, lo, hi},
      QUAD_PARAM_TABLE(QUAD_PARAM_ROW)
#undef QUAD_PARAM_ROW
  };
  ASSERT_EQ(sizeof rows / sizeof rows[0], static_cast<size_t>(quad::fw::kParamCount));
  for (uint8_t i = 0; i < quad::fw::kParamCount; ++i) {
    const quad::fw::ParamInfo info = quad::fw::param_info(i);
    EXPECT_STREQ(info.name, rows[i].name) << int(i);
    EXPECT_EQ(info.name[quad::fw::kParamNameLength], '\0');
    // Bit patterns, not values: the pool must not merge 0.0f with -0.0f or round anything.
    EXPECT_EQ(std::memcmp(&info.default_value, &rows[i].def, sizeof(float)), 0) << rows[i].name;
    EXPECT_EQ(std::memcmp(&info.min, &rows[i].lo, sizeof(float)), 0) << rows[i].name;
    EXPECT_EQ(std::memcmp(&info.max, &rows[i].hi, sizeof(float)), 0) << rows[i].name;
    EXPECT_EQ(Params().get(i), rows[i].def) << rows[i].name;
  }
  // An index beyond the table reads entry 0, as before.
  EXPECT_STREQ(quad::fw::param_info(quad::fw::kParamCount).name, rows[0].name);
}

// param_find over the packed names: strncmp(name, stored, 16) semantics for every name, its prefixes,
// its extensions and a 16-byte id without a terminator.
TEST(ParamTable, FindComparesTheFirstSixteenCharacters) {
  for (uint8_t i = 0; i < quad::fw::kParamCount; ++i) {
    const std::string name = quad::fw::param_info(i).name;
    EXPECT_EQ(quad::fw::param_find(name.c_str()), i) << name;
    EXPECT_EQ(quad::fw::param_find(name.substr(0, name.size() - 1).c_str()), -1) << name;
    EXPECT_EQ(quad::fw::param_find((name + "X").c_str()), name.size() == 16 ? i : -1) << name;
    char id[16];
    std::memset(id, 0, sizeof id);
    std::memcpy(id, name.data(), name.size());
    EXPECT_EQ(quad::fw::param_find(id), i) << name;
    // Characters after the 16th never count.
    char longer[24];
    std::memset(longer, 'Z', sizeof longer);
    longer[23] = '\0';
    std::memcpy(longer, name.data(), name.size());
    if (name.size() < 16) longer[name.size()] = '\0';
    EXPECT_EQ(quad::fw::param_find(longer), i) << name;
  }
  EXPECT_EQ(quad::fw::param_find(""), -1);
  EXPECT_EQ(quad::fw::param_find("SYS_LOOP_HZ_"), -1);
  EXPECT_EQ(quad::fw::param_find("TEL_SYS_HZ"), quad::fw::kTelSysHz) << "the last name";
}

// Every entry of param_fields.h's tables against member-by-member assignments written out here: each
// parameter holds a value no other parameter holds, so a wrong id or a wrong offset shows as a field
// with another parameter's value (or its default).
class ParamFields : public ::testing::Test {
 protected:
  void SetUp() override {
    std::set<float> seen;
    for (uint8_t i = 0; i < quad::fw::kParamCount; ++i) {
      const quad::fw::ParamInfo info = quad::fw::param_info(i);
      float v = info.min + (0.1f + 0.8f * static_cast<float>(i + 1) / (quad::fw::kParamCount + 1)) * (info.max - info.min);
      while (seen.count(v) != 0) v = std::nextafter(v, info.max);  // another parameter's value by chance
      ASSERT_EQ(p_.set(i, v), ParamError::kNone) << info.name;
      seen.insert(v);
    }
  }
  float get(quad::fw::ParamId id) const { return p_.get(id); }
  Params p_;
};

TEST_F(ParamFields, Cascade) {
  quad::ctrl::CascadeParams c;
  const quad::ctrl::CascadeParams defaults;
  quad::fw::load_fields(p_, c, quad::fw::kCascadeFields);
  EXPECT_EQ(c.vehicle.mass, get(quad::fw::kVehMass));
  EXPECT_EQ(c.vehicle.inertia.x, get(quad::fw::kVehIxx));
  EXPECT_EQ(c.vehicle.inertia.y, get(quad::fw::kVehIyy));
  EXPECT_EQ(c.vehicle.inertia.z, get(quad::fw::kVehIzz));
  EXPECT_EQ(c.vehicle.arm_length, get(quad::fw::kVehArm));
  EXPECT_EQ(c.vehicle.max_motor_thrust, get(quad::fw::kVehMotThrMax));
  EXPECT_EQ(c.vehicle.thrust_coeff, get(quad::fw::kVehThrCoef));
  EXPECT_EQ(c.position.kp.x, get(quad::fw::kPosKpXY));
  EXPECT_EQ(c.position.kp.y, get(quad::fw::kPosKpXY));
  EXPECT_EQ(c.position.kp.z, get(quad::fw::kPosKpZ));
  EXPECT_EQ(c.position.kv.x, get(quad::fw::kPosKvXY));
  EXPECT_EQ(c.position.kv.y, get(quad::fw::kPosKvXY));
  EXPECT_EQ(c.position.kv.z, get(quad::fw::kPosKvZ));
  EXPECT_EQ(c.attitude.alpha, get(quad::fw::kAttAlpha));
  EXPECT_EQ(c.attitude.gamma.x, get(quad::fw::kAttGammaXY));
  EXPECT_EQ(c.attitude.gamma.y, get(quad::fw::kAttGammaXY));
  EXPECT_EQ(c.attitude.gamma.z, get(quad::fw::kAttGammaZ));
  EXPECT_EQ(c.max_tilt, get(quad::fw::kPosTiltMax));
  // The computed fields are apply_params()' own: untouched here.
  EXPECT_EQ(c.vehicle.yaw_coeff, defaults.vehicle.yaw_coeff);
  EXPECT_EQ(c.vehicle.frame, defaults.vehicle.frame);
  EXPECT_EQ(sizeof quad::fw::kCascadeFields / sizeof(quad::fw::ParamField), 18u) << "a new entry needs a check here";
}

TEST_F(ParamFields, ManualAndShaper) {
  quad::ctrl::ManualParams m;
  const quad::ctrl::ManualParams md;
  quad::fw::load_fields(p_, m, quad::fw::kManualFields);
  EXPECT_EQ(m.max_angle, get(quad::fw::kManTiltMax));
  EXPECT_EQ(m.max_yaw_rate, get(quad::fw::kManYawRate));
  EXPECT_EQ(m.max_thrust, md.max_thrust);
  EXPECT_EQ(m.dead_band, md.dead_band);
  EXPECT_EQ(m.min_pulse, md.min_pulse);
  EXPECT_EQ(m.max_pulse, md.max_pulse);
  EXPECT_EQ(sizeof quad::fw::kManualFields / sizeof(quad::fw::ParamField), 2u);

  quad::ctrl::ShaperParams s;
  quad::fw::load_fields(p_, s, quad::fw::kShaperFields);
  EXPECT_EQ(s.max_speed, get(quad::fw::kShpSpeed));
  EXPECT_EQ(s.max_accel, get(quad::fw::kShpAccel));
  EXPECT_EQ(s.final_gain, get(quad::fw::kShpGain));
  EXPECT_EQ(sizeof quad::fw::kShaperFields / sizeof(quad::fw::ParamField), 3u);
}

TEST_F(ParamFields, MagnetometerCalibration) {
  quad::est::MagCalibration c;
  quad::fw::load_fields(p_, c, quad::fw::kMagFields);
  EXPECT_EQ(c.offset.x, get(quad::fw::kMagOfsX));
  EXPECT_EQ(c.offset.y, get(quad::fw::kMagOfsY));
  EXPECT_EQ(c.offset.z, get(quad::fw::kMagOfsZ));
  // Mat3::from_rows(X*, Y*, Z*) as before: row r, column c.
  const quad::Mat3 w = quad::Mat3::from_rows(
      quad::Vec3{get(quad::fw::kMagSiXX), get(quad::fw::kMagSiXY), get(quad::fw::kMagSiXZ)},
      quad::Vec3{get(quad::fw::kMagSiYX), get(quad::fw::kMagSiYY), get(quad::fw::kMagSiYZ)},
      quad::Vec3{get(quad::fw::kMagSiZX), get(quad::fw::kMagSiZY), get(quad::fw::kMagSiZZ)});
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) EXPECT_EQ(c.soft_iron(r, k), w(r, k)) << r << k;
  }
  EXPECT_EQ(sizeof quad::fw::kMagFields / sizeof(quad::fw::ParamField), 12u);
}

TEST_F(ParamFields, ObserverFilterStarAndCalibration) {
  quad::est::ObserverParams o;
  const quad::est::ObserverParams od;
  quad::fw::load_fields(p_, o, quad::fw::kObserverFields);
  EXPECT_EQ(o.k1, get(quad::fw::kObsK1));
  EXPECT_EQ(o.k2, get(quad::fw::kObsK2));
  EXPECT_EQ(o.k3, get(quad::fw::kObsK3));
  EXPECT_EQ(o.k4, get(quad::fw::kObsK4));
  EXPECT_EQ(o.kb, get(quad::fw::kObsKb));
  EXPECT_EQ(o.delta, get(quad::fw::kObsDelta));
  EXPECT_EQ(o.accel_norm_tolerance, get(quad::fw::kObsAccTol));
  EXPECT_EQ(o.k_i, od.k_i);
  EXPECT_EQ(o.mag_ref_ned.x, od.mag_ref_ned.x);
  EXPECT_EQ(o.mag_ref_ned.z, od.mag_ref_ned.z);
  EXPECT_EQ(sizeof quad::fw::kObserverFields / sizeof(quad::fw::ParamField), 7u);

  quad::est::PositionFilterParams f;
  const quad::est::PositionFilterParams fd;
  quad::fw::load_fields(p_, f, quad::fw::kFilterFields);
  EXPECT_EQ(f.q_pos, get(quad::fw::kKfQPos));
  EXPECT_EQ(f.q_vel, get(quad::fw::kKfQVel));
  EXPECT_EQ(f.q_accel, get(quad::fw::kKfQAcc));
  EXPECT_EQ(f.fix_sigma_xy, get(quad::fw::kKfFixSigXY));
  EXPECT_EQ(f.fix_sigma_z, get(quad::fw::kKfFixSigZ));
  EXPECT_EQ(f.gate_sigma, get(quad::fw::kKfGateSig));
  EXPECT_EQ(f.q_bias, fd.q_bias);
  EXPECT_EQ(f.bias_sigma0, fd.bias_sigma0);
  EXPECT_EQ(f.reset_position_sigma, fd.reset_position_sigma);
  EXPECT_EQ(sizeof quad::fw::kFilterFields / sizeof(quad::fw::ParamField), 6u);

  quad::Vec3 star{-1.0f, -2.0f, -3.0f};
  quad::fw::load_fields(p_, star, quad::fw::kStarFields);
  EXPECT_EQ(star.x, get(quad::fw::kVisStarN));
  EXPECT_EQ(star.y, get(quad::fw::kVisStarE));
  EXPECT_EQ(star.z, get(quad::fw::kVisStarD));

  quad::Euler mount{-1.0f, -2.0f, -3.0f};
  quad::fw::load_fields(p_, mount, quad::fw::kCameraMountFields);
  EXPECT_EQ(mount.roll, get(quad::fw::kEstCamRoll));
  EXPECT_EQ(mount.pitch, get(quad::fw::kEstCamPitch));
  EXPECT_EQ(mount.yaw, get(quad::fw::kEstCamYaw));

  quad::fw::CalibrationConfig cc;
  const quad::fw::CalibrationConfig cd;
  quad::fw::load_fields(p_, cc, quad::fw::kCalibrationFields);
  EXPECT_EQ(cc.duration_s, get(quad::fw::kCalTime));
  EXPECT_EQ(cc.limits.max_gyro_std, get(quad::fw::kCalGyroStd));
  EXPECT_EQ(cc.limits.max_accel_std, get(quad::fw::kCalAccStd));
  EXPECT_EQ(cc.limits.max_gyro_mean, get(quad::fw::kCalGyroMax));
  EXPECT_EQ(cc.limits.max_accel_bias, get(quad::fw::kCalAccMax));
  EXPECT_EQ(cc.limits.min_samples, cd.limits.min_samples);
  EXPECT_EQ(sizeof quad::fw::kCalibrationFields / sizeof(quad::fw::ParamField), 5u);
}

TEST_F(ParamFields, Ekf) {
  quad::est::EkfParams e;
  const quad::est::EkfParams ed;
  quad::fw::load_fields(p_, e, quad::fw::kEkfFields);
  EXPECT_EQ(e.fix_sigma_floor, get(quad::fw::kEstEvpNoise));
  EXPECT_EQ(e.attitude_sigma_floor, get(quad::fw::kEstEvaNoise));
  EXPECT_EQ(e.star_bias_sigma0, get(quad::fw::kEstSattBias));
  EXPECT_EQ(e.fix_sigma, ed.fix_sigma);
  EXPECT_EQ(e.star_bias_walk, ed.star_bias_walk);
  EXPECT_EQ(sizeof quad::fw::kEkfFields / sizeof(quad::fw::ParamField), 3u);
}

// The EKF library's defaults (its tests, estimation_replay) are the firmware's parameter defaults.
TEST(ParamTable, EkfDefaultsAreTheLibrarysDefaults) {
  const Params defaults;
  quad::est::EkfParams loaded;
  loaded.fix_sigma_floor = loaded.attitude_sigma_floor = loaded.star_bias_sigma0 = -1.0f;
  quad::fw::load_fields(defaults, loaded, quad::fw::kEkfFields);
  const quad::est::EkfParams library;
  EXPECT_EQ(loaded.fix_sigma_floor, library.fix_sigma_floor);
  EXPECT_EQ(loaded.attitude_sigma_floor, library.attitude_sigma_floor);
  EXPECT_EQ(loaded.star_bias_sigma0, library.star_bias_sigma0);
}

}  // namespace
