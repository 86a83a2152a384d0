// SPDX-License-Identifier: BSD-3-Clause
#include "io/json_value.hpp"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <utility>
#include <vector>

namespace ehpt::io {
namespace {

using Pairs = std::vector<std::pair<std::string, std::string>>;

// A trimmed summary.json as io::JsonObject writes it (out/psecu2_nedc/summary.json), with its
// odd indentation of objects nested two deep kept as it is.
constexpr const char* kSummary = R"({
  "status": "ok",
  "scenario": "psecu2_nedc",
  "description": "paper PSecu2 (library PSecu3) on NEDC",
  "solver": "rk4",
  "step_s": 0.001,
  "steps": 1400000,
  "soc_start": 0.5999999999999999,
  "energy_balance_residual_J": 1.4603137969970703e-06,
  "energy_balance_ok": true,
  "energy_audit": {
    "fuel_chemical_J": 15405698.685339684,
    "fuel_lhv_J_kg": 4.3e+07,
    "battery_stored_out_J": -39024.42040300369,
    "brake_dissipation_J": 0
  },
  "warnings": [],
  "bus": {
    "transport": "socketcand:127.0.0.1:48645",
    "rejected": {
    "unknown_id": 0,
    "stale": 0
  },
    "round_trip_us": {
    "p50": 45,
    "max": 8190.751
  }
  }
})";

// The text without the whitespace between tokens: what to_compact_json should give back.
std::string without_layout(const std::string& json) {
  std::string out;
  bool in_string = false;
  for (std::size_t i = 0; i < json.size(); ++i) {
    const char c = json[i];
    if (in_string && c == '\\') {
      out += c;
      out += json[++i];
      continue;
    }
    if (c == '"') in_string = !in_string;
    if (in_string || (c != ' ' && c != '\n' && c != '\t' && c != '\r')) out += c;
  }
  return out;
}

std::string parse_error(const std::string& text) {
  JsonValue v;
  std::string error;
  EXPECT_FALSE(parse_json(text, v, error)) << text;
  return error;
}

TEST(JsonValue, SummaryRoundTripsExactly) {
  JsonValue v;
  std::string error;
  ASSERT_TRUE(parse_json(kSummary, v, error)) << error;
  ASSERT_EQ(v.kind, JsonValue::Kind::kObject);
  EXPECT_EQ(v.members.front().key, "status");
  EXPECT_EQ(v.members.back().key, "bus");  // file order, not sorted
  ASSERT_NE(v.find("energy_audit"), nullptr);
  EXPECT_EQ(v.find("energy_audit")->find("fuel_lhv_J_kg")->text, "4.3e+07");
  EXPECT_EQ(v.find("energy_balance_ok")->kind, JsonValue::Kind::kBool);
  EXPECT_EQ(v.find("nope"), nullptr);
  EXPECT_EQ(to_compact_json(v), without_layout(kSummary));
}

TEST(JsonValue, NumbersKeepTheirSourceText) {
  const std::string text = "[4.3e+07,0.5999999999999999,-0,1e-300,1E5,-0.0e-0,123456789012345678901234567890,2.5E+308]";
  JsonValue v;
  std::string error;
  ASSERT_TRUE(parse_json(text, v, error)) << error;
  ASSERT_EQ(v.items.size(), 8u);
  EXPECT_EQ(v.items[2].text, "-0");
  EXPECT_EQ(v.items[7].text, "2.5E+308");  // out of double range: still just text
  EXPECT_EQ(to_compact_json(v), text);
}

TEST(JsonValue, StringsDecodeEscapesAndReescape) {
  JsonValue v;
  std::string error;
  ASSERT_TRUE(parse_json(R"(["a\"b\\c\/d\b\f\n\r\t", "\u00e9\u20AC\ud83d\ude00", "é€", "\u0001\u001f"])", v, error)) << error;
  EXPECT_EQ(v.items[0].text, "a\"b\\c/d\b\f\n\r\t");
  EXPECT_EQ(v.items[1].text, "\xC3\xA9\xE2\x82\xAC\xF0\x9F\x98\x80");  // a surrogate pair is one code point
  EXPECT_EQ(v.items[2].text, "\xC3\xA9\xE2\x82\xAC");
  EXPECT_EQ(to_compact_json(v),
            R"(["a\"b\\c/d\u0008\u000c\u000a\u000d\u0009","é€😀","é€","\u0001\u001f"])");
}

