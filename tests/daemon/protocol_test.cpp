// The protocol library on its own: request validation, framing, typed parameters.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "protocol/jsonrpc/jsonrpc.hpp"
#include "protocol/jsonrpc/line_buffer.hpp"
#include "protocol/jsonrpc/text.hpp"
#include "tests/support/utf8_cases.hpp"

using namespace standcal::protocol;
using nlohmann::json;

namespace {

int error_code_of(std::string_view line) {
  auto r = parse_request(line);
  auto* bad = std::get_if<BadRequest>(&r);
  return bad ? bad->error.code() : 0;
}

}  // namespace

TEST(JsonRpc, ParsesARequestWithNamedParams) {
  auto r =
      parse_request(R"({"jsonrpc":"2.0","id":7,"method":"stand.move","params":{"alpha1_deg":90}})");
  ASSERT_TRUE(std::holds_alternative<Request>(r));
  const Request& req = std::get<Request>(r);
  EXPECT_EQ(req.id, 7);
  EXPECT_FALSE(req.is_notification);
  EXPECT_EQ(req.method, "stand.move");
  EXPECT_EQ(req.params["alpha1_deg"], 90);
}

TEST(JsonRpc, ANotificationHasNoId) {
  auto r = parse_request(R"({"jsonrpc":"2.0","method":"status"})");
  ASSERT_TRUE(std::holds_alternative<Request>(r));
  EXPECT_TRUE(std::get<Request>(r).is_notification);
}

TEST(JsonRpc, RejectsBadRequestsWithTheStandardCodes) {
  EXPECT_EQ(error_code_of("{not json"), -32700);
  EXPECT_EQ(error_code_of("[1,2]"), -32600);
  EXPECT_EQ(error_code_of(R"({"id":1,"method":"status"})"), -32600);  // no jsonrpc
  EXPECT_EQ(error_code_of(R"({"jsonrpc":"1.0","id":1,"method":"status"})"), -32600);
  EXPECT_EQ(error_code_of(R"({"jsonrpc":"2.0","id":1,"method":5})"), -32600);
  EXPECT_EQ(error_code_of(R"({"jsonrpc":"2.0","id":{"a":1},"method":"status"})"), -32600);
  // Positional params make a valid request (or notification) that no method takes: the
  // server answers it -32602, unless it is a notification.
  auto positional = parse_request(R"({"jsonrpc":"2.0","id":1,"method":"status","params":[1]})");
  ASSERT_TRUE(std::holds_alternative<Request>(positional));
  EXPECT_TRUE(std::get<Request>(positional).positional_params);
}

TEST(JsonRpc, FollowsTheSpecificationsIdRules) {
  // id null: a request (discouraged by the specification, but not a notification).
  auto r = parse_request(R"({"jsonrpc":"2.0","id":null,"method":"status"})");
  ASSERT_TRUE(std::holds_alternative<Request>(r));
  EXPECT_FALSE(std::get<Request>(r).is_notification);
  EXPECT_TRUE(std::get<Request>(r).id.is_null());
  // Any number is an id (fractions are discouraged, not forbidden).
  r = parse_request(R"({"jsonrpc":"2.0","id":1.5,"method":"status"})");
  ASSERT_TRUE(std::holds_alternative<Request>(r));
  EXPECT_EQ(std::get<Request>(r).id, 1.5);
  // params, when present, is a structured value: anything else is not a request object.
  EXPECT_EQ(error_code_of(R"({"jsonrpc":"2.0","id":1,"method":"status","params":5})"), -32600);
  EXPECT_EQ(error_code_of(R"({"jsonrpc":"2.0","id":1,"method":"status","params":"x"})"), -32600);
}

TEST(JsonRpc, ABatchIsRefusedAsOneInvalidRequestNamingBatches) {
  for (const char* line : {"[]", R"([{"jsonrpc":"2.0","id":1,"method":"status"}])"}) {
    auto r = parse_request(line);
    ASSERT_TRUE(std::holds_alternative<BadRequest>(r)) << line;
    const BadRequest& bad = std::get<BadRequest>(r);
    EXPECT_EQ(bad.error.code(), -32600) << line;
    EXPECT_TRUE(bad.id.is_null()) << line;
    EXPECT_NE(std::string(bad.error.what()).find("batch"), std::string::npos) << bad.error.what();
  }
}

