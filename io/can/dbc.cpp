// SPDX-License-Identifier: BSD-3-Clause
#include "io/can/dbc.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <tuple>
#include <unordered_map>

#include "io/number_format.hpp"
#include "io/text_file.hpp"

namespace ehpt::io::can {

namespace {

// ---- tokens ----------------------------------------------------------------------------

enum class Tok { kIdent, kNumber, kString, kPunct, kEnd };

struct Token {
  Tok kind = Tok::kEnd;
  std::string_view text;  // a string's text without its quotes (escapes resolved in str)
  std::string str;        // kString only
  int line = 0;
  bool line_start = false;  // the first token on its line
};

constexpr std::size_t kMaxProblems = 100;  // a binary file would give one per line

bool ident_start(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || c == '_'; }
bool ident_char(char c) { return ident_start(c) || (c >= '0' && c <= '9'); }
bool digit(char c) { return c >= '0' && c <= '9'; }

class Lexer {
 public:
  explicit Lexer(std::string_view text) : s_(text) {}

  // false with a problem on an unterminated string or a character no DBC has
  bool next(Token& t, std::string& problem) {
    bool new_line = pos_ == 0;
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (c == '\n') {
        ++line_;
        new_line = true;
        ++pos_;
      } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
        ++pos_;
      } else if (c == '/' && pos_ + 1 < s_.size() && s_[pos_ + 1] == '/') {
        while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;  // a comment some writers add
      } else {
        break;
      }
    }
    t = Token{};
    t.line = line_;
    t.line_start = new_line;
    if (pos_ >= s_.size()) return true;
    const std::size_t begin = pos_;
    const char c = s_[pos_];
    if (ident_start(c)) {
      while (pos_ < s_.size() && ident_char(s_[pos_])) ++pos_;
      t.kind = Tok::kIdent;
    } else if (digit(c) || ((c == '-' || c == '+' || c == '.') && pos_ + 1 < s_.size() &&
                            (digit(s_[pos_ + 1]) || (s_[pos_ + 1] == '.' && pos_ + 2 < s_.size() && digit(s_[pos_ + 2]))))) {
      if (c == '-' || c == '+') ++pos_;
      while (pos_ < s_.size() && digit(s_[pos_])) ++pos_;
      if (pos_ < s_.size() && s_[pos_] == '.') {
        ++pos_;
        while (pos_ < s_.size() && digit(s_[pos_])) ++pos_;
      }
      if (pos_ < s_.size() && (s_[pos_] == 'e' || s_[pos_] == 'E')) {
        std::size_t q = pos_ + 1;
        if (q < s_.size() && (s_[q] == '+' || s_[q] == '-')) ++q;
        if (q < s_.size() && digit(s_[q])) {
          pos_ = q;
          while (pos_ < s_.size() && digit(s_[pos_])) ++pos_;
        }
      }
      t.kind = Tok::kNumber;
    } else if (c == '"') {
      ++pos_;
      const int first_line = line_;
      while (pos_ < s_.size() && s_[pos_] != '"') {
        if (s_[pos_] == '\\' && pos_ + 1 < s_.size()) ++pos_;  // \" and \\ .
        if (s_[pos_] == '\n') ++line_;
        t.str += s_[pos_++];
      }
      if (pos_ >= s_.size()) {
        line_ = first_line;
        problem = "a string that is never closed (a \" is missing)";
        return false;
      }
      ++pos_;
      t.kind = Tok::kString;
      t.text = s_.substr(begin + 1, pos_ - begin - 2);
      return true;
    } else if (std::strchr(":;|@()[],+-", c) != nullptr) {
      ++pos_;
      t.kind = Tok::kPunct;
    } else {
      problem = "unexpected character '" + printable(c) + "'";
      while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;  // one problem per line: the rest of it is skipped
      return false;
    }
    t.text = s_.substr(begin, pos_ - begin);
    return true;
  }
  int line() const { return line_; }

 private:
  static std::string printable(char c) {
    if (c >= 0x20 && c < 0x7F) return std::string(1, c);
    static const char* hex = "0123456789ABCDEF";
    const auto u = static_cast<unsigned char>(c);
    return std::string("\\x") + hex[u >> 4] + hex[u & 15];
  }
  std::string_view s_;
  std::size_t pos_ = 0;
  int line_ = 1;
};

// the statements a DBC has; an identifier that is one of them at the start of a line begins a
// new statement (that is how the reader finds its feet again after a bad one)
const std::set<std::string_view>& keywords() {
  static const std::set<std::string_view> k = {
      "VERSION", "NS_", "BS_", "BU_", "VAL_TABLE_", "BO_", "SG_", "BO_TX_BU_", "CM_", "BA_DEF_", "BA_DEF_DEF_",
      "BA_", "VAL_", "SIG_VALTYPE_", "SG_MUL_VAL_", "EV_", "ENVVAR_DATA_", "SGTYPE_", "SGTYPE_VAL_",
      "SIG_GROUP_", "SIG_TYPE_REF_", "BA_DEF_SGTYPE_", "BA_SGTYPE_", "SIGTYPE_VALTYPE_", "BA_DEF_REL_",
      "BA_REL_", "BA_DEF_DEF_REL_", "BU_SG_REL_", "BU_EV_REL_", "BU_BO_REL_", "CAT_DEF_", "CAT_", "FILTER",
      "EV_DATA_", "NS_DESC_", "SIG_GROUP_"};
  return k;
}

struct ParseError {
  std::string problem;
};

// ---- attributes -------------------------------------------------------------------------

enum class AttrType { kInt, kHex, kFloat, kString, kEnum };
struct AttrDef {
  AttrType type = AttrType::kString;
  std::string object;  // "", "BU_", "BO_", "SG_", "EV_"
  double min = 0, max = 0;
  std::vector<std::string> values;  // kEnum
  int line = 0;
};
// a value as written: a number or a string
struct AttrValue {
  bool is_string = false;
  double number = 0;
  std::string text;
  int line = 0;
  std::string statement;
};

class Parser {
 public:
  Parser(std::string_view text, Dbc& out) : text_(text), lex_(text), out_(out) {}

