// The table-driven decoder: bit positions in both byte orders, signedness, scaling,
// the default layout's exact bytes, and the JSON schema of docs/unit-can.md.
#include <gtest/gtest.h>
#include <linux/can.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "drivers/socketcan/frame_layout.hpp"

namespace standcal::drivers::can {
namespace {

TEST(CanBits, IntelReadsLittleEndianFromTheLsb) {
  const std::uint8_t d[8] = {0x78, 0x56, 0x34, 0x12, 0, 0, 0, 0};
  EXPECT_EQ(extract_raw(d, 0, 32, ByteOrder::intel), 0x12345678U);
  EXPECT_EQ(extract_raw(d, 4, 8, ByteOrder::intel), 0x67U);  // high nibble of byte 0, low of byte 1
  EXPECT_EQ(extract_raw(d, 8, 16, ByteOrder::intel), 0x3456U);
  EXPECT_EQ(bytes_needed(4, 8, ByteOrder::intel), 2);
}

TEST(CanBits, MotorolaReadsBigEndianFromTheMsbInDbcNumbering) {
  const std::uint8_t d[8] = {0x12, 0x34, 0x56, 0x78, 0, 0, 0, 0};
  EXPECT_EQ(extract_raw(d, 7, 16, ByteOrder::motorola), 0x1234U);  // MSB = bit 7 of byte 0
  EXPECT_EQ(extract_raw(d, 7, 32, ByteOrder::motorola), 0x12345678U);
  EXPECT_EQ(extract_raw(d, 3, 8, ByteOrder::motorola),
            0x23U);  // low nibble of byte 0, high of byte 1
  EXPECT_EQ(extract_raw(d, 15, 8, ByteOrder::motorola), 0x34U);
  EXPECT_EQ(bytes_needed(3, 8, ByteOrder::motorola), 2);
}

TEST(CanBits, InsertIsTheInverseOfExtractInBothOrders) {
  std::mt19937_64 rng(42);
  for (auto order : {ByteOrder::intel, ByteOrder::motorola}) {
    for (int trial = 0; trial < 2000; ++trial) {
      const int length = 1 + static_cast<int>(rng() % 64);
      const int start = static_cast<int>(rng() % 64);
      if (bytes_needed(start, length, order) > 16) continue;
      std::uint8_t d[16];
      for (auto& b : d) b = static_cast<std::uint8_t>(rng());
      std::uint8_t before[16];
      std::copy(std::begin(d), std::end(d), before);
      const std::uint64_t raw = rng() & (length == 64 ? ~0ULL : ((1ULL << length) - 1));
      insert_raw(d, start, length, order, raw);
      ASSERT_EQ(extract_raw(d, start, length, order), raw)
          << "start " << start << " length " << length;
      // Bits outside the signal are untouched.
      int changed_bits = 0;
      for (int i = 0; i < 16; ++i)
        changed_bits += __builtin_popcount(static_cast<unsigned>(d[i] ^ before[i]));
      ASSERT_LE(changed_bits, length);
    }
  }
}

FrameLayout one_signal_layout(SignalSpec temperature) {
  std::vector<SignalSpec> s{
      {"fx", SignalRole::force_x, 0x10, false, 0, 8, ByteOrder::intel, true, 1, 0, "m/s2"},
      {"fy", SignalRole::force_y, 0x10, false, 8, 8, ByteOrder::intel, true, 1, 0, "m/s2"},
      {"fz", SignalRole::force_z, 0x10, false, 16, 8, ByteOrder::intel, true, 1, 0, "m/s2"},
      {"n", SignalRole::counter, 0x10, false, 24, 8, ByteOrder::intel, false, 1, 0, ""},
      std::move(temperature)};
  auto r = FrameLayout::from_signals(std::move(s));
  EXPECT_TRUE(r.ok()) << r.status().message;
  return r.value();
}

TEST(FrameLayout, SignedAndUnsignedReadTheSameBitsDifferently) {
  const std::uint8_t d[8] = {0xFE, 0xFF, 0, 0, 0, 0, 0, 0};
  FrameValues v;
  auto s = one_signal_layout(
      {"t", SignalRole::temperature, 0x20, false, 0, 16, ByteOrder::intel, true, 1, 0, "degC"});
  ASSERT_TRUE(s.decode(0x20, d, 8, v));
  EXPECT_TRUE(v.has_temperature);
  EXPECT_DOUBLE_EQ(v.temperature_c, -2.0);
  auto u = one_signal_layout(
      {"t", SignalRole::temperature, 0x20, false, 0, 16, ByteOrder::intel, false, 1, 0, "degC"});
  ASSERT_TRUE(u.decode(0x20, d, 8, v));
  EXPECT_DOUBLE_EQ(v.temperature_c, 65534.0);
}

TEST(FrameLayout, ScaleAndOffsetGivePhysicalValues) {
  // Motorola 12-bit signed at 0.0625 degC with -40 offset: raw 0x7FF -> 87.9375 degC.
  auto layout = one_signal_layout({"t", SignalRole::temperature, 0x20, false, 7, 12,
                                   ByteOrder::motorola, true, 0.0625, -40, "degC"});
  const std::uint8_t pos[8] = {0x7F, 0xF0, 0, 0, 0, 0, 0, 0};
  FrameValues v;
  ASSERT_TRUE(layout.decode(0x20, pos, 8, v));
  EXPECT_DOUBLE_EQ(v.temperature_c, 0x7FF * 0.0625 - 40);
  const std::uint8_t neg[8] = {0x80, 0x00, 0, 0, 0, 0, 0, 0};  // raw 0x800 = -2048
  ASSERT_TRUE(layout.decode(0x20, neg, 8, v));
  EXPECT_DOUBLE_EQ(v.temperature_c, -2048 * 0.0625 - 40);
}

TEST(FrameLayout, ForceUnitsConvertToMetresPerSecondSquared) {
  std::vector<SignalSpec> s{
      {"fx", SignalRole::force_x, 0x10, false, 0, 16, ByteOrder::intel, true, 1, 0, "mg"},
      {"fy", SignalRole::force_y, 0x10, false, 16, 16, ByteOrder::intel, true, 1, 0, "ug"},
      {"fz", SignalRole::force_z, 0x10, false, 32, 16, ByteOrder::intel, true, 0.5, 0, "m/s2"},
      {"n", SignalRole::counter, 0x10, false, 48, 16, ByteOrder::intel, false, 1, 0, ""}};
  auto layout = FrameLayout::from_signals(s);
  ASSERT_TRUE(layout.ok()) << layout.status().message;
  const std::uint8_t d[8] = {0xE8, 0x03, 0x0C, 0xFE, 0x03, 0x00, 0x07, 0x00};  // 1000, -500, 3, 7
  FrameValues v;
  ASSERT_TRUE(layout.value().decode(0x10, d, 8, v));
  EXPECT_EQ(v.force_mask, 0x7);
  EXPECT_NEAR(v.force_mps2[0], 1000 * 1e-3 * kStandardGravity_mps2, 1e-12);
  EXPECT_NEAR(v.force_mps2[1], -500 * 1e-6 * kStandardGravity_mps2, 1e-12);
  EXPECT_NEAR(v.force_mps2[2], 1.5, 1e-12);
  EXPECT_EQ(v.counter, 7U);
}

TEST(FrameLayout, DefaultLayoutHasTheDocumentedBytes) {
  const auto layout = FrameLayout::default_layout();
  EXPECT_EQ(layout.counter_modulus(), 65536U);
  EXPECT_EQ(layout.can_ids(), (std::vector<std::uint32_t>{0x101, 0x102, 0x103, 0x104}));
  // +1 g on x is 10 000 000 in 1e-7 g = 0x00989680, little-endian; counter 0x1234.
  const auto frames =
      layout.encode({kStandardGravity_mps2, -0.5 * kStandardGravity_mps2, 0.0}, 25.5, 0x1234);
  ASSERT_EQ(frames.size(), 4U);
  EXPECT_EQ(frames[0].can_id, 0x101U);
  EXPECT_EQ(frames[0].len, 6);
  const std::uint8_t x_bytes[6] = {0x80, 0x96, 0x98, 0x00, 0x34, 0x12};
  EXPECT_TRUE(std::equal(std::begin(x_bytes), std::end(x_bytes), frames[0].data.begin()));
  const std::uint8_t y_bytes[6] = {0xC0, 0xB4, 0xB3, 0xFF, 0x34, 0x12};  // -5 000 000
  EXPECT_TRUE(std::equal(std::begin(y_bytes), std::end(y_bytes), frames[1].data.begin()));
  const std::uint8_t t_bytes[4] = {0xF6, 0x09, 0x34, 0x12};  // 2550 x 0.01 degC
  EXPECT_EQ(frames[3].len, 4);
  EXPECT_TRUE(std::equal(std::begin(t_bytes), std::end(t_bytes), frames[3].data.begin()));

  FrameValues v;
  ASSERT_TRUE(layout.decode(0x101, frames[0].data.data(), frames[0].len, v));
  EXPECT_EQ(v.force_mask, 0x1);
  EXPECT_NEAR(v.force_mps2[0], kStandardGravity_mps2, 1e-12);
  EXPECT_EQ(v.counter, 0x1234U);
  ASSERT_TRUE(layout.decode(0x104, frames[3].data.data(), frames[3].len, v));
  EXPECT_NEAR(v.temperature_c, 25.5, 1e-9);
}

TEST(FrameLayout, UnknownIdsAndShortFramesAreRejected) {
  const auto layout = FrameLayout::default_layout();
  const std::uint8_t d[8] = {};
  FrameValues v;
  EXPECT_FALSE(layout.decode(0x105, d, 8, v));
  EXPECT_FALSE(layout.decode(0x101, d, 5, v));                 // counter needs bytes 4..5
  EXPECT_FALSE(layout.decode(0x101 | CAN_EFF_FLAG, d, 8, v));  // same number, extended id
}

TEST(FrameLayout, EncodeClampsOutOfRangeValues) {
  const auto layout = FrameLayout::default_layout();
  const auto frames = layout.encode({1e9, -1e9, 0}, std::nan(""), 0);
  FrameValues v;
  ASSERT_TRUE(layout.decode(0x101, frames[0].data.data(), frames[0].len, v));
  EXPECT_NEAR(v.force_mps2[0], 2147483647 * 1e-7 * kStandardGravity_mps2, 1e-9);
  ASSERT_TRUE(layout.decode(0x102, frames[1].data.data(), frames[1].len, v));
  EXPECT_NEAR(v.force_mps2[1], -2147483648.0 * 1e-7 * kStandardGravity_mps2, 1e-9);
}

const char* kDocExample = R"({
  "signals": [
    {"name": "force_x", "role": "force_x", "can_id": "0x181", "start_bit": 7, "length": 24,
     "byte_order": "motorola", "signed": true, "scale": 1e-6, "unit": "g"},
    {"name": "force_y", "role": "force_y", "can_id": "0x181", "start_bit": 31, "length": 24,
     "byte_order": "motorola", "signed": true, "scale": 1e-6, "unit": "g"},
    {"name": "force_z", "role": "force_z", "can_id": "0x182", "start_bit": 7, "length": 24,
     "byte_order": "motorola", "signed": true, "scale": 1e-6, "unit": "g"},
    {"name": "seq_xy", "role": "counter", "can_id": "0x181", "start_bit": 55, "length": 8,
     "byte_order": "motorola"},
    {"name": "seq_z", "role": "counter", "can_id": "0x182", "start_bit": 55, "length": 8,
     "byte_order": "motorola"},
    {"name": "temp", "role": "temperature", "can_id": 386, "start_bit": 31, "length": 16,
     "byte_order": "motorola", "signed": true, "scale": 0.01, "offset": 0, "unit": "degC"}
  ]
})";