TEST(JsonValue, FlattenGivesDottedKeysAndTextValues) {
  JsonValue v;
  std::string error;
  ASSERT_TRUE(parse_json(R"({"a": 1.50, "s": "x,y", "n": null, "t": true, "f": false,
      "o": {"p": {"q": -0}, "empty": {}, "w": ["a", "b"]}, "warnings": [], "mixed": [1, {"k": null}]})",
                         v, error))
      << error;
  Pairs flat;
  flatten(v, flat);
  const Pairs expected = {{"a", "1.50"},  {"s", "x,y"},  {"n", ""},
                          {"t", "true"},  {"f", "false"}, {"o.p.q", "-0"},
                          {"o.w", R"(["a","b"])"}, {"warnings", "[]"}, {"mixed", R"([1,{"k":null}])"}};
  EXPECT_EQ(flat, expected);

  Pairs summary;
  ASSERT_TRUE(parse_json(kSummary, v, error)) << error;
  flatten(v, summary);
  EXPECT_EQ(summary[10], (std::pair<std::string, std::string>{"energy_audit.fuel_lhv_J_kg", "4.3e+07"}));
  EXPECT_EQ(summary.back(), (std::pair<std::string, std::string>{"bus.round_trip_us.max", "8190.751"}));

  Pairs scalar;
  ASSERT_TRUE(parse_json(" \"top\" ", v, error));
  flatten(v, scalar);
  EXPECT_EQ(scalar, (Pairs{{"", "top"}}));
}

TEST(JsonValue, ErrorsNameLineAndColumn) {
  EXPECT_EQ(parse_error("{\"a\": 1,\n \"b\": [1, 2,]}"), "line 2, column 13: a trailing comma");
  EXPECT_EQ(parse_error("{\"a\": 1,\n}"), "line 2, column 1: a trailing comma");
  EXPECT_EQ(parse_error("{\"a\": \"abc"), "line 1, column 7: a string is not closed");
  EXPECT_EQ(parse_error("[\"a\\x\"]"), "line 1, column 4: an unknown escape in a string");
  EXPECT_EQ(parse_error("[\"\\u12G4\"]"), "line 1, column 5: \\u needs four hex digits");
  EXPECT_EQ(parse_error("{\n  \"a\": 1,\n  \"b\": 2,\n  \"a\": 3\n}"), "line 4, column 3: a duplicate key");
  // the first repeat in file order, not the first in key order
  EXPECT_EQ(parse_error("{\"b\": 1, \"a\": 2, \"a\": 3, \"b\": 4}"), "line 1, column 18: a duplicate key");
  EXPECT_EQ(parse_error("{\"\\u0061\": 1, \"a\": 2}"), "line 1, column 15: a duplicate key");  // decoded keys compared
  EXPECT_EQ(parse_error("{\"a\": 1} x"), "line 1, column 10: unexpected text after the value");
  EXPECT_EQ(parse_error("[1] [2]"), "line 1, column 5: unexpected text after the value");
  EXPECT_EQ(parse_error("[\"\\ud800\"]"), "line 1, column 3: a lone high surrogate");
  EXPECT_EQ(parse_error("[\"\\ud800\\u0041\"]"), "line 1, column 3: a lone high surrogate");
  EXPECT_EQ(parse_error("[\"x\\udc00\"]"), "line 1, column 4: a lone low surrogate");
  EXPECT_EQ(parse_error("[\"tab\there\"]"), "line 1, column 6: a control character in a string (escape it)");
  EXPECT_EQ(parse_error("[\"\xC3\"]"), "line 1, column 3: invalid UTF-8 in a string");
  EXPECT_EQ(parse_error("[\"\xED\xA0\x80\"]"), "line 1, column 3: invalid UTF-8 in a string");  // a surrogate
  EXPECT_EQ(parse_error("[\"\xC0\xAF\"]"), "line 1, column 3: invalid UTF-8 in a string");      // overlong '/'
  EXPECT_EQ(parse_error(""), "line 1, column 1: a value is missing");
  EXPECT_EQ(parse_error("  \n "), "line 2, column 2: a value is missing");
  EXPECT_EQ(parse_error("[NaN]"), "line 1, column 2: not a JSON value");
  EXPECT_EQ(parse_error("[tru]"), "line 1, column 2: not a JSON value");
  EXPECT_EQ(parse_error("[1] // note"), "line 1, column 5: unexpected text after the value");
  EXPECT_EQ(parse_error("[01]"), "line 1, column 3: a number has a leading zero");
  EXPECT_EQ(parse_error("[1.]"), "line 1, column 4: a digit is missing in a number");
  EXPECT_EQ(parse_error("[-]"), "line 1, column 3: a digit is missing in a number");
  EXPECT_EQ(parse_error("[+1]"), "line 1, column 2: not a JSON value");
  EXPECT_EQ(parse_error("{1: 2}"), "line 1, column 2: a key (a string) expected");
  EXPECT_EQ(parse_error("{\"a\" 2}"), "line 1, column 6: ':' expected");
  EXPECT_EQ(parse_error("[1 2]"), "line 1, column 4: ',' or ']' expected");
  EXPECT_EQ(parse_error("[1,"), "line 1, column 4: a value is missing");
  EXPECT_EQ(parse_error("{\"a\": [1}"), "line 1, column 9: ',' or ']' expected");
}