  void run() {
    advance();
    while (cur_.kind != Tok::kEnd && !stopped_) {
      const int line = cur_.line;
      const std::size_t before = consumed_;
      try {
        statement();
        if (consumed_ == before) advance();  // every statement reads a token: never spin in place
      } catch (const ParseError& e) {
        error(line, e.problem);
        if (consumed_ == before) advance();  // never stuck on the statement's first token
        resync();
      }
    }
    apply_attributes();
    check();
  }

 private:
  // ---- token access ----
  void advance() {
    ++consumed_;
    std::string problem;
    while (!lex_.next(cur_, problem)) {  // a loop, not recursion: a file of bad bytes must not overflow the stack
      error(lex_.line(), problem);
      if (problem.rfind("a string", 0) == 0) {
        cur_ = Token{};  // the rest of the file is inside the string: stop here
        stopped_ = true;
        return;
      }
    }
  }
  bool is(Tok k, std::string_view text = {}) const { return cur_.kind == k && (text.empty() || cur_.text == text); }
  bool at_keyword() const { return cur_.kind == Tok::kIdent && keywords().count(cur_.text) != 0; }
  [[noreturn]] void fail(const std::string& what) const {
    const std::string found = cur_.kind == Tok::kEnd      ? "the end of the file"
                              : cur_.kind == Tok::kString ? "\"" + cur_.str + "\""
                                                          : "'" + std::string(cur_.text) + "'";
    throw ParseError{"expected " + what + ", found " + found};
  }
  void expect(std::string_view punct) {
    if (!is(Tok::kPunct, punct)) fail("'" + std::string(punct) + "'");
    advance();
  }
  std::string ident(const char* what) {
    // a keyword at the start of a line begins the next statement: this one ended early
    if (cur_.kind != Tok::kIdent || (at_keyword() && cur_.line_start)) fail(what);
    std::string s(cur_.text);
    advance();
    return s;
  }
  std::string string(const char* what) {
    if (cur_.kind != Tok::kString) fail(what);
    std::string s = cur_.str;
    advance();
    return s;
  }
  double number(const char* what) {
    if (cur_.kind != Tok::kNumber) fail(what);
    const std::string_view t = cur_.text[0] == '+' ? cur_.text.substr(1) : cur_.text;
    double v = 0;
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size() || !std::isfinite(v)) {
      throw ParseError{std::string(what) + " '" + std::string(cur_.text) + "' is not a finite number"};
    }
    advance();
    return v;
  }
  // a whole number in [lo, hi]
  std::int64_t integer(const char* what, std::int64_t lo, std::int64_t hi) {
    if (cur_.kind != Tok::kNumber) fail(what);
    const std::string_view t = cur_.text[0] == '+' ? cur_.text.substr(1) : cur_.text;
    std::int64_t v = 0;
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size() || v < lo || v > hi) {
      throw ParseError{std::string(what) + " '" + std::string(cur_.text) + "' must be a whole number in [" +
                       std::to_string(lo) + ", " + std::to_string(hi) + "]"};
    }
    advance();
    return v;
  }
  // skip to the end of a ';'-terminated statement
  void skip_to_semicolon() {
    while (!is(Tok::kEnd) && !is(Tok::kPunct, ";") && !(at_keyword() && cur_.line_start)) advance();
    if (is(Tok::kPunct, ";")) advance();
  }
  // to the next statement: a keyword at the start of a line (the current token, if it is one)
  void resync() {
    while (!is(Tok::kEnd) && !(at_keyword() && cur_.line_start)) advance();
  }
  void end_statement() {
    if (!is(Tok::kPunct, ";")) fail("';' at the end of the statement");
    advance();
  }

  std::string statement_text(int line) {
    if (line_starts_.empty()) {  // once, on the first problem: each problem is then one lookup
      line_starts_.push_back(0);
      for (std::size_t i = 0; i < text_.size(); ++i) {
        if (text_[i] == '\n') line_starts_.push_back(i + 1);
      }
    }
    if (line < 1 || static_cast<std::size_t>(line) > line_starts_.size()) return "";
    const std::size_t pos = line_starts_[static_cast<std::size_t>(line) - 1];
    if (pos >= text_.size()) return "";
    std::string_view s = text_.substr(pos, text_.find('\n', pos) - pos);
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == '\r' || s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
    std::string r;
    for (const char c : s.substr(0, 100)) r += (c >= 0x20 && c < 0x7F) ? c : '?';
    return s.size() > 100 ? r + "..." : r;
  }
  void error(int line, const std::string& problem) {
    if (out_.errors.size() < kMaxProblems) {
      out_.errors.push_back({line, line > 0 ? statement_text(line) : "", problem});
    } else if (out_.errors.size() == kMaxProblems) {
      out_.errors.push_back({line, "", "more problems; the first " + std::to_string(kMaxProblems) + " are listed"});
    }
  }
  void warning(int line, const std::string& problem) {
    if (out_.warnings.size() < kMaxProblems) out_.warnings.push_back({line, statement_text(line), problem});
  }

  // ---- statements ----
  void statement() {
    if (cur_.kind != Tok::kIdent) fail("a statement (BO_, SG_, BA_, CM_, ...)");
    const std::string_view kw = cur_.text;
    const int line = cur_.line;
    if (kw == "VERSION") {
      advance();
      out_.version = string("the version string");
    } else if (kw == "NS_") {
      advance();
      expect(":");
      // the list of new symbols: keywords themselves, up to BS_
      while (cur_.kind == Tok::kIdent && cur_.text != "BS_" && cur_.text != "BU_" && cur_.text != "BO_") advance();
    } else if (kw == "BS_") {
      advance();
      expect(":");
      while (is(Tok::kNumber) || is(Tok::kPunct, ":") || is(Tok::kPunct, ",")) advance();
    } else if (kw == "BU_") {
      advance();
      expect(":");
      while (cur_.kind == Tok::kIdent && !(at_keyword() && cur_.line_start)) {
        out_.nodes.emplace_back(cur_.text);
        advance();
      }
    } else if (kw == "VAL_TABLE_") {
      advance();
      ident("the value table's name");
      while (is(Tok::kNumber)) {
        number("a value");
        string("the value's name");
      }
      end_statement();
    } else if (kw == "BO_") {
      message();
    } else if (kw == "SG_") {
      signal();
    } else if (kw == "BO_TX_BU_") {
      advance();
      TxNodes tx;
      tx.line = line;
      tx.id = integer("the message id", 0, 0xFFFFFFFFLL);
      expect(":");
      tx.nodes.push_back(ident("a sending node"));
      while (is(Tok::kPunct, ",")) {
        advance();
        tx.nodes.push_back(ident("a sending node"));
      }
      end_statement();
      tx_nodes_.push_back(std::move(tx));
    } else if (kw == "CM_") {
      comment();
    } else if (kw == "BA_DEF_") {
      attribute_definition();
    } else if (kw == "BA_DEF_DEF_") {
      advance();
      const std::string name = string("the attribute's name");
      AttrValue v = attribute_value();
      v.line = line;
      defaults_[name] = v;
      end_statement();
    } else if (kw == "BA_") {
      attribute();
    } else if (kw == "VAL_") {
      value_names();
    } else if (kw == "SIG_VALTYPE_") {
      value_type();
    } else if (kw == "SG_MUL_VAL_") {
      advance();
      skip_to_semicolon();
      error(line, "extended multiplexing (SG_MUL_VAL_) is not supported: give each multiplexed signal one mN value");
    } else if (keywords().count(kw) != 0) {
      const std::string name(kw);
      advance();
      skip_to_semicolon();
      warning(line, name + " is not used by ehpt; skipped");
    } else {
      throw ParseError{"unknown statement '" + std::string(kw) + "'"};
    }
  }

  // BO_ <id> <name>: <size> <sender>
  void message() {
    const int line = cur_.line;
    advance();
    owner_ = Owner::kDropped;  // until this BO_ is read: its signals go nowhere (its error is reported)
    const std::int64_t raw_id = integer("the message id", 0, 0xFFFFFFFFLL);
    DbcMessage m;
    m.line = line;
    m.name = ident("the message name");
    expect(":");
    m.size_bytes = static_cast<int>(integer("the message size in bytes", 0, kMaxDbcPayloadBytes));
    m.senders.push_back(ident("the sending node"));
    m.extended = (raw_id & 0x80000000LL) != 0;
    m.id = static_cast<std::uint32_t>(raw_id & 0x7FFFFFFFLL);
    // Vector's container for signals of no message: not a frame
    if (m.name == "VECTOR__INDEPENDENT_SIG_MSG") return;
    if (m.extended && m.id > kMaxExtendedId) {
      throw ParseError{"extended id 0x" + hex(m.id) + " has more than 29 bits"};
    }
    if (!m.extended && m.id > 0x7FF) {
      throw ParseError{"standard id " + std::to_string(m.id) + " (0x" + hex(m.id) +
                       ") has more than 11 bits; an extended id is written with bit 31 set (id + 2147483648)"};
    }
    static const std::set<int> fd_sizes = {12, 16, 20, 24, 32, 48, 64};
    if (m.size_bytes > 8 && fd_sizes.count(m.size_bytes) == 0) {
      throw ParseError{"size " + std::to_string(m.size_bytes) +
                       " bytes is no CAN frame length (0..8, CAN FD 12, 16, 20, 24, 32, 48, 64)"};
    }
    m.fd = m.size_bytes > 8;
    if (!index_.emplace(std::make_pair(m.id, m.extended), out_.messages.size()).second) {
      throw ParseError{"message id " + std::to_string(m.id) + " (0x" + hex(m.id) + ") is defined twice"};
    }
    out_.messages.push_back(std::move(m));
    owner_ = Owner::kMessage;
  }

  // SG_ <name> [M|mN] : <start>|<length>@<order><sign> (<factor>,<offset>) [<min>|<max>] "<unit>" <receivers>
  void signal() {
    const int line = cur_.line;
    advance();
    if (owner_ == Owner::kNone) throw ParseError{"SG_ before any BO_: a signal belongs to the message above it"};
    DbcSignal s;
    s.line = line;
    s.name = ident("the signal name");
    if (cur_.kind == Tok::kIdent) {
      const std::string_view m = cur_.text;
      if (m == "M") {
        s.multiplex = Multiplex::kMultiplexor;
      } else if (m.size() > 1 && m[0] == 'm' && std::all_of(m.begin() + 1, m.end(), digit)) {
        s.multiplex = Multiplex::kMultiplexed;
        const auto r = std::from_chars(m.data() + 1, m.data() + m.size(), s.multiplex_value);
        if (r.ec != std::errc()) throw ParseError{"multiplex value '" + std::string(m) + "' is too large"};
      } else if (m.size() > 1 && m[0] == 'm' && m.back() == 'M') {
        throw ParseError{"extended multiplexing ('" + std::string(m) + "') is not supported"};
      } else {
        fail("':' or a multiplex indicator (M, m0, m1, ...)");
      }
      advance();
    }
    expect(":");
    s.start_bit = static_cast<int>(integer("the start bit", 0, 8 * kMaxDbcPayloadBytes - 1));
    expect("|");
    s.length = static_cast<int>(integer("the length in bits", 1, 64));
    expect("@");
    const std::int64_t order = integer("the byte order (0 Motorola, 1 Intel)", 0, 1);
    s.byte_order = order == 1 ? ByteOrder::kIntel : ByteOrder::kMotorola;
    if (is(Tok::kPunct, "+") || is(Tok::kPunct, "-")) {
      s.is_signed = cur_.text == "-";
      advance();
    } else {
      fail("'+' (unsigned) or '-' (signed)");
    }
    expect("(");
    s.factor = number("the factor");
    expect(",");
    s.offset = number("the offset");
    expect(")");
    expect("[");
    s.min = number("the minimum");
    expect("|");
    s.max = number("the maximum");
    expect("]");
    s.unit = string("the unit in quotes");
    if (cur_.kind == Tok::kIdent && !(at_keyword() && cur_.line_start)) {
      s.receivers.push_back(ident("a receiving node"));
      while (is(Tok::kPunct, ",")) {
        advance();
        s.receivers.push_back(ident("a receiving node"));
      }
    }
    if (owner_ == Owner::kDropped) return;
    if (s.factor == 0.0) throw ParseError{"factor 0: every raw value would decode to the offset"};
    if (s.min > s.max) throw ParseError{"minimum " + number_text(s.min) + " is above the maximum " + number_text(s.max)};
    out_.messages.back().signals.push_back(std::move(s));
  }

  // CM_ [BU_ <node> | BO_ <id> | SG_ <id> <signal> | EV_ <name>] "<text>";
  void comment() {
    const int line = cur_.line;
    advance();
    if (is(Tok::kString)) {
      string("the comment");
    } else {
      const std::string object = ident("BU_, BO_, SG_, EV_ or the comment");
      if (object == "BO_" || object == "SG_") {
        const std::int64_t id = integer("the message id", 0, 0xFFFFFFFFLL);
        std::string sig = object == "SG_" ? ident("the signal name") : "";
        const std::string text = string("the comment in quotes");
        comments_.push_back({id, sig, text, line});
      } else if (object == "BU_" || object == "EV_") {
        ident("the node or variable name");
        string("the comment in quotes");
      } else {
        throw ParseError{"CM_ of '" + object + "': expected BU_, BO_, SG_ or EV_"};
      }
    }
    end_statement();
  }

  // BA_DEF_ [BU_|BO_|SG_|EV_] "<name>" INT|HEX <min> <max> | FLOAT <min> <max> | STRING | ENUM "<a>","<b>";
  void attribute_definition() {
    const int line = cur_.line;
    advance();
    AttrDef d;
    d.line = line;
    if (cur_.kind == Tok::kIdent) d.object = ident("the object type");
    const std::string name = string("the attribute's name in quotes");
    const std::string type = ident("the attribute's type (INT, HEX, FLOAT, STRING, ENUM)");
    if (type == "INT" || type == "HEX" || type == "FLOAT") {
      d.type = type == "INT" ? AttrType::kInt : type == "HEX" ? AttrType::kHex : AttrType::kFloat;
      d.min = number("the minimum");
      d.max = number("the maximum");
    } else if (type == "STRING") {
      d.type = AttrType::kString;
    } else if (type == "ENUM") {
      d.type = AttrType::kEnum;
      if (is(Tok::kString)) {
        d.values.push_back(string("a value"));
        while (is(Tok::kPunct, ",")) {
          advance();
          d.values.push_back(string("a value in quotes"));
        }
      }
    } else {
      throw ParseError{"attribute type '" + type + "': expected INT, HEX, FLOAT, STRING or ENUM"};
    }
    end_statement();
    definitions_[name] = d;
  }

  AttrValue attribute_value() {
    AttrValue v;
    if (is(Tok::kString)) {
      v.is_string = true;
      v.text = string("the value");
    } else {
      v.number = number("the attribute's value");
    }
    return v;
  }

  // BA_ "<name>" [BU_ <node> | BO_ <id> | SG_ <id> <signal> | EV_ <name>] <value>;
  void attribute() {
    const int line = cur_.line;
    advance();
    const std::string name = string("the attribute's name in quotes");
    Assignment a;
    a.name = name;
    a.line = line;
    if (cur_.kind == Tok::kIdent) {
      a.object = ident("BU_, BO_, SG_ or EV_");
      if (a.object == "BO_" || a.object == "SG_") {
        a.id = integer("the message id", 0, 0xFFFFFFFFLL);
        if (a.object == "SG_") a.signal = ident("the signal name");
      } else if (a.object == "BU_" || a.object == "EV_") {
        ident("the node or variable name");
      } else {
        throw ParseError{"BA_ of '" + a.object + "': expected BU_, BO_, SG_ or EV_"};
      }
    }
    a.value = attribute_value();
    a.value.line = line;
    end_statement();
    if (a.object == "BO_" || a.object == "SG_") {
      values_by_object_[{a.name, a.object, a.id & 0xFFFFFFFFLL, a.signal}] = a.value;
      referenced_.push_back({a.id, a.signal, a.line, a.object});
    }
  }

  // VAL_ <id> <signal> <raw> "<name>" ... ;
  void value_names() {
    const int line = cur_.line;
    advance();
    if (cur_.kind == Tok::kIdent) {  // an environment variable's
      advance();
      skip_to_semicolon();
      return;
    }
    ValueNames v;
    v.line = line;
    v.id = integer("the message id", 0, 0xFFFFFFFFLL);
    v.signal = ident("the signal name");
    while (is(Tok::kNumber)) {
      DbcValueName n;
      n.raw = integer("a raw value", INT64_MIN, INT64_MAX);
      n.name = string("the value's name in quotes");
      v.names.push_back(std::move(n));
    }
    end_statement();
    values_.push_back(std::move(v));
  }

  // SIG_VALTYPE_ <id> <signal> : 0|1|2;
  void value_type() {
    const int line = cur_.line;
    advance();
    ValueType v;
    v.line = line;
    v.id = integer("the message id", 0, 0xFFFFFFFFLL);
    v.signal = ident("the signal name");
    if (is(Tok::kPunct, ":")) advance();
    v.type = static_cast<int>(integer("the value type (0 integer, 1 float, 2 double)", 0, 2));
    end_statement();
    types_.push_back(v);
  }

  // ---- after the last statement: attach what refers to messages and signals ----
  DbcMessage* find(std::int64_t raw_id, int line, const std::string& what) {
    const bool extended = (raw_id & 0x80000000LL) != 0;
    const auto id = static_cast<std::uint32_t>(raw_id & 0x7FFFFFFFLL);
    const auto it = index_.find({id, extended});
    if (it != index_.end()) return &out_.messages[it->second];
    if ((raw_id & 0xFFFFFFFFLL) != 0xC0000000LL) {  // not VECTOR__INDEPENDENT_SIG_MSG
      warning(line, what + " of message " + std::to_string(raw_id) + ", which no BO_ defines; ignored");
    }
    return nullptr;
  }
  DbcSignal* find(std::int64_t raw_id, const std::string& signal, int line, const std::string& what) {
    DbcMessage* m = find(raw_id, line, what);
    if (m == nullptr) return nullptr;
    const auto& index = signal_index_[static_cast<std::size_t>(m - out_.messages.data())];
    if (const auto it = index.find(signal); it != index.end()) return &m->signals[it->second];
    warning(line, what + " of signal " + signal + ", which message " + m->name + " does not have; ignored");
    return nullptr;
  }
  // signal lookups by name: an index per message, built once before the attributes are applied
  std::vector<std::unordered_map<std::string, std::size_t>> signal_index_;

  void apply_attributes() {
    signal_index_.resize(out_.messages.size());
    for (std::size_t i = 0; i < out_.messages.size(); ++i) {
      const auto& signals = out_.messages[i].signals;
      for (std::size_t k = 0; k < signals.size(); ++k) signal_index_[i].emplace(signals[k].name, k);  // the first of a name
    }
    for (const auto& tx : tx_nodes_) {
      DbcMessage* m = find(tx.id, tx.line, "BO_TX_BU_");
      if (m == nullptr) continue;
      for (const std::string& n : tx.nodes) {
        if (std::find(m->senders.begin(), m->senders.end(), n) == m->senders.end()) m->senders.push_back(n);
      }
    }
    for (const auto& r : referenced_) {  // a BA_ of an object no BO_ or SG_ defines: worth a warning
      if (r.object == "BO_") {
        find(r.id, r.line, "BA_");
      } else {
        find(r.id, r.signal, r.line, "BA_");
      }
    }
    for (const auto& c : comments_) {
      if (c.signal.empty()) {
        if (DbcMessage* m = find(c.id, c.line, "a comment")) m->comment = c.text;
      } else if (DbcSignal* s = find(c.id, c.signal, c.line, "a comment")) {
        s->comment = c.text;
      }
    }
    for (const auto& v : values_) {
      if (DbcSignal* s = find(v.id, v.signal, v.line, "VAL_")) s->value_names = v.names;
    }
    for (const auto& t : types_) {
      DbcSignal* s = find(t.id, t.signal, t.line, "SIG_VALTYPE_");
      if (s == nullptr) continue;
      s->value_type = t.type == 0 ? SignalValueType::kInteger : t.type == 1 ? SignalValueType::kFloat32 : SignalValueType::kFloat64;
      const int bits = t.type == 1 ? 32 : 64;
      if (t.type != 0 && s->length != bits) {
        error(t.line, "signal " + s->name + " is " + std::to_string(s->length) + " bits long; an IEEE " +
                          (t.type == 1 ? "float" : "double") + " has " + std::to_string(bits));
      }
    }
    // the defaults first, then each object's own value
    for (DbcMessage& m : out_.messages) {
      if (const auto v = value_of("GenMsgCycleTime", m, nullptr)) set_cycle_time(m, *v);
      if (const auto v = value_of("GenMsgSendType", m, nullptr)) m.send_type = text_of("GenMsgSendType", *v);
      if (const auto v = value_of("VFrameFormat", m, nullptr)) {
        const std::string f = text_of("VFrameFormat", *v);
        if (f.size() > 3 && f.compare(f.size() - 3, 3, "_FD") == 0) m.fd = true;
      }
      for (DbcSignal& s : m.signals) {
        if (const auto v = value_of("GenSigStartValue", m, &s)) {
          if (v->is_string) {
            error(v->line, "GenSigStartValue of " + s.name + " must be a number");
          } else {
            s.start_value_raw = v->number;
          }
        }
      }
    }
  }
  // the value of an attribute for a message (signal == nullptr) or a signal: its own, else the default
  std::optional<AttrValue> value_of(const std::string& name, const DbcMessage& m, const DbcSignal* s) {
    const std::int64_t raw_id = static_cast<std::int64_t>(m.id) | (m.extended ? 0x80000000LL : 0);
    const auto own = values_by_object_.find({name, s ? "SG_" : "BO_", raw_id, s ? s->name : ""});
    if (own != values_by_object_.end()) return own->second;
    const auto d = defaults_.find(name);
    if (d != defaults_.end()) return d->second;
    return std::nullopt;
  }
  // an ENUM's value as text: written as its index (as Vector's tools do) or as the text
  std::string text_of(const std::string& name, const AttrValue& v) {
    if (v.is_string) return v.text;
    const auto d = definitions_.find(name);
    if (d != definitions_.end() && d->second.type == AttrType::kEnum) {
      if (v.number >= 0 && v.number < static_cast<double>(d->second.values.size()) && v.number == std::floor(v.number)) {
        return d->second.values[static_cast<std::size_t>(v.number)];
      }
      error(v.line, name + " = " + number_text(v.number) + " is no index of its ENUM (0.." +
                        std::to_string(static_cast<long long>(d->second.values.size()) - 1) + ")");
      return "";
    }
    return number_text(v.number);
  }
  void set_cycle_time(DbcMessage& m, const AttrValue& v) {
    if (v.is_string || !(v.number >= 0 && v.number <= 3600000 && v.number == std::floor(v.number))) {
      error(v.line, "GenMsgCycleTime of " + m.name + " must be a whole number of ms in [0, 3600000]");
      return;
    }
    if (v.number > 0) m.cycle_time_ms = static_cast<int>(v.number);
  }

  // ---- the rules the run phase relies on ----
  void check() {
    std::set<std::string> names;
    for (const DbcMessage& m : out_.messages) {
      if (!names.insert(m.name).second) error(m.line, "message name " + m.name + " is defined twice");
      std::set<std::string> signal_names;
      int multiplexors = 0;
      for (const DbcSignal& s : m.signals) {
        if (!signal_names.insert(s.name).second) {
          error(s.line, "signal " + s.name + " is defined twice in " + m.name);
        }
        if (!signal_fits(s, m.size_bytes)) {
          error(s.line, "signal " + s.name + " (start bit " + std::to_string(s.start_bit) + ", " +
                            std::to_string(s.length) + " bits, " +
                            (s.byte_order == ByteOrder::kIntel ? "Intel" : "Motorola") + ") does not fit in the " +
                            std::to_string(m.size_bytes) + " bytes of " + m.name);
        }
        if (s.multiplex == Multiplex::kMultiplexor) {
          ++multiplexors;
          if (s.length > 32) error(s.line, "multiplexor " + s.name + " has more than 32 bits");
        }
      }
      if (multiplexors > 1) error(m.line, m.name + " has more than one multiplexor (extended multiplexing is not supported)");
      for (const DbcSignal& s : m.signals) {
        if (s.multiplex == Multiplex::kMultiplexed && multiplexors == 0) {
          error(s.line, "signal " + s.name + " is multiplexed (m" + std::to_string(s.multiplex_value) + ") but " +
                            m.name + " has no multiplexor (M)");
        }
      }
      overlaps(m);
    }
  }
  // two signals present at the same time that share a bit: legal in a DBC, nearly always a typo
  void overlaps(const DbcMessage& m) {
    // a real message has at most a few hundred signals (512 bits; multiplexed pages add some):
    // beyond that the pairwise check would cost more than the file is worth
    constexpr std::size_t kMaxChecked = 1024;
    if (m.signals.size() > kMaxChecked) {
      warning(m.line, m.name + " has " + std::to_string(m.signals.size()) + " signals; overlaps are checked for " +
                          std::to_string(kMaxChecked) + " at most, so not for it");
      return;
    }
    std::vector<std::vector<std::size_t>> owners(static_cast<std::size_t>(8 * m.size_bytes));  // signals per bit
    for (std::size_t j = 0; j < m.signals.size() && out_.warnings.size() < kMaxProblems; ++j) {
      const DbcSignal& b = m.signals[j];
      const std::vector<bool> mask = bit_mask(b, m.size_bytes);
      bool warned = false;
      for (std::size_t k = 0; k < mask.size(); ++k) {
        if (!mask[k]) continue;
        for (const std::size_t i : owners[k]) {
          const DbcSignal& a = m.signals[i];
          const bool apart = a.multiplex == Multiplex::kMultiplexed && b.multiplex == Multiplex::kMultiplexed &&
                             a.multiplex_value != b.multiplex_value;
          if (!apart && !warned) {
            warning(b.line, "signal " + b.name + " shares bit " + std::to_string(k) + " with " + a.name + " in " + m.name);
            warned = true;
          }
        }
        if (!warned) owners[k].push_back(j);  // an overlapping signal is reported once and not kept
      }
    }
  }
  static std::vector<bool> bit_mask(const DbcSignal& s, int size_bytes) {
    std::vector<bool> mask(static_cast<std::size_t>(8 * size_bytes), false);
    if (!signal_fits(s, size_bytes)) return mask;
    int pos = s.start_bit;
    for (int i = 0; i < s.length; ++i) {
      mask[static_cast<std::size_t>(pos)] = true;
      if (s.byte_order == ByteOrder::kIntel) {
        ++pos;
      } else {
        pos = pos % 8 == 0 ? pos + 15 : pos - 1;
      }
    }
    return mask;
  }

  static std::string hex(std::uint32_t v) {
    char buf[16];
    const auto r = std::to_chars(buf, buf + sizeof buf, v, 16);
    std::string s(buf, r.ptr);
    for (char& c : s) c = static_cast<char>(c >= 'a' && c <= 'f' ? c - 'a' + 'A' : c);
    return s;
  }

  struct Comment {
    std::int64_t id;
    std::string signal, text;
    int line;
  };
  struct Assignment {
    std::string name, object, signal;
    std::int64_t id = 0;
    AttrValue value;
    int line = 0;
  };
  struct ValueNames {
    std::int64_t id = 0;
    std::string signal;
    std::vector<DbcValueName> names;
    int line = 0;
  };
  struct ValueType {
    std::int64_t id = 0;
    std::string signal;
    int type = 0;
    int line = 0;
  };

  std::string_view text_;
  std::vector<std::size_t> line_starts_;  // where each line begins (statement_text)
  Lexer lex_;
  Dbc& out_;
  Token cur_;
  bool stopped_ = false;
  // whose are the SG_ lines: none yet, the last BO_'s, or dropped (VECTOR__INDEPENDENT_SIG_MSG,
  // or a BO_ with an error)
  enum class Owner { kNone, kMessage, kDropped } owner_ = Owner::kNone;
  std::size_t consumed_ = 0;  // tokens read
  std::map<std::pair<std::uint32_t, bool>, std::size_t> index_;  // (id, extended) -> messages[i]
  // BA_ values by (attribute, object, raw id, signal): the last one written wins
  std::map<std::tuple<std::string, std::string, std::int64_t, std::string>, AttrValue> values_by_object_;
  std::vector<Comment> comments_;
  std::map<std::string, AttrDef> definitions_;
  std::map<std::string, AttrValue> defaults_;
  struct TxNodes {
    std::int64_t id = 0;
    std::vector<std::string> nodes;
    int line = 0;
  };
  std::vector<TxNodes> tx_nodes_;
  struct Reference {
    std::int64_t id;
    std::string signal;
    int line;
    std::string object;
  };
  std::vector<Reference> referenced_;
  std::vector<ValueNames> values_;
  std::vector<ValueType> types_;
};

}  // namespace

