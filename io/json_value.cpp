// SPDX-License-Identifier: BSD-3-Clause
#include "io/json_value.hpp"

#include <algorithm>
#include <cstdint>
#include <new>
#include <numeric>

namespace ehpt::io {
namespace {

// Length of the valid UTF-8 sequence at s[pos] (1..4), or 0 if it is not one: RFC 3629
// table, so overlong forms, UTF-16 surrogates and code points above U+10FFFF are refused.
std::size_t utf8_length(std::string_view s, std::size_t pos) {
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(s[pos + i]); };
  const unsigned char b0 = byte(0);
  if (b0 < 0x80) return 1;
  std::size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
  if (b0 >= 0xC2 && b0 <= 0xDF) n = 2;
  else if (b0 == 0xE0) n = 3, lo = 0xA0;
  else if (b0 >= 0xE1 && b0 <= 0xEC) n = 3;
  else if (b0 == 0xED) n = 3, hi = 0x9F;
  else if (b0 >= 0xEE && b0 <= 0xEF) n = 3;
  else if (b0 == 0xF0) n = 4, lo = 0x90;
  else if (b0 >= 0xF1 && b0 <= 0xF3) n = 4;
  else if (b0 == 0xF4) n = 4, hi = 0x8F;
  else return 0;
  if (s.size() - pos < n) return 0;
  if (byte(1) < lo || byte(1) > hi) return 0;
  for (std::size_t i = 2; i < n; ++i) {
    if (byte(i) < 0x80 || byte(i) > 0xBF) return 0;
  }
  return n;
}

void append_utf8(std::string& out, std::uint32_t cp) {
  if (cp < 0x80) {
    out += static_cast<char>(cp);
  } else if (cp < 0x800) {
    out += static_cast<char>(0xC0 | (cp >> 6));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else if (cp < 0x10000) {
    out += static_cast<char>(0xE0 | (cp >> 12));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (cp >> 18));
    out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (cp & 0x3F));
  }
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// Recursive descent over the text; depth is bounded by kMaxJsonDepth, so the recursion is too.
// Every failure records the offset and what was wrong; parse_json turns it into line/column.
class Parser {
 public:
  explicit Parser(std::string_view s) : s_(s) {}

  bool document(JsonValue& out) {
    skip_space();
    if (!value(out, 0)) return false;
    skip_space();
    if (pos_ != s_.size()) return fail(pos_, "unexpected text after the value");
    return true;
  }
  std::size_t error_at() const { return error_at_; }
  const std::string& what() const { return what_; }

 private:
  bool fail(std::size_t at, const char* what) {
    error_at_ = at;
    what_ = what;
    return false;
  }
  bool at_end() const { return pos_ >= s_.size(); }
  void skip_space() {
    while (!at_end() && (s_[pos_] == ' ' || s_[pos_] == '\t' || s_[pos_] == '\n' || s_[pos_] == '\r')) ++pos_;
  }
  bool literal(std::string_view word) {
    if (s_.substr(pos_, word.size()) != word) return fail(pos_, "not a JSON value");
    pos_ += word.size();
    return true;
  }

  bool value(JsonValue& out, int depth) {
    if (at_end()) return fail(pos_, "a value is missing");
    const char c = s_[pos_];
    if (c == '{' || c == '[') {
      if (depth >= kMaxJsonDepth) return fail(pos_, "nested deeper than 64 levels");
      return c == '{' ? object(out, depth + 1) : array(out, depth + 1);
    }
    if (c == '"') {
      out.kind = JsonValue::Kind::kString;
      return string(out.text);
    }
    if (c == '-' || is_digit(c)) return number(out);
    if (c == 't' || c == 'f') {
      out.kind = JsonValue::Kind::kBool;
      out.boolean = c == 't';
      return literal(c == 't' ? "true" : "false");
    }
    if (c == 'n') {
      out.kind = JsonValue::Kind::kNull;
      return literal("null");
    }
    return fail(pos_, "not a JSON value");
  }