TEST(JsonRpc, TheIdIsEchoedInErrorsWhenItCouldBeRead) {
  auto r = parse_request(R"({"jsonrpc":"1.0","id":"abc","method":"status"})");
  ASSERT_TRUE(std::holds_alternative<BadRequest>(r));
  EXPECT_EQ(std::get<BadRequest>(r).id, "abc");
  const json err = json::parse(make_error("abc", -32600, "bad"));
  EXPECT_EQ(err["id"], "abc");
  EXPECT_EQ(err["error"]["code"], -32600);
  EXPECT_EQ(err["jsonrpc"], "2.0");
}

TEST(JsonRpc, ParamsNameTheWrongParameter) {
  const json p{{"alpha1_deg", "ninety"}, {"wait", 1}};
  Params params(p, "stand.move");
  try {
    params.number("alpha1_deg");
    FAIL() << "accepted a string as a number";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), -32602);
    EXPECT_NE(std::string(e.what()).find("alpha1_deg"), std::string::npos);
  }
  EXPECT_THROW(params.optional_bool("wait", true), RpcError);
  EXPECT_THROW(params.number("alpha2_deg"), RpcError);  // missing
  EXPECT_THROW(params.only({"alpha1_deg"}), RpcError);  // "wait" not allowed
  EXPECT_NO_THROW(params.only({"alpha1_deg", "wait"}));
}

TEST(JsonRpc, AnIntegerParameterMustBeWholeAndInRange) {
  const json p{{"a", 7}, {"b", 7.0}, {"c", 7.5}, {"d", 0}, {"e", "7"}};
  Params params(p, "runs.list");
  EXPECT_EQ(params.optional_integer("a", 1, 10), 7);
  EXPECT_EQ(params.optional_integer("b", 1, 10), 7);
  EXPECT_FALSE(params.optional_integer("missing", 1, 10).has_value());
  for (const char* key : {"c", "d", "e"}) {
    try {
      params.optional_integer(key, 1, 10);
      ADD_FAILURE() << key << " accepted";
    } catch (const RpcError& e) {
      EXPECT_EQ(e.code(), -32602);
      EXPECT_NE(std::string(e.what()).find(std::string("\"") + key +
                                           "\" must be a whole number from 1 to 10"),
                std::string::npos)
          << e.what();
    }
  }
}

// A unit serial given on the command line in Latin-1 made `standcal run start` print only
// nlohmann's "type_error.316 invalid UTF-8 byte" (a review, 2026-12-05): the request is
// refused naming the parameter, not sent with the byte replaced (a changed serial).
TEST(JsonRpc, ARequestParameterThatIsNotUtf8IsRefusedByName) {
  try {
    (void)make_request(1, "run.start", {{"program", "paper9"}, {"unit_serial", "SN\xd6"}});
    ADD_FAILURE() << "a Latin-1 serial was sent";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "run.start: parameter \"unit_serial\" must be UTF-8 text: byte 3 is not");
  }
  EXPECT_NE(make_request(1, "run.start", {{"unit_serial", "SN-\u00d6"}}).find("SN-\u00d6"),
            std::string::npos);
  // Inside a parameter too: it printed only "type_error.316".
  const json positions = json::array({{{"alpha1_deg", 0}}, {{"alpha1_deg", 90}, {"name", "\xd6"}}});
  try {
    (void)make_request(1, "run.start", {{"program", positions}});
    ADD_FAILURE() << "a Latin-1 position name was sent";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "run.start: parameter \"program/1/name\" must be UTF-8 text: byte 1 is not");
  }
  try {
    (void)make_request(1, "run.start", {{"options", {{"k\xd6", 1}}}});
    ADD_FAILURE() << "a Latin-1 key was sent";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "run.start: a key of parameter \"options\" must be UTF-8 text: byte 2 is not");
  }
  try {
    (void)make_request(1, "run.start", {{"unit_\xd6", "SN-1"}});
    ADD_FAILURE() << "a Latin-1 parameter name was sent";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "run.start: a parameter's name must be UTF-8 text: byte 6 is not");
  }
}