std::uint64_t raw_mask(int length) { return length >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << length) - 1; }

const DbcSignal* DbcMessage::signal(std::string_view signal_name) const {
  for (const DbcSignal& s : signals) {
    if (s.name == signal_name) return &s;
  }
  return nullptr;
}

const DbcSignal* DbcMessage::multiplexor() const {
  for (const DbcSignal& s : signals) {
    if (s.multiplex == Multiplex::kMultiplexor) return &s;
  }
  return nullptr;
}

const DbcMessage* Dbc::message(std::string_view message_name) const {
  for (const DbcMessage& m : messages) {
    if (m.name == message_name) return &m;
  }
  return nullptr;
}

const DbcMessage* Dbc::message(std::uint32_t id, bool extended) const {
  for (const DbcMessage& m : messages) {
    if (m.id == id && m.extended == extended) return &m;
  }
  return nullptr;
}

std::string to_string(const Dbc& dbc, const DbcProblem& p) {
  std::string s = dbc.file;
  if (p.line > 0) s += ":" + std::to_string(p.line);
  s += ": " + p.problem;
  if (!p.statement.empty()) s += " (" + p.statement + ")";
  return s;
}

Dbc parse_dbc(std::string_view text, const std::string& file) {
  Dbc dbc;
  dbc.file = file;
  Parser(text, dbc).run();
  return dbc;
}