  // RFC 8259 section 6: -? (0 | [1-9][0-9]*) (. [0-9]+)? ([eE] [+-]? [0-9]+)?
  bool number(JsonValue& out) {
    const std::size_t start = pos_;
    if (s_[pos_] == '-') ++pos_;
    if (at_end() || !is_digit(s_[pos_])) return fail(pos_, "a digit is missing in a number");
    if (s_[pos_] == '0') {
      ++pos_;
      if (!at_end() && is_digit(s_[pos_])) return fail(pos_, "a number has a leading zero");
    } else {
      while (!at_end() && is_digit(s_[pos_])) ++pos_;
    }
    if (!at_end() && s_[pos_] == '.') {
      ++pos_;
      if (at_end() || !is_digit(s_[pos_])) return fail(pos_, "a digit is missing in a number");
      while (!at_end() && is_digit(s_[pos_])) ++pos_;
    }
    if (!at_end() && (s_[pos_] == 'e' || s_[pos_] == 'E')) {
      ++pos_;
      if (!at_end() && (s_[pos_] == '+' || s_[pos_] == '-')) ++pos_;
      if (at_end() || !is_digit(s_[pos_])) return fail(pos_, "a digit is missing in a number");
      while (!at_end() && is_digit(s_[pos_])) ++pos_;
    }
    out.kind = JsonValue::Kind::kNumber;
    out.text.assign(s_.substr(start, pos_ - start));
    return true;
  }

  bool hex4(std::uint32_t& v) {
    if (s_.size() - pos_ < 4) return fail(pos_, "\\u needs four hex digits");
    v = 0;
    for (int i = 0; i < 4; ++i) {
      const char c = s_[pos_ + i];
      const int d = is_digit(c) ? c - '0' : (c >= 'a' && c <= 'f') ? c - 'a' + 10 : (c >= 'A' && c <= 'F') ? c - 'A' + 10 : -1;
      if (d < 0) return fail(pos_, "\\u needs four hex digits");
      v = v * 16 + static_cast<std::uint32_t>(d);
    }
    pos_ += 4;
    return true;
  }

  // At the opening quote; decodes into out (UTF-8).
  bool string(std::string& out) {
    const std::size_t open = pos_++;
    out.clear();
    while (true) {
      if (at_end()) return fail(open, "a string is not closed");
      const char c = s_[pos_];
      if (c == '"') {
        ++pos_;
        return true;
      }
      if (static_cast<unsigned char>(c) < 0x20) return fail(pos_, "a control character in a string (escape it)");
      if (c != '\\') {
        const std::size_t n = utf8_length(s_, pos_);
        if (n == 0) return fail(pos_, "invalid UTF-8 in a string");
        out.append(s_.substr(pos_, n));
        pos_ += n;
        continue;
      }
      const std::size_t escape = pos_++;
      if (at_end()) return fail(open, "a string is not closed");
      switch (s_[pos_++]) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          std::uint32_t cp = 0;
          if (!hex4(cp)) return false;
          if (cp >= 0xDC00 && cp <= 0xDFFF) return fail(escape, "a lone low surrogate");
          if (cp >= 0xD800 && cp <= 0xDBFF) {  // UTF-16 pair: \uD8xx must be followed by \uDCxx
            std::uint32_t low = 0;
            if (s_.substr(pos_, 2) != "\\u") return fail(escape, "a lone high surrogate");
            pos_ += 2;
            if (!hex4(low)) return false;
            if (low < 0xDC00 || low > 0xDFFF) return fail(escape, "a lone high surrogate");
            cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
          }
          append_utf8(out, cp);
          break;
        }
        default:
          return fail(escape, "an unknown escape in a string");
      }
    }
  }

  bool array(JsonValue& out, int depth) {
    out.kind = JsonValue::Kind::kArray;
    ++pos_;
    skip_space();
    if (!at_end() && s_[pos_] == ']') {
      ++pos_;
      return true;
    }
    while (true) {
      out.items.emplace_back();
      if (!value(out.items.back(), depth)) return false;
      skip_space();
      if (at_end()) return fail(pos_, "an array is not closed");
      if (s_[pos_] == ']') {
        ++pos_;
        return true;
      }
      if (s_[pos_] != ',') return fail(pos_, "',' or ']' expected");
      ++pos_;
      skip_space();
      if (!at_end() && s_[pos_] == ']') return fail(pos_, "a trailing comma");
    }
  }

  bool object(JsonValue& out, int depth) {
    out.kind = JsonValue::Kind::kObject;
    ++pos_;
    skip_space();
    if (!at_end() && s_[pos_] == '}') {
      ++pos_;
      return true;
    }
    std::vector<std::size_t> key_at;  // offset of each key, for the duplicate message
    while (true) {
      if (at_end() || s_[pos_] != '"') return fail(pos_, "a key (a string) expected");
      key_at.push_back(pos_);
      out.members.emplace_back();
      if (!string(out.members.back().key)) return false;
      skip_space();
      if (at_end() || s_[pos_] != ':') return fail(pos_, "':' expected");
      ++pos_;
      skip_space();
      if (!value(out.members.back().value, depth)) return false;
      skip_space();
      if (at_end()) return fail(pos_, "an object is not closed");
      if (s_[pos_] == '}') {
        ++pos_;
        return unique_keys(out, key_at);
      }
      if (s_[pos_] != ',') return fail(pos_, "',' or '}' expected");
      ++pos_;
      skip_space();
      if (!at_end() && s_[pos_] == '}') return fail(pos_, "a trailing comma");
    }
  }

  // Sorting the key indices keeps this n log n, so a hostile object with a million keys
  // cannot make it quadratic. Reports the first repeat in file order.
  bool unique_keys(const JsonValue& obj, const std::vector<std::size_t>& key_at) {
    const auto& m = obj.members;
    std::vector<std::size_t> order(m.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return m[a].key < m[b].key; });
    std::size_t first_repeat = m.size();
    for (std::size_t i = 1; i < order.size(); ++i) {
      if (m[order[i]].key == m[order[i - 1]].key) first_repeat = std::min(first_repeat, order[i]);
    }
    if (first_repeat == m.size()) return true;
    return fail(key_at[first_repeat], "a duplicate key");
  }

  std::string_view s_;
  std::size_t pos_ = 0;
  std::size_t error_at_ = 0;
  std::string what_;
};

