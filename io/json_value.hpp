// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Reading ehpt's own summary.json files back (written by io::JsonObject), so that thousands
// of run summaries can be merged into one CSV. Start-up / tool code: allocates freely.
//
// Numbers are kept as their source text, never as a double: a merge copies
// "0.5999999999999999" or "4.3e+07" bit for bit, with no round trip that could change them.
// Objects keep their keys in file order, so the merged columns come out as the runs wrote
// them. The reader is strict RFC 8259 (no trailing commas, comments, NaN, or invalid UTF-8),
// because a file that is not exactly what JsonObject writes is a sign of a damaged run.

#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace ehpt::io {

struct JsonMember;

struct JsonValue {
  enum class Kind { kNull, kBool, kNumber, kString, kArray, kObject };

  Kind kind = Kind::kNull;
  bool boolean = false;  // kBool
  std::string text;      // kNumber: the source text; kString: the decoded UTF-8
  std::vector<JsonValue> items;                            // kArray
  std::vector<JsonMember> members;  // kObject, in file order, keys unique

  // The member named key of an object, or nullptr (also for a non-object).
  const JsonValue* find(std::string_view key) const;
};

// A named struct rather than std::pair: a pair of the still-incomplete JsonValue inside
// JsonValue is rejected by clang with libstdc++ (its is_destructible check).
struct JsonMember {
  std::string key;
  JsonValue value;
};

// Nesting deeper than this is an error (not a stack overflow on a hostile file).
inline constexpr int kMaxJsonDepth = 64;

// Parses one JSON document (whitespace around it allowed). On failure returns false and sets
// error to "line L, column C: what" (1-based; the column counts bytes); out is then unspecified.
// Never throws: running out of memory is reported as an error too.
bool parse_json(std::string_view text, JsonValue& out, std::string& error);

// One line, no spaces; numbers as their text; strings escaped with \" \\ and \u00XX for
// control characters, other UTF-8 passed through unchanged.
std::string to_compact_json(const JsonValue& v);

// For a CSV row: the leaves of v as (key, text) pairs in file order. Nested objects give
// dotted keys ("energy_audit.fuel_chemical_J"); numbers give their text, booleans
// "true"/"false", null "", strings their value unquoted; arrays their compact JSON ("[]",
// "[\"a\",\"b\"]"). An empty object has no leaves, so it gives nothing; a v that is not an
// object gives one pair with an empty key. Appends to out.
void flatten(const JsonValue& v, std::vector<std::pair<std::string, std::string>>& out);

}  // namespace ehpt::io