TEST(FrameLayoutJson, ParsesTheDocumentedExampleAndRoundTrips) {
  auto r = FrameLayout::from_json(nlohmann::json::parse(kDocExample));
  ASSERT_TRUE(r.ok()) << r.status().message;
  const auto& layout = r.value();
  EXPECT_EQ(layout.counter_modulus(), 256U);
  EXPECT_EQ(layout.can_ids(), (std::vector<std::uint32_t>{0x181, 0x182}));
  const auto frames = layout.encode(
      {0.25 * kStandardGravity_mps2, -0.125 * kStandardGravity_mps2, kStandardGravity_mps2}, -12.34,
      300);
  ASSERT_EQ(frames.size(), 2U);
  // force_x = 250 000 = 0x03D090, big-endian in bytes 0..2; counter 300 mod 256 = 44 in byte 6.
  EXPECT_EQ(frames[0].data[0], 0x03);
  EXPECT_EQ(frames[0].data[1], 0xD0);
  EXPECT_EQ(frames[0].data[2], 0x90);
  EXPECT_EQ(frames[0].data[6], 44);
  FrameValues v;
  ASSERT_TRUE(layout.decode(0x181, frames[0].data.data(), frames[0].len, v));
  EXPECT_EQ(v.force_mask, 0x3);
  EXPECT_NEAR(v.force_mps2[0], 0.25 * kStandardGravity_mps2, 1e-9);
  EXPECT_NEAR(v.force_mps2[1], -0.125 * kStandardGravity_mps2, 1e-9);
  ASSERT_TRUE(layout.decode(0x182, frames[1].data.data(), frames[1].len, v));
  EXPECT_EQ(v.force_mask, 0x4);
  EXPECT_TRUE(v.has_temperature);
  EXPECT_NEAR(v.temperature_c, -12.34, 1e-9);
  EXPECT_EQ(v.counter, 44U);
}