void append_escaped(std::string& out, const std::string& s) {
  static constexpr char kHex[] = "0123456789abcdef";
  out += '"';
  for (const char c : s) {
    const auto b = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (b < 0x20) {
      out += "\\u00";
      out += kHex[b >> 4];
      out += kHex[b & 0x0f];
    } else {
      out += c;
    }
  }
  out += '"';
}

void append_compact(std::string& out, const JsonValue& v) {
  switch (v.kind) {
    case JsonValue::Kind::kNull: out += "null"; break;
    case JsonValue::Kind::kBool: out += v.boolean ? "true" : "false"; break;
    case JsonValue::Kind::kNumber: out += v.text; break;
    case JsonValue::Kind::kString: append_escaped(out, v.text); break;
    case JsonValue::Kind::kArray:
      out += '[';
      for (std::size_t i = 0; i < v.items.size(); ++i) {
        if (i > 0) out += ',';
        append_compact(out, v.items[i]);
      }
      out += ']';
      break;
    case JsonValue::Kind::kObject:
      out += '{';
      for (std::size_t i = 0; i < v.members.size(); ++i) {
        if (i > 0) out += ',';
        append_escaped(out, v.members[i].key);
        out += ':';
        append_compact(out, v.members[i].value);
      }
      out += '}';
      break;
  }
}

void flatten_into(const JsonValue& v, const std::string& key,
                  std::vector<std::pair<std::string, std::string>>& out) {
  switch (v.kind) {
    case JsonValue::Kind::kObject:
      for (const auto& [name, member] : v.members) flatten_into(member, key.empty() ? name : key + "." + name, out);
      break;
    case JsonValue::Kind::kNull: out.emplace_back(key, ""); break;
    case JsonValue::Kind::kBool: out.emplace_back(key, v.boolean ? "true" : "false"); break;
    case JsonValue::Kind::kNumber:
    case JsonValue::Kind::kString: out.emplace_back(key, v.text); break;
    case JsonValue::Kind::kArray: out.emplace_back(key, to_compact_json(v)); break;
  }
}

}  // namespace

const JsonValue* JsonValue::find(std::string_view key) const {
  for (const auto& [name, value] : members) {
    if (name == key) return &value;
  }
  return nullptr;
}

bool parse_json(std::string_view text, JsonValue& out, std::string& error) {
  out = JsonValue{};
  Parser parser(text);
  try {
    if (parser.document(out)) return true;
  } catch (const std::bad_alloc&) {  // a document too large for memory: a message, not a crash
    error = "out of memory reading the JSON text";
    return false;
  }
  // line and column only now, on failure, so that parsing does not count them per byte
  const std::string_view before = text.substr(0, std::min(parser.error_at(), text.size()));
  const auto line = 1 + std::count(before.begin(), before.end(), '\n');
  const std::size_t last_newline = before.rfind('\n');
  const std::size_t column = last_newline == std::string_view::npos ? before.size() + 1 : before.size() - last_newline;
  error = "line " + std::to_string(line) + ", column " + std::to_string(column) + ": " + parser.what();
  return false;
}

std::string to_compact_json(const JsonValue& v) {
  std::string out;
  append_compact(out, v);
  return out;
}

void flatten(const JsonValue& v, std::vector<std::pair<std::string, std::string>>& out) {
  flatten_into(v, "", out);
}

}  // namespace ehpt::io