Dbc load_dbc(const std::string& path) {
  std::string text, reason;
  if (!read_text_file(path, text, reason)) {
    Dbc dbc;
    dbc.file = path;
    dbc.errors.push_back({0, "", "cannot read the DBC: " + reason});
    return dbc;
  }
  return parse_dbc(text, path);
}

bool signal_fits(const DbcSignal& s, int payload_bytes) {
  const int bits = 8 * payload_bytes;
  if (s.length < 1 || s.length > 64 || s.start_bit < 0 || s.start_bit >= bits) return false;
  if (s.byte_order == ByteOrder::kIntel) return s.start_bit + s.length <= bits;
  // Motorola: the least significant bit is length - 1 steps down the sawtooth from the start
  const int msb_byte = s.start_bit / 8;
  const int bits_in_first = s.start_bit % 8 + 1;
  if (s.length <= bits_in_first) return true;
  const int more_bytes = (s.length - bits_in_first + 7) / 8;
  return msb_byte + more_bytes < payload_bytes;
}

namespace {

// The signal's bits as one shift of the payload read as a 64-bit word (the codec's hot path:
// a bit at a time was 9 000 instructions per PSecu2 sample). Intel: the payload little-endian,
// the signal from start_bit up. Motorola: the payload big-endian (byte 0's bit 7 first), the
// signal from its most significant bit, which the DBC numbers start_bit (byte start_bit / 8,
// bit start_bit % 8), so at big-endian index 8 (start_bit / 8) + 7 - start_bit % 8. shift is
// the signal's lowest bit in the word; false (the bit loops below) if the signal does not lie
// within the payload's first 8 bytes.
bool word_shift(const DbcSignal& s, std::size_t payload_bytes, int& shift) {
  if (s.length < 1 || s.length > 64 || s.start_bit < 0 || payload_bytes > 8) return false;
  const int bits = static_cast<int>(payload_bytes) * 8;
  if (s.byte_order == ByteOrder::kIntel) {
    if (s.start_bit + s.length > bits) return false;
    shift = s.start_bit;
  } else {
    const int msb = 8 * (s.start_bit / 8) + 7 - s.start_bit % 8;
    if (msb + s.length > bits) return false;
    shift = 64 - msb - s.length;
  }
  return true;
}
// Byte i at bits 8i up (little-endian: one load on such a host), or at bits 56 - 8i down.
std::uint64_t load_word(const DbcSignal& s, std::span<const std::uint8_t> payload) {
  std::uint64_t w = 0;
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(&w, payload.data(), payload.size());
    return s.byte_order == ByteOrder::kIntel ? w : __builtin_bswap64(w);
  }
  if (s.byte_order == ByteOrder::kIntel) {
    for (std::size_t i = payload.size(); i-- > 0;) w = (w << 8) | payload[i];
  } else {
    for (std::size_t i = 0; i < 8; ++i) w = (w << 8) | (i < payload.size() ? payload[i] : 0u);
  }
  return w;
}
void store_word(const DbcSignal& s, std::uint64_t w, std::span<std::uint8_t> payload) {
  if constexpr (std::endian::native == std::endian::little) {
    if (s.byte_order != ByteOrder::kIntel) w = __builtin_bswap64(w);
    std::memcpy(payload.data(), &w, payload.size());
    return;
  }
  if (s.byte_order == ByteOrder::kIntel) {
    for (std::size_t i = 0; i < payload.size(); ++i, w >>= 8) payload[i] = static_cast<std::uint8_t>(w);
  } else {
    for (std::size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<std::uint8_t>(w >> (56 - 8 * i));
  }
}

}  // namespace

