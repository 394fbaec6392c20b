// calib/text.hpp: the one-line text fields of the file formats.
#include "calib/text.hpp"

#include <gtest/gtest.h>

#include "tests/support/utf8_cases.hpp"

namespace standcal {
namespace {

// Every boundary of the standard's table: the lowest and highest character of each length
// and beside the surrogates accepted; overlong forms, surrogates, bytes past U+10FFFF, bad
// continuation bytes and cut-short characters refused at their first byte.
TEST(Utf8, TheFileFormatsDecoderFollowsTheStandardsTable) {
  for (const test::Utf8Case& c : test::utf8_cases())
    EXPECT_EQ(first_non_utf8_byte(c.bytes), c.first_bad_byte) << c.what;
}

TEST(RoundTripText, WritesTheShortestTextThatReadsBackExactly) {
  for (const double v : {100.0, 0.5, 1e-7, 9.8162538712345, 0.1 + 0.2, -273.15, 1e300}) {
    const std::string text = round_trip_text(v);
    EXPECT_EQ(std::stod(text), v) << text;
  }
  EXPECT_EQ(round_trip_text(100.0), "100");
  EXPECT_EQ(round_trip_text(1e-7), "1e-07");
  EXPECT_EQ(plain_round_trip_text(100000), "100000");  // round_trip_text: 1e+05
  EXPECT_EQ(plain_round_trip_text(0.0005), "0.0005");  // 5e-04
  EXPECT_EQ(plain_round_trip_text(3600.0000001), "3600.0000001");
  EXPECT_EQ(plain_round_trip_text(1e-7), "1e-07");
  EXPECT_EQ(plain_round_trip_text(9e15), "9e+15");
  for (const double v : {0.1 + 0.2, 123456789012345.6, -0.00012345678901234567})
    EXPECT_EQ(std::stod(plain_round_trip_text(v)), v);
}

// The axes a finding flags, as the reports' sentences name them (a static recording's axes at
// their bound, a run's axes at the given wander's size).
TEST(AxisNames, TheFlaggedAxesReadAsASentence) {
  EXPECT_EQ(axis_names({false, false, false}), "");
  EXPECT_EQ(axis_names({false, true, false}), "y");
  EXPECT_EQ(axis_names({true, false, true}), "x and z");
  EXPECT_EQ(axis_names({true, true, true}), "x, y and z");
  EXPECT_EQ(axis_names({false, true, false, true}), "y");  // three axes only
}

// A value found past its limit never reads as equal to it (standcald said "noise 5000 µg
// above the limit 5000 µg" of 5000.004 µg).
TEST(NumberTextsApart, AValuePastItsLimitReadsAsPastIt) {
  const auto texts = [](double v, double limit) {
    const NumberTextsApart t = number_texts_apart(v, limit);
    return t.value + " " + t.limit;
  };
  EXPECT_EQ(texts(6003.002252, 5000), "6003 5000");  // six digits when they tell them apart
  EXPECT_EQ(texts(5000.004, 5000), "5000.004 5000");
  EXPECT_EQ(texts(-5000.004, 5000), "-5000.004 5000");            // a trend past the limit in size
  EXPECT_EQ(texts(1234.5679, 1234.5678), "1234.5679 1234.5678");  // both with more digits
  EXPECT_EQ(texts(3.0000000000000004, 3), "3.0000000000000004 3");
  EXPECT_EQ(texts(3, 3), "3 3");
  EXPECT_EQ(texts(0.1, 0.1), "0.1 0.1");  // equal: not its binary fraction's 17 digits
  const auto fixed = [](double v, double limit) {
    const NumberTextsApart t = fixed_texts_apart(v, limit, 2);
    return t.value + " " + t.limit;
  };
  EXPECT_EQ(fixed(1.5, 1), "1.50 1.00");
  EXPECT_EQ(fixed(1.004, 1), "1.004 1.000");
  EXPECT_EQ(fixed(0.004, 0), "0.004 0.000");  // a margin past zero
  EXPECT_EQ(fixed(2, 2), "2.00 2.00");
}

}  // namespace
}  // namespace standcal