std::string parse_error(const std::string& text) {
  auto r = FrameLayout::from_json(nlohmann::json::parse(text));
  return r.ok() ? "" : r.status().message;
}

TEST(FrameLayoutJson, MistakesAreNamed) {
  auto doc = nlohmann::json::parse(kDocExample);
  auto with = [&](auto edit) {
    auto j = doc;
    edit(j);
    return parse_error(j.dump());
  };
  EXPECT_NE(with([](auto& j) { j["signals"][0]["lenght"] = 3; }).find("unknown key 'lenght'"),
            std::string::npos);
  EXPECT_NE(with([](auto& j) { j["signals"][1]["start_bit"] = 15; }).find("overlaps"),
            std::string::npos);
  EXPECT_NE(with([](auto& j) {
              j["signals"][2]["role"] = "force_y";
            }).find("exactly one signal must have role force_y"),
            std::string::npos);
  EXPECT_NE(
      with([](auto& j) { j["signals"][0]["unit"] = "degC"; }).find("does not fit role force_x"),
      std::string::npos);
  EXPECT_NE(with([](auto& j) { j["signals"].erase(4); }).find("needs exactly one counter"),
            std::string::npos);
  EXPECT_NE(with([](auto& j) { j["signals"][0]["can_id"] = "0x800"; }).find("id too large"),
            std::string::npos);
  // Wholly a number: std::stoul took "0x181zz" as 0x181 and said only "stoul" for "x".
  for (const char* bad : {"0x181zz", "x", "0x", "18 1"}) {
    EXPECT_NE(with([bad](auto& j) {
                j["signals"][0]["can_id"] = bad;
              }).find(std::string("signals[0]: can_id \"") + bad + "\" must be a number"),
              std::string::npos)
        << bad;
  }
  EXPECT_EQ(with([](auto& j) { j["signals"][0]["can_id"] = "385"; }), "") << "0x181 in decimal";
  EXPECT_NE(with([](auto& j) { j["signals"][0]["byte_order"] = "big"; }).find("intel or motorola"),
            std::string::npos);
  EXPECT_NE(with([](auto& j) { j["signals"][0]["length"] = "24"; }).find("signals[0]"),
            std::string::npos);
  EXPECT_NE(parse_error("[1,2]").find("\"signals\" array"), std::string::npos);
}