std::uint64_t extract_raw(const DbcSignal& s, std::span<const std::uint8_t> payload) {
  int shift = 0;
  if (word_shift(s, payload.size(), shift)) return (load_word(s, payload) >> shift) & raw_mask(s.length);
  std::uint64_t raw = 0;
  int pos = s.start_bit;
  if (s.byte_order == ByteOrder::kIntel) {
    for (int i = 0; i < s.length; ++i, ++pos) {
      raw |= static_cast<std::uint64_t>((payload[static_cast<std::size_t>(pos >> 3)] >> (pos & 7)) & 1u) << i;
    }
  } else {
    for (int i = 0; i < s.length; ++i) {
      raw = (raw << 1) | ((payload[static_cast<std::size_t>(pos >> 3)] >> (pos & 7)) & 1u);
      pos = (pos & 7) == 0 ? pos + 15 : pos - 1;
    }
  }
  return raw;
}

void insert_raw(const DbcSignal& s, std::uint64_t raw, std::span<std::uint8_t> payload) {
  raw &= raw_mask(s.length);
  int shift = 0;
  if (word_shift(s, payload.size(), shift)) {
    const std::uint64_t mask = raw_mask(s.length) << shift;
    store_word(s, (load_word(s, payload) & ~mask) | (raw << shift), payload);
    return;
  }
  const auto put = [&](int pos, std::uint64_t bit) {
    std::uint8_t& byte = payload[static_cast<std::size_t>(pos >> 3)];
    byte = static_cast<std::uint8_t>((byte & ~(1u << (pos & 7))) | (static_cast<unsigned>(bit) << (pos & 7)));
  };
  int pos = s.start_bit;
  if (s.byte_order == ByteOrder::kIntel) {
    for (int i = 0; i < s.length; ++i, ++pos) put(pos, (raw >> i) & 1u);
  } else {
    for (int i = s.length - 1; i >= 0; --i) {
      put(pos, (raw >> i) & 1u);
      pos = (pos & 7) == 0 ? pos + 15 : pos - 1;
    }
  }
}

