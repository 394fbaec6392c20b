// The unit's CAN layout from a DBC file (drivers/socketcan/dbc.hpp, docs/unit-can.md):
// a DBC written by hand for the emulator's frames is the default layout, a vendor-style
// DBC with a role map is the documented JSON layout, and mistakes name file and line.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <tuple>
#include <vector>

#include "drivers/socketcan/dbc.hpp"
#include "drivers/socketcan/frame_layout.hpp"

namespace standcal::drivers::can {
namespace {

const std::string kData = STANDCAL_CAN_TEST_DATA;

void expect_same_signal(const SignalSpec& a, const SignalSpec& b) {
  SCOPED_TRACE(a.name + " vs " + b.name);
  EXPECT_EQ(a.role, b.role);
  EXPECT_EQ(a.can_id, b.can_id);
  EXPECT_EQ(a.extended, b.extended);
  EXPECT_EQ(a.start_bit, b.start_bit);
  EXPECT_EQ(a.length, b.length);
  EXPECT_EQ(a.byte_order, b.byte_order);
  EXPECT_EQ(a.is_signed, b.is_signed);
  EXPECT_DOUBLE_EQ(a.scale, b.scale);
  EXPECT_DOUBLE_EQ(a.offset, b.offset);
  EXPECT_EQ(a.unit, b.unit);
}

// Signals with a role, in role order then by CAN id, so two layouts compare one to one.
std::vector<SignalSpec> by_role(std::vector<SignalSpec> s) {
  std::sort(s.begin(), s.end(), [](const SignalSpec& a, const SignalSpec& b) {
    return std::tie(a.role, a.can_id) < std::tie(b.role, b.can_id);
  });
  return s;
}

void expect_same_layout(const FrameLayout& a, const FrameLayout& b) {
  const auto sa = by_role(a.signals()), sb = by_role(b.signals());
  ASSERT_EQ(sa.size(), sb.size());
  for (std::size_t i = 0; i < sa.size(); ++i) expect_same_signal(sa[i], sb[i]);
  EXPECT_EQ(a.can_ids(), b.can_ids());
  EXPECT_EQ(a.counter_modulus(), b.counter_modulus());
  // The frames one encodes, the other decodes to the same sample.
  const std::array<double, 3> force{0.5 * kStandardGravity_mps2, -0.25 * kStandardGravity_mps2,
                                    0.875 * kStandardGravity_mps2};
  FrameValues v;
  std::array<double, 3> decoded{};
  for (const auto& f : a.encode(force, 23.45, 77)) {
    ASSERT_TRUE(b.decode(f.can_id, f.data.data(), f.len, v));
    EXPECT_EQ(v.counter, 77U);
    for (std::size_t i = 0; i < 3; ++i)
      if (v.force_mask & (1U << i)) decoded[i] = v.force_mps2[i];
    if (v.has_temperature) {
      EXPECT_NEAR(v.temperature_c, 23.45, 1e-9);
    }
  }
  for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(decoded[i], force[i], 1e-5);
}

TEST(Dbc, HandWrittenFileForTheEmulatorsFramesIsTheDefaultLayout) {
  const auto dbc = FrameLayout::from_file(kData + "/standcal_unit.dbc");
  ASSERT_TRUE(dbc.ok()) << dbc.status().message;
  // Four messages; the comment's "SG_" line is not read, nor the pseudo-message's signal
  // (named force_x: read, it would make a second force_x and the layout fail).
  EXPECT_EQ(dbc.value().signals().size(), 8U);
  expect_same_layout(dbc.value(), FrameLayout::default_layout());
  expect_same_layout(FrameLayout::default_layout(), dbc.value());
}

TEST(Dbc, VendorFileWithARoleMapIsTheDocumentedJsonLayout) {
  const auto dbc = FrameLayout::from_file(kData + "/vendor_imu_layout.json");
  ASSERT_TRUE(dbc.ok()) << dbc.status().message;
  const auto json = FrameLayout::from_file(kData + "/vendor_imu_signals.json");
  ASSERT_TRUE(json.ok()) << json.status().message;
  EXPECT_EQ(dbc.value().signals().size(), 6U);  // Status and IMU_INFO have no role
  expect_same_layout(dbc.value(), json.value());
  expect_same_layout(json.value(), dbc.value());
}

TEST(Dbc, ParsesEveryMessageAndTheFloatMarks) {
  // CRLF line ends (Windows tools), a blank line and a tab inside the signal list, a
  // comment with escaped quotes over two lines whose second line looks like an SG_, and
  // the look-alike keywords BO_TX_BU_ and SG_MUL_VAL_.
  const auto parsed = parse_dbc(
      "BO_ 2147484033 EXT: 8 IMU\r\n"
      " SG_ A : 0|32@1- (0.5,-1) [0|0] \"m/s^2\" Logger\r\n"
      "\r\n"
      " SG_\tF : 32|32@1- (1,0) [0|0] \"\" Logger\r\n"
      "CM_ SG_ 2147484033 A \"a \\\"quoted\\\" word,\r\n"
      " SG_ B : 0|8@1+ (1,0) [0|0] \"\" L is comment text\";\r\n"
      "BO_TX_BU_ 2147484033 : IMU,Logger;\r\n"
      "SG_MUL_VAL_ 2147484033 A F 0-0;\r\n"
      "SIG_VALTYPE_ 2147484033 F : 1;\r\n",
      "x.dbc");
  ASSERT_TRUE(parsed.ok()) << parsed.status().message;
  ASSERT_EQ(parsed.value().size(), 2U);
  const auto& a = parsed.value()[0];
  EXPECT_EQ(a.message, "EXT");
  EXPECT_EQ(a.message_dlc, 8);
  EXPECT_EQ(a.line, 2);
  EXPECT_TRUE(a.spec.extended);
  EXPECT_EQ(a.spec.can_id, 0x181U);  // 2147484033 = 0x80000181: the extended flag and 0x181
  EXPECT_EQ(a.spec.unit, "m/s2");
  EXPECT_DOUBLE_EQ(a.spec.scale, 0.5);
  EXPECT_DOUBLE_EQ(a.spec.offset, -1);
  EXPECT_FALSE(a.is_float);
  EXPECT_TRUE(parsed.value()[1].is_float);
}

std::string dbc_error(const std::string& text, const DbcRoles& roles = {}) {
  const auto r = layout_from_dbc(text, "unit.dbc", roles);
  return r.ok() ? "(accepted)" : r.status().message;
}

// A valid three-axis file to break one line of.
std::string three_axes(const std::string& force_x_line, const std::string& extra = "") {
  return "BO_ 257 ACC_XY: 8 IMU\n" + force_x_line +
         "\n SG_ force_y : 16|16@1- (1E-4,0) [0|0] \"g\" L\n"
         " SG_ counter_a : 32|16@1+ (1,0) [0|0] \"\" L\n"
         "BO_ 258 ACC_Z: 4 IMU\n"
         " SG_ force_z : 0|16@1- (1E-4,0) [0|0] \"g\" L\n"
         " SG_ counter_b : 16|16@1+ (1,0) [0|0] \"\" L\n" +
         extra;
}

TEST(Dbc, MistakesNameTheFileTheLineAndTheFix) {
  const std::string good_x = " SG_ force_x : 0|16@1- (1E-4,0) [0|0] \"g\" L";
  ASSERT_EQ(dbc_error(three_axes(good_x)), "(accepted)");
  EXPECT_EQ(dbc_error(three_axes(" SG_ force_x M : 0|16@1- (1E-4,0) [0|0] \"g\" L")),
            "unit.dbc:2: signal force_x of ACC_XY is multiplexed; standcal reads only plain "
            "signals");
  EXPECT_EQ(dbc_error(three_axes(good_x, "SIG_VALTYPE_ 257 force_x : 1;\n")),
            "unit.dbc:2: signal force_x of ACC_XY is an IEEE float (SIG_VALTYPE_); standcal "
            "reads integer signals");
  EXPECT_EQ(dbc_error(three_axes(" SG_ force_x : 56|16@1- (1E-4,0) [0|0] \"g\" L")),
            "unit.dbc:2: signal force_x of ACC_XY needs 9 bytes but the message's DLC is 8");
  EXPECT_EQ(dbc_error(three_axes(" SG_ force_x : 0|16@2- (1E-4,0) [0|0] \"g\" L"))
                .rfind("unit.dbc:2: an SG_ line must read 'SG_ NAME : START|LENGTH@ORDER", 0),
            0U);
  EXPECT_EQ(dbc_error(three_axes(" SG_ force_x : 0|16@1- (1E-4,0) [0|0] \"furlong\" L")),
            "unit.dbc: CAN layout: signal 'force_x' (0x101): unit 'furlong' does not fit role "
            "force_x");
  EXPECT_EQ(dbc_error(" SG_ force_x : 0|16@1- (1,0) [0|0] \"g\" L\n"),
            "unit.dbc:1: an SG_ line outside a BO_ message's signal list");
  EXPECT_EQ(dbc_error("BO_ 257 ACC: 99 IMU\n"),
            "unit.dbc:1: message ACC: DLC 99 is not 0..64 bytes");
  EXPECT_EQ(dbc_error(three_axes(good_x, "CM_ BO_ 257 \"never closed;\nBA_ \"x\" 1;\n")),
            "unit.dbc:8: a string opened here is never closed");
  EXPECT_EQ(dbc_error("BO_ 257 A: 8 IMU\n SG_ s : 0|8@1+ (1,0) [0|0] \"\" L\n"),
            "unit.dbc: no signal has a role: name the signals force_x, force_y, force_z, "
            "temperature and counter_*, or give a JSON layout with \"dbc\" and \"roles\" "
            "(docs/unit-can.md)");
}

TEST(Dbc, LongReceiverListsAreReadAndOverlongLinesRefused) {
  std::string receivers;
  while (receivers.size() < 3900) receivers += "Node" + std::to_string(receivers.size()) + ",";
  receivers.pop_back();
  const std::string long_x = " SG_ force_x : 0|16@1- (1E-4,0) [0|0] \"g\" " + receivers;
  ASSERT_LE(long_x.size(), 4096U);
  EXPECT_EQ(dbc_error(three_axes(long_x)), "(accepted)");
  const std::string overlong = long_x + std::string(5000, 'x');
  EXPECT_EQ(dbc_error(three_axes(overlong)),
            "unit.dbc:2: line is " + std::to_string(overlong.size() - 1) +
                " characters long; a SG_ line may have at most 4096");
}

TEST(Dbc, ARoleMapMustNameSignalsThatExistAndOnlyOnce) {
  const std::string text =
      "BO_ 257 A: 8 IMU\n SG_ ax : 0|16@1- (1,0) [0|0] \"g\" L\n SG_ seq : 16|8@1+ (1,0) [0|0] "
      "\"\" L\n"
      "BO_ 258 B: 8 IMU\n SG_ ay : 0|16@1- (1,0) [0|0] \"g\" L\n SG_ seq : 16|8@1+ (1,0) [0|0] "
      "\"\" L\n"
      "BO_ 259 C: 8 IMU\n SG_ az : 0|16@1- (1,0) [0|0] \"g\" L\n SG_ sq : 16|8@1+ (1,0) [0|0] \"\" "
      "L\n";
  DbcRoles roles{{"ax", SignalRole::force_x},    {"ay", SignalRole::force_y},
                 {"az", SignalRole::force_z},    {"A.seq", SignalRole::counter},
                 {"B.seq", SignalRole::counter}, {"sq", SignalRole::counter}};
  EXPECT_EQ(dbc_error(text, roles), "(accepted)");
  EXPECT_EQ(dbc_error(text + " SG_ sq : 24|8@1+ (1,0) [0|0] \"\" L\n", roles),
            "unit.dbc: roles: 'sq' is twice in message C");
  roles["seq"] = SignalRole::counter;
  EXPECT_EQ(dbc_error(text, roles),
            "unit.dbc: roles: 'seq' is a signal of A and B; name it MESSAGE.SIGNAL");
  roles.erase("seq");
  roles["AccX"] = SignalRole::force_x;
  EXPECT_EQ(dbc_error(text, roles), "unit.dbc: roles: no signal 'AccX' in the file");
  roles.erase("AccX");
  roles.erase("sq");  // C's force then has no counter: the layout's own rule
  EXPECT_EQ(dbc_error(text, roles),
            "unit.dbc: CAN layout: frame 0x103 carries a force and needs exactly one counter "
            "signal");
}

// A layout JSON written to the test's temporary directory.
std::string layout_file_error(const std::string& json_text) {
  const std::string path = ::testing::TempDir() + "/dbc_layout.json";
  std::ofstream(path) << json_text;
  const auto r = FrameLayout::from_file(path);
  return r.ok() ? "(accepted)" : r.status().message.substr(path.size() + 2);
}

TEST(Dbc, ALayoutFileNamingADbcChecksItsKeysAndRoles) {
  const std::string dbc = "\"" + kData + "/vendor_imu.dbc\"";
  EXPECT_EQ(
      layout_file_error("{\"dbc\": " + dbc +
                        ", \"roles\": {\"AccX\": \"force_x\", \"AccY\": \"force_y\", "
                        "\"AccZ\": \"force_z\", \"SeqXY\": \"counter\", \"SeqZ\": \"counter\"}}"),
      "(accepted)");  // an absolute path, and no temperature
  EXPECT_EQ(layout_file_error("{\"dbc\": " + dbc + ", \"role\": {}}"),
            "CAN layout: unknown key 'role' beside \"dbc\" (expected \"dbc\" and \"roles\")");
  EXPECT_EQ(layout_file_error("{\"dbc\": " + dbc + ", \"roles\": {\"AccX\": \"x\"}}"),
            "CAN layout: roles.AccX: must be force_x, force_y, force_z, temperature or counter");
  EXPECT_EQ(layout_file_error("{\"dbc\": 7}"), "CAN layout: \"dbc\" must be the DBC file's path");
  const auto missing = FrameLayout::from_file(kData + "/no_such.dbc");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().message, "cannot open CAN layout file " + kData + "/no_such.dbc");
  const auto dir = FrameLayout::from_file(kData);
  ASSERT_FALSE(dir.ok());
  EXPECT_NE(dir.status().message.find("is a directory, not a layout file"), std::string::npos);
}

}  // namespace
}  // namespace standcal::drivers::can