TEST(FrameLayoutJson, ExtendedIdsAndCanFdPayloads) {
  // One 64-byte CAN FD frame with all three axes as 64-bit doubles' worth of bits.
  nlohmann::json j;
  j["signals"] = nlohmann::json::array();
  const char* roles[3] = {"force_x", "force_y", "force_z"};
  for (int i = 0; i < 3; ++i)
    j["signals"].push_back({{"role", roles[i]},
                            {"can_id", 0x1ABCDE},
                            {"extended", true},
                            {"start_bit", 128 + 64 * i},
                            {"length", 64},
                            {"signed", true},
                            {"scale", 1e-12},
                            {"unit", "g"}});
  j["signals"].push_back({{"role", "counter"},
                          {"can_id", 0x1ABCDE},
                          {"extended", true},
                          {"start_bit", 480},
                          {"length", 32}});
  auto r = FrameLayout::from_json(j);
  ASSERT_TRUE(r.ok()) << r.status().message;
  EXPECT_EQ(r.value().can_ids(), (std::vector<std::uint32_t>{0x1ABCDE | CAN_EFF_FLAG}));
  const auto frames = r.value().encode({1.0, -2.0, 3.0}, 0, 0xFFFFFFFFU);
  ASSERT_EQ(frames.size(), 1U);
  EXPECT_EQ(frames[0].len, 64);
  FrameValues v;
  ASSERT_TRUE(r.value().decode(0x1ABCDE | CAN_EFF_FLAG, frames[0].data.data(), 64, v));
  EXPECT_NEAR(v.force_mps2[0], 1.0, 1e-10);
  EXPECT_NEAR(v.force_mps2[1], -2.0, 1e-10);
  EXPECT_NEAR(v.force_mps2[2], 3.0, 1e-10);
  EXPECT_EQ(v.counter, 0xFFFFFFFFU);
  EXPECT_EQ(r.value().counter_modulus(), 1ULL << 32);
}

}  // namespace
}  // namespace standcal::drivers::can