double raw_to_physical(const DbcSignal& s, std::uint64_t raw) {
  double value = 0;
  if (s.value_type == SignalValueType::kFloat32) {
    const auto bits = static_cast<std::uint32_t>(raw);
    float f;
    std::memcpy(&f, &bits, sizeof f);
    value = f;
  } else if (s.value_type == SignalValueType::kFloat64) {
    std::memcpy(&value, &raw, sizeof value);
  } else if (s.is_signed) {
    value = static_cast<double>(raw_to_int(s, raw));
  } else {
    value = static_cast<double>(raw);
  }
  return value * s.factor + s.offset;
}

std::uint64_t physical_to_raw(const DbcSignal& s, double physical) {
  if (std::isnan(physical)) {
    if (!s.start_value_raw || s.value_type != SignalValueType::kInteger) return 0;
    return physical_to_raw(s, *s.start_value_raw * s.factor + s.offset);  // finite: checked at load
  }
  if (s.has_range()) physical = std::clamp(physical, s.min, s.max);
  const double scaled = (physical - s.offset) / s.factor;
  if (s.value_type == SignalValueType::kFloat32) {
    const float f = static_cast<float>(std::clamp(scaled, -3.4028234663852886e38, 3.4028234663852886e38));
    std::uint32_t bits;
    std::memcpy(&bits, &f, sizeof bits);
    return bits;
  }
  if (s.value_type == SignalValueType::kFloat64) {
    std::uint64_t bits;
    std::memcpy(&bits, &scaled, sizeof bits);
    return bits;
  }
  double r = std::nearbyint(scaled);
  if (s.has_range()) {  // rounding to a step may leave [min, max] (factor 0.5, max 10.3: 10.5): one step back
    const double step = s.factor > 0.0 ? 1.0 : -1.0;
    if (r * s.factor + s.offset > s.max) r -= step;
    if (r * s.factor + s.offset < s.min) r += step;
  }
  // the raw range as doubles: exact up to 53 bits, and the comparisons below keep every cast defined
  if (s.is_signed) {
    const double lo = -std::ldexp(1.0, s.length - 1), hi = std::ldexp(1.0, s.length - 1);  // [lo, hi)
    if (!(r >= lo)) return (~std::uint64_t{0} << (s.length - 1)) & raw_mask(s.length);  // the most negative
    if (!(r < hi)) return raw_mask(s.length) >> 1;
    return static_cast<std::uint64_t>(static_cast<std::int64_t>(r)) & raw_mask(s.length);
  }
  const double hi = std::ldexp(1.0, s.length);  // [0, hi)
  if (!(r >= 0.0)) return 0;
  if (!(r < hi)) return raw_mask(s.length);
  return static_cast<std::uint64_t>(r);
}

