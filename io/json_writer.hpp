// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Writing JSON: summary.json, bench.json, sweep.json (io/json_writer.cpp). Reading it is
// io/json_value.hpp.

#include <string>
#include <utility>
#include <vector>

namespace ehpt::io {

// Minimal ordered JSON object writer for summary.json (numbers exact, NaN as null).
class JsonObject {
 public:
  void number(const std::string& key, double value);
  void integer(const std::string& key, long long value);
  void text(const std::string& key, const std::string& value);
  void boolean(const std::string& key, bool value);
  void null(const std::string& key);
  void object(const std::string& key, const JsonObject& value);
  void strings(const std::string& key, const std::vector<std::string>& values);
  void objects(const std::string& key, const std::vector<JsonObject>& values);  // one line each
  std::string str(int indent = 0) const;
  std::string compact() const;  // on one line: {"a": 1, "b": "x"}

 private:
  std::vector<std::pair<std::string, std::string>> items_;  // key, raw JSON text
};

// A JSON string literal (with its quotes) of s: always valid JSON, whatever the bytes (a byte
// that is not part of well-formed UTF-8 becomes U+FFFD).
std::string json_escape(const std::string& s);

}  // namespace ehpt::io