// The protocol's own decoder (this room depends on nlohmann-json alone) agrees with the file
// formats' on every boundary of the standard's table (tests/calib/text_test.cpp).
TEST(JsonRpc, TheProtocolsUtf8DecoderFollowsTheStandardsTable) {
  for (const standcal::test::Utf8Case& c : standcal::test::utf8_cases())
    EXPECT_EQ(first_non_utf8_byte(c.bytes), c.first_bad_byte) << c.what;
}

TEST(LineBuffer, JoinsPiecesIntoLines) {
  LineBuffer b(100);
  b.append("{\"a\":");
  EXPECT_FALSE(b.next_line());
  b.append("1}\r\n{\"b\":2}\n{\"c\"");
  EXPECT_EQ(b.next_line().value(), "{\"a\":1}");
  EXPECT_EQ(b.next_line().value(), "{\"b\":2}");
  EXPECT_FALSE(b.next_line());
  EXPECT_EQ(b.pending_bytes(), 4u);
}

TEST(LineBuffer, ReportsALineLongerThanTheLimit) {
  LineBuffer b(10);
  b.append("0123456789");
  EXPECT_FALSE(b.overflowed());
  b.append("X");
  EXPECT_TRUE(b.overflowed());
}

TEST(TextFields, PrintableOneLineTextIsCountedInCharacters) {
  EXPECT_FALSE(text_field_problem("AU-0042", 64));
  EXPECT_FALSE(text_field_problem("", 64));
  EXPECT_FALSE(text_field_problem("Prüfstand 3 \xE2\x80\x94 Müller", 64));  // ü, em dash
  std::string e64;
  for (int i = 0; i < 64; ++i) e64 += "\xC3\xA9";  // é: 64 characters, 128 bytes
  EXPECT_FALSE(text_field_problem(e64, 64));
  EXPECT_EQ(text_field_problem(e64 + "x", 64),
            "be at most 64 characters (UTF-8 code points), not 65");
}

TEST(TextFields, ControlCharactersSeparatorsAndBrokenUtf8AreNamed) {
  EXPECT_EQ(
      text_field_problem("AU\n# mount: y", 64),
      "be printable text on one line: it contains the control character U+000A at character 3");
  EXPECT_EQ(
      text_field_problem(std::string("AU\0", 3), 64),
      "be printable text on one line: it contains the control character U+0000 at character 3");
  EXPECT_EQ(
      text_field_problem("\xC3\xA9\t", 64),
      "be printable text on one line: it contains the control character U+0009 at character 2");
  EXPECT_EQ(
      text_field_problem("a\x7F", 64),
      "be printable text on one line: it contains the control character U+007F at character 2");
  EXPECT_EQ(
      text_field_problem("a\xC2\x85", 64),
      "be printable text on one line: it contains the control character U+0085 at character 2");
  EXPECT_EQ(text_field_problem("a\xE2\x80\xA8", 64),
            "be printable text on one line: it contains the line separator U+2028 at character 2");
  EXPECT_EQ(text_field_problem("AU-\xC3", 64), "be UTF-8 text: byte 4 is not");   // cut short
  EXPECT_EQ(text_field_problem("\xC0\xAF", 64), "be UTF-8 text: byte 1 is not");  // overlong '/'
  EXPECT_EQ(text_field_problem("\xED\xA0\x80", 64), "be UTF-8 text: byte 1 is not");  // a surrogate
  try {
    require_text_field("run.start: parameter \"unit_type\"", "QA\r7", 64);
    FAIL() << "a carriage return was accepted";
  } catch (const RpcError& e) {
    EXPECT_EQ(e.code(), -32602);
    EXPECT_EQ(std::string(e.what()),
              "run.start: parameter \"unit_type\" must be printable text on one line: it contains "
              "the control "
              "character U+000D at character 3");
  }
}