bool is_present(const DbcMessage& m, const DbcSignal& s, std::span<const std::uint8_t> payload) {
  if (s.multiplex != Multiplex::kMultiplexed) return true;
  const DbcSignal* mux = m.multiplexor();
  return mux != nullptr && extract_raw(*mux, payload) == s.multiplex_value;
}

std::int64_t raw_to_int(const DbcSignal& s, std::uint64_t raw) {
  if (s.is_signed && s.length < 64 && ((raw >> (s.length - 1)) & 1u)) return static_cast<std::int64_t>(raw | ~raw_mask(s.length));
  return static_cast<std::int64_t>(raw);
}

RawRange codec_raw_range(const DbcSignal& s) {
  RawRange r;
  if (s.is_signed) {
    r.lo = s.length >= 64 ? INT64_MIN : -(std::int64_t{1} << (s.length - 1));
    r.hi = s.length >= 64 ? INT64_MAX : (std::int64_t{1} << (s.length - 1)) - 1;
  } else {
    r.lo = 0;
    r.hi = s.length >= 63 ? INT64_MAX : (std::int64_t{1} << s.length) - 1;
  }
  if (!s.has_range() || s.value_type != SignalValueType::kInteger) return r;
  double a = (s.min - s.offset) / s.factor, b = (s.max - s.offset) / s.factor;
  if (a > b) std::swap(a, b);  // a negative factor
  // the comparisons keep every conversion defined: beyond +-9e18 the bits' range stands
  if (a > -9e18 && a < 9e18) r.lo = std::max(r.lo, static_cast<std::int64_t>(std::llround(a)));
  if (b > -9e18 && b < 9e18) r.hi = std::min(r.hi, static_cast<std::int64_t>(std::llround(b)));
  return r;
}