TEST(JsonValue, DepthIsLimitedTo64) {
  JsonValue v;
  std::string error;
  const std::string ok = std::string(64, '[') + std::string(64, ']');
  EXPECT_TRUE(parse_json(ok, v, error)) << error;
  EXPECT_EQ(to_compact_json(v), ok);
  EXPECT_EQ(parse_error(std::string(65, '[') + std::string(65, ']')), "line 1, column 65: nested deeper than 64 levels");
  std::string objects;
  for (int i = 0; i < 65; ++i) objects += "{\"k\":";
  EXPECT_EQ(parse_error(objects + "1" + std::string(65, '}')), "line 1, column 321: nested deeper than 64 levels");
  // far deeper than any stack allows without the limit
  EXPECT_EQ(parse_error(std::string(1000000, '[')), "line 1, column 65: nested deeper than 64 levels");
}

// Mutations of a valid document: parse_json must return (no crash, no hang, no exception)
// and whatever it accepts must round-trip through to_compact_json. Run under ASan/UBSan
// to make this a real fuzz check.
TEST(JsonValue, MutatedDocumentsNeverCrash) {
  const std::string base = kSummary;
  const std::string interesting = "{}[]\",:\\u0123456789eE+-.tfn \n\t\x01\x7f\xC3\xA9\xED\xF4\x80\xBF\xFF";
  std::mt19937 rng(20240611);
  const auto pick = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  int accepted = 0;
  for (int round = 0; round < 20000; ++round) {
    std::string text = base;
    const int edits = 1 + static_cast<int>(pick(4));
    for (int e = 0; e < edits && !text.empty(); ++e) {
      const std::size_t at = pick(text.size());
      switch (pick(5)) {
        case 0: text[at] = interesting[pick(interesting.size())]; break;
        case 1: text.insert(at, 1, interesting[pick(interesting.size())]); break;
        case 2: text.erase(at, 1 + pick(8)); break;
        case 3: text.insert(at, text.substr(pick(text.size()), pick(40))); break;  // a copied span
        default: text[at] = static_cast<char>(pick(256)); break;
      }
    }
    JsonValue v;
    std::string error;
    if (!parse_json(text, v, error)) {
      ASSERT_EQ(error.rfind("line ", 0), 0u) << error;
      continue;
    }
    ++accepted;
    const std::string compact = to_compact_json(v);
    JsonValue again;
    ASSERT_TRUE(parse_json(compact, again, error)) << error << "\n" << compact;
    ASSERT_EQ(to_compact_json(again), compact);
    Pairs flat;
    flatten(v, flat);
  }
  EXPECT_GT(accepted, 100);  // the mutations do reach the accepting paths too
}

}  // namespace
}  // namespace ehpt::io
