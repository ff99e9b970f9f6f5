// The small JSON reader: every value kind, escapes, round-trip numbers, and the errors with their
// line and column.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <string>

#include <diachron/io/json.hpp>

using namespace diachron;
using Catch::Matchers::Contains;

TEST_CASE("parse_json: every kind of value", "[io]") {
  const JsonValue v = parse_json(
      " {\"a\": [1, -2.5e3, 0], \"b\": {\"c\": true, \"d\": false, \"e\": null}, \"s\": \"x\\\"\\\\\\n\\u00e9\\ud83d\\ude00\"} ",
      "text");
  REQUIRE(v.type == JsonValue::Type::object);
  const JsonValue* a = v.find("a");
  REQUIRE(a);
  REQUIRE(a->array.size() == 3);
  CHECK(a->array[1].number == -2500.0);
  CHECK(v.find("b")->find("c")->boolean);
  CHECK(v.find("b")->find("d")->type == JsonValue::Type::boolean);
  CHECK(v.find("b")->find("e")->type == JsonValue::Type::null);
  CHECK(v.find("s")->string == "x\"\\\n\xc3\xa9\xf0\x9f\x98\x80");
  CHECK(v.find("missing") == nullptr);
  CHECK(parse_json("[]", "t").array.empty());
  CHECK(parse_json("{}", "t").object.empty());
}

TEST_CASE("json_number and json_quoted read back exactly", "[io]") {
  for (double x : {0.1, -1.0 / 3.0, 6.02214076e23, 5e-324, 1.7976931348623157e308, -0.0}) {
    const JsonValue v = parse_json(json_number(x), "n");
    CHECK(v.number == x);
  }
  CHECK_THROWS_AS(json_number(std::numeric_limits<double>::quiet_NaN()), Error);
  const std::string s = "a\"b\\c\td\x01";
  CHECK(parse_json(json_quoted(s), "q").string == s);
}

TEST_CASE("parse_json: errors name the place", "[io]") {
  CHECK_THROWS_WITH(parse_json("{\"a\": 1,\n \"b\" 2}", "f.json"), Contains("f.json: line 2, column 6"));
  CHECK_THROWS_WITH(parse_json("[1, 2", "t"), Contains("',' or ']'"));
  CHECK_THROWS_WITH(parse_json("{\"a\": 1, \"a\": 2}", "t"), Contains("appears twice"));
  CHECK_THROWS_WITH(parse_json("[01]", "t"), Contains("',' or ']'"));
  CHECK_THROWS_AS(parse_json("NaN", "t"), Error);
  CHECK_THROWS_AS(parse_json("[1.]", "t"), Error);
  CHECK_THROWS_AS(parse_json("\"abc", "t"), Error);
  CHECK_THROWS_AS(parse_json("\"a\\qb\"", "t"), Error);
  CHECK_THROWS_WITH(parse_json("1 2", "t"), Contains("after the JSON value"));
  CHECK_THROWS_AS(parse_json("", "t"), Error);
  CHECK_THROWS_AS(parse_json(std::string(1000, '['), "t"), Error);
  // Overflow is kept as an infinity for the caller to reject by key; underflow is zero.
  CHECK(std::isinf(parse_json("1e999", "t").number));
  CHECK(parse_json("-1e999", "t").number < 0.0);
  CHECK(parse_json("1e-999", "t").number == 0.0);
}
