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
}

}  // namespace
}  // namespace standcal