std::uint64_t encode_codec_rule(const DbcSignal& s, const RawRange& range, double v, bool& saturated) {
  if (s.value_type != SignalValueType::kInteger) {
    if (!std::isfinite(v) || (s.has_range() && (v < s.min || v > s.max))) saturated = true;
    return physical_to_raw(s, v);
  }
  std::int64_t r = 0;
  if (std::isnan(v)) {
    saturated = true;
    r = std::clamp<std::int64_t>(0, range.lo, range.hi);
  } else {
    if (s.has_range() && v < s.min) {
      v = s.min;
      saturated = true;
    } else if (s.has_range() && v > s.max) {
      v = s.max;
      saturated = true;
    }
    const double scaled = (v - s.offset) / s.factor;
    if (!(scaled >= static_cast<double>(range.lo) - 0.5)) {  // NaN-safe; also -inf without a range
      r = range.lo;  // the bits cannot hold it (a DBC range wider than its bits, or none)
      saturated = true;
    } else if (!(scaled <= static_cast<double>(range.hi) + 0.5)) {
      r = range.hi;
      saturated = true;
    } else {
      r = std::clamp(static_cast<std::int64_t>(std::llround(scaled)), range.lo, range.hi);
    }
  }
  return static_cast<std::uint64_t>(r) & raw_mask(s.length);
}

}  // namespace ehpt::io::can
