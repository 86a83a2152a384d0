// SPDX-License-Identifier: BSD-3-Clause
// Writing JSON (json_writer.hpp); reading it is io/json_value.hpp.
#include "io/json_writer.hpp"

#include <cmath>
#include <cstdio>

#include "io/number_format.hpp"

namespace ehpt::io {

namespace {

// The length of the well-formed UTF-8 sequence at s[i] (RFC 3629: no overlong forms, no
// surrogates, nothing above U+10FFFF), or 0.
std::size_t utf8_length(const std::string& s, std::size_t i) {
  const auto at = [&](std::size_t k) { return i + k < s.size() ? static_cast<unsigned char>(s[i + k]) : 0u; };
  const auto cont = [&](std::size_t k, unsigned lo = 0x80, unsigned hi = 0xBF) { return at(k) >= lo && at(k) <= hi; };
  const unsigned c = at(0);
  if (c < 0x80) return 1;
  if (c >= 0xC2 && c <= 0xDF) return cont(1) ? 2 : 0;
  if (c == 0xE0) return cont(1, 0xA0) && cont(2) ? 3 : 0;
  if (c == 0xED) return cont(1, 0x80, 0x9F) && cont(2) ? 3 : 0;
  if (c >= 0xE1 && c <= 0xEF) return cont(1) && cont(2) ? 3 : 0;
  if (c == 0xF0) return cont(1, 0x90) && cont(2) && cont(3) ? 4 : 0;
  if (c >= 0xF1 && c <= 0xF3) return cont(1) && cont(2) && cont(3) ? 4 : 0;
  if (c == 0xF4) return cont(1, 0x80, 0x8F) && cont(2) && cont(3) ? 4 : 0;
  return 0;
}

}  // namespace

// A JSON string: always valid JSON, whatever the bytes. A byte that is not part of
// well-formed UTF-8 (a file name in Latin-1) becomes U+FFFD: JSON text must be Unicode, and
// a reader (ours is strict) would refuse the whole document.
std::string json_escape(const std::string& s) {
  std::string out = "\"";
  for (std::size_t i = 0; i < s.size();) {
    const char c = s[i];
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else if (const std::size_t n = utf8_length(s, i); n == 0) {
          out += "\\ufffd";
        } else {
          out.append(s, i, n);
          i += n;
          continue;
        }
    }
    ++i;
  }
  return out + "\"";
}

void JsonObject::number(const std::string& key, double value) {
  items_.emplace_back(key, std::isfinite(value) ? number_text(value) : "null");
}
void JsonObject::integer(const std::string& key, long long value) { items_.emplace_back(key, std::to_string(value)); }
void JsonObject::text(const std::string& key, const std::string& value) { items_.emplace_back(key, json_escape(value)); }
void JsonObject::boolean(const std::string& key, bool value) { items_.emplace_back(key, value ? "true" : "false"); }
void JsonObject::null(const std::string& key) { items_.emplace_back(key, "null"); }
void JsonObject::object(const std::string& key, const JsonObject& value) { items_.emplace_back(key, value.str(2)); }
void JsonObject::strings(const std::string& key, const std::vector<std::string>& values) {
  std::string raw = "[";
  for (std::size_t i = 0; i < values.size(); ++i) raw += (i ? ", " : "") + json_escape(values[i]);
  items_.emplace_back(key, raw + "]");
}

void JsonObject::objects(const std::string& key, const std::vector<JsonObject>& values) {
  std::string raw = "[";
  for (std::size_t i = 0; i < values.size(); ++i) raw += (i ? ",\n      " : "\n      ") + values[i].compact();
  items_.emplace_back(key, raw + (values.empty() ? "]" : "\n    ]"));
}

std::string JsonObject::compact() const {
  std::string out = "{";
  for (std::size_t i = 0; i < items_.size(); ++i) out += (i ? ", " : "") + json_escape(items_[i].first) + ": " + items_[i].second;
  return out + "}";
}

std::string JsonObject::str(int indent) const {
  const std::string pad(static_cast<std::size_t>(indent) + 2, ' ');
  std::string out = "{\n";
  for (std::size_t i = 0; i < items_.size(); ++i) {
    out += pad + json_escape(items_[i].first) + ": " + items_[i].second;
    out += i + 1 < items_.size() ? ",\n" : "\n";
  }
  return out + std::string(static_cast<std::size_t>(indent), ' ') + "}";
}

}  // namespace ehpt::io
