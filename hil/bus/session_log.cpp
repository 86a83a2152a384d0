// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/session_log.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>

#include "io/number_format.hpp"
#include "io/sha256.hpp"

namespace ehpt::hil {

namespace {

// One command line: "FAMILY STEP SEQUENCE STAMP_STEP" and the values (each the shortest text
// that reads back to its double: a replay gets the same bits), and the flag if the family has
// one (-1: none). The length; -1 if the buffer could not hold the longest such line.
int format_line(char* buf, std::size_t size, std::string_view family, std::int64_t step, const msgs::Stamp& stamp,
                std::initializer_list<double> values, int flag) {
  // family, three integers of at most 20 characters and 25 per value, with their spaces
  if (size < family.size() + 3 * 21 + 25 * (values.size() + 1) + 3) return -1;
  char* p = std::copy(family.begin(), family.end(), buf);
  *p++ = ' ';
  p = io::put_int(p, step);
  *p++ = ' ';
  p = io::put_uint(p, stamp.sequence);
  *p++ = ' ';
  p = io::put_int(p, stamp.step);
  *p++ = ' ';
  p = io::put_number(p, stamp.time_s);
  for (const double v : values) {
    *p++ = ' ';
    p = io::put_number(p, v);
  }
  if (flag >= 0) {
    *p++ = ' ';
    *p++ = static_cast<char>('0' + flag);
  }
  *p = '\0';
  return static_cast<int>(p - buf);
}

}  // namespace

int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::EvCommand& c) {
  return format_line(buf, size, "ev", step, c.stamp, {c.driveTauRef_Nm}, -1);
}

int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::PsdCommand& c) {
  return format_line(buf, size, "psd", step, c.stamp, {c.icePowRef_W, c.iceTauRef_Nm, c.genTauRef_Nm, c.motTauRef_Nm},
                     c.iceON ? 1 : 0);
}

int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::ShevCommand& c) {
  return format_line(buf, size, "shev", step, c.stamp, {c.driveTauRef_Nm, c.gensetPowRef_W}, c.gensetON ? 1 : 0);
}

std::string inputs_log_header(const std::string& scenario_path, const std::vector<std::string>& overrides,
                              const std::vector<std::string>& faults, const char* family, const char* pacing) {
  std::string h = "# ehpt inputs log 1\n# scenario " + scenario_path + "\n";
  for (const std::string& o : overrides) h += "# set " + o + "\n";
  for (const std::string& f : faults) h += "# fault " + f + "\n";
  h += std::string("# family ") + family + "\n# pacing " + pacing + "\n";
  return h;
}

namespace {

// How many values (time_s first) a command line of a family has, and which of them is an
// on/off flag (0 or 1); 0 values: not a family with bus messages.
struct FamilyLine {
  std::size_t values = 0;
  std::size_t flag = 0;  // 0: none (values[0] is the time)
};
FamilyLine family_line(std::string_view family) {
  if (family == "ev") return {2, 0};
  if (family == "psd") return {6, 5};
  if (family == "shev") return {4, 3};
  return {};
}

// The next whitespace-separated token of `rest` (advanced past it); empty at the end.
std::string_view next_token(std::string_view& rest) {
  std::size_t i = 0;
  while (i < rest.size() && (rest[i] == ' ' || rest[i] == '\t')) ++i;
  std::size_t j = i;
  while (j < rest.size() && rest[j] != ' ' && rest[j] != '\t') ++j;
  const std::string_view tok = rest.substr(i, j - i);
  rest.remove_prefix(j);
  return tok;
}

// A token as a C string for strtoll/strtod (a token this long is no number of ours).
bool c_token(std::string_view tok, std::array<char, 64>& buf) {
  if (tok.empty() || tok.size() >= buf.size()) return false;
  tok.copy(buf.data(), tok.size());
  buf[tok.size()] = '\0';
  return true;
}

bool parse_integer(std::string_view tok, long long lo, long long hi, long long& v) {
  std::array<char, 64> buf{};
  if (!c_token(tok, buf)) return false;
  char* end = nullptr;
  errno = 0;
  v = std::strtoll(buf.data(), &end, 10);
  return end != buf.data() && *end == '\0' && errno != ERANGE && v >= lo && v <= hi;
}

// exact for the 17 digits written; inf and nan refused
bool parse_finite(std::string_view tok, double& v) {
  std::array<char, 64> buf{};
  if (!c_token(tok, buf)) return false;
  char* end = nullptr;
  errno = 0;
  v = std::strtod(buf.data(), &end);
  return end != buf.data() && *end == '\0' && errno != ERANGE && std::isfinite(v);
}

}  // namespace

bool parse_inputs_line(std::string_view line, InputsLogLine& out, std::string& why) {
  std::string_view rest = line;
  out.family = next_token(rest);
  long long step = 0, sequence = 0, stamp_step = 0;
  const std::string_view t_step = next_token(rest), t_seq = next_token(rest), t_stamp = next_token(rest);
  if (!parse_integer(t_step, 0, std::numeric_limits<std::int64_t>::max(), step) ||
      !parse_integer(t_seq, 0, std::numeric_limits<std::uint32_t>::max(), sequence) ||
      !parse_integer(t_stamp, std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::max(),
                     stamp_step)) {
    why = "expected FAMILY STEP SEQUENCE STAMP_STEP (STEP >= 0, SEQUENCE 0..4294967295) and numbers";
    return false;
  }
  out.step = step;
  out.sequence = static_cast<std::uint32_t>(sequence);  // range checked above
  out.stamp_step = stamp_step;
  out.n_values = 0;
  for (std::string_view tok = next_token(rest); !tok.empty(); tok = next_token(rest)) {
    double v = 0.0;
    if (!parse_finite(tok, v)) {
      why = "'" + std::string(tok.substr(0, 40)) + (tok.size() > 40 ? "...'" : "'") + " is not a finite number";
      return false;
    }
    if (out.n_values == out.values.size()) {
      why = "more than " + std::to_string(out.values.size() + 4) + " fields";
      return false;
    }
    out.values[out.n_values++] = v;
  }
  return true;
}

// A file as lines, in fixed memory: one block of it and one line at a time. Every byte read
// goes through the SHA-256, so the digest is the file's (sha256sum's), whatever its lines.
struct InputsLogLines {
  std::FILE* f = nullptr;
  std::array<char, 65536> block{};
  std::size_t block_len = 0, block_pos = 0;
  std::array<char, kMaxInputsLineBytes> line{};
  std::size_t line_len = 0;
  bool too_long = false;  // the current line is longer than kMaxInputsLineBytes (the rest skipped)
  int line_no = 0;
  std::uint64_t bytes = 0;
  io::Sha256 sha;
  bool read_error = false;

  std::string open_error;  // why f is null

  // A regular file only, opened without blocking (a FIFO with no writer would hang the replay
  // here), as io/text_file.cpp opens input files.
  explicit InputsLogLines(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    struct stat st {};
    if (fd < 0) {
      open_error = errno == ENOENT ? "no such file" : std::strerror(errno);
    } else if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
      open_error = "not a regular file";
    } else if ((f = ::fdopen(fd, "rb")) == nullptr) {
      open_error = std::strerror(errno);
    }
    if (f == nullptr && fd >= 0) ::close(fd);
  }
  ~InputsLogLines() {
    if (f != nullptr) std::fclose(f);
  }
  InputsLogLines(const InputsLogLines&) = delete;
  InputsLogLines& operator=(const InputsLogLines&) = delete;

  std::string_view text() const { return {line.data(), line_len}; }

  // The next line (without '\n', nor a '\r' before it: a CRLF log); false at the end.
  bool next() {
    line_len = 0;
    too_long = false;
    bool any = false;
    for (;;) {
      if (block_pos == block_len) {
        block_len = std::fread(block.data(), 1, block.size(), f);
        block_pos = 0;
        if (block_len == 0) {
          read_error = std::ferror(f) != 0;
          if (!any) return false;
          break;  // a last line without '\n'
        }
        bytes += block_len;
        sha.update(std::string_view(block.data(), block_len));
      }
      any = true;
      const char ch = block[block_pos++];
      if (ch == '\n') break;
      if (line_len < line.size()) {
        line[line_len++] = ch;
      } else {
        too_long = true;
      }
    }
    if (!too_long && line_len > 0 && line[line_len - 1] == '\r') --line_len;
    ++line_no;
    return true;
  }
};

bool read_inputs_log(const std::string& path, InputsLog& out, std::vector<std::string>& problems) {
  InputsLogLines lines(path);
  if (lines.f == nullptr) {
    problems.push_back(path + ": cannot read (" + lines.open_error + ")");
    return false;
  }
  std::int64_t last_step = 0;
  bool version = false, commands_seen = false;
  const auto bad = [&](const std::string& what) {
    if (problems.size() < 20) problems.push_back(path + ":" + std::to_string(lines.line_no) + ": " + what);
  };
  std::string why;
  InputsLogLine l;
  while (lines.next()) {
    if (lines.too_long) {
      bad("a line longer than " + std::to_string(kMaxInputsLineBytes) + " bytes");
      continue;
    }
    const std::string_view line = lines.text();
    if (line.empty()) continue;
    if (line[0] == '#') {
      // "# KEY VALUE" -> VALUE
      const auto value = [&](std::string_view key) -> std::optional<std::string_view> {
        if (line.size() < key.size() + 3 || line.substr(0, 2) != "# " || line.substr(2, key.size()) != key ||
            line[2 + key.size()] != ' ') {
          return std::nullopt;
        }
        return line.substr(key.size() + 3);
      };
      // the header comes first and says each thing once: a later line must not change what
      // the commands above it were read as
      const auto header = [&](const char* key, std::string& field, std::string_view v) {
        if (commands_seen) {
          bad(std::string("'# ") + key + "' after the commands: the header comes before them");
        } else if (!field.empty()) {
          bad(std::string("a second '# ") + key + "' line (the first said '" + field + "')");
        } else {
          field = std::string(v);
        }
      };
      if (line == "# ehpt inputs log 1") {
        version = true;
      } else if (const auto v = value("scenario")) {
        header("scenario", out.scenario_path, *v);
      } else if (const auto v2 = value("set")) {
        if (commands_seen) {
          bad("'# set' after the commands: the header comes before them");
        } else {
          out.overrides.emplace_back(*v2);
        }
      } else if (const auto vf = value("fault")) {
        if (commands_seen) {
          bad("'# fault' after the commands: the header comes before them");
        } else {
          out.faults.emplace_back(*vf);
        }
      } else if (const auto v3 = value("family")) {
        header("family", out.family, *v3);
      } else if (const auto v4 = value("pacing")) {
        header("pacing", out.pacing, *v4);
      }
      continue;
    }
    commands_seen = true;
    if (!parse_inputs_line(line, l, why)) {
      bad(why);
      continue;
    }
    const FamilyLine fl = family_line(l.family);
    if (l.family != out.family || fl.values == 0) {
      bad("a command of family '" + std::string(l.family.substr(0, 40)) + "' (the log's family is '" + out.family +
          "')");
      continue;
    }
    const std::size_t want = fl.values;
    if (l.n_values != want) {
      bad("expected " + std::to_string(want + 4) + " fields");
      continue;
    }
    if (l.step < last_step) {
      bad("step " + std::to_string(l.step) + " before the previous command's " + std::to_string(last_step));
      continue;
    }
    if (fl.flag != 0 && l.values[fl.flag] != 0.0 && l.values[fl.flag] != 1.0) {
      bad(std::string(l.family == "psd" ? "iceON" : "gensetON") + " must be 0 or 1");
    }
    last_step = l.step;
    ++out.commands;
  }
  if (lines.read_error) problems.push_back(path + ": a read error after " + std::to_string(lines.bytes) + " bytes");
  out.file = InputFile{path, io::to_hex(lines.sha.finish()), static_cast<std::size_t>(lines.bytes)};
  if (!version) problems.insert(problems.begin(), path + ": not an ehpt inputs log (its first line is not '# ehpt inputs log 1')");
  if (out.scenario_path.empty() || out.family.empty()) {
    problems.push_back(path + ": the header lacks '# scenario' or '# family'");
  }
  return problems.empty();
}

InputsLogReader::InputsLogReader(const std::string& path, const InputsLog& validated)
    : path_(path), expected_(validated.file), family_(validated.family), lines_(std::make_unique<InputsLogLines>(path)) {
  if (lines_->f == nullptr) error_ = path + ": cannot open again (" + lines_->open_error + ")";
}

InputsLogReader::~InputsLogReader() = default;

bool InputsLogReader::next_line(InputsLogLine& l) {
  if (done_ || !error_.empty()) return false;
  std::string why;
  const auto changed = [&](const std::string& what) {
    error_ = path_ + ":" + std::to_string(lines_->line_no) + ": " + what +
             ": the log changed after it was checked (the replay is not the session's)";
    return false;
  };
  while (lines_->next()) {
    const std::string_view line = lines_->text();
    if (lines_->too_long) return changed("a line too long");
    if (line.empty() || line[0] == '#') continue;
    if (!parse_inputs_line(line, l, why)) return changed(why);
    if (l.family != family_ || l.n_values != family_line(family_).values || l.step < last_step_) {
      return changed("a command that does not follow the header and the one before it");
    }
    last_step_ = l.step;
    ++commands_;
    return true;
  }
  done_ = true;
  // compared without allocating (the end of the log may come inside the run's loop)
  const std::array<std::uint8_t, 32> d = lines_->sha.finish();
  std::array<char, 64> hex{};
  for (std::size_t i = 0; i < d.size(); ++i) {
    hex[2 * i] = "0123456789abcdef"[d[i] >> 4];
    hex[2 * i + 1] = "0123456789abcdef"[d[i] & 0xF];
  }
  const std::string_view digest(hex.data(), hex.size());
  if (lines_->read_error || lines_->bytes != expected_.bytes || digest != expected_.sha256) {
    error_ = path_ + ": its " + std::to_string(lines_->bytes) + " bytes (SHA-256 " + std::string(digest) +
             ") are not the ones checked before the run (" + std::to_string(expected_.bytes) +
             " bytes): the log changed while it was replayed";
  }
  return false;
}

bool InputsLogReader::next(std::int64_t& step, msgs::EvCommand& c) {
  InputsLogLine l;
  if (family_ != "ev" || !next_line(l)) return false;
  step = l.step;
  c = msgs::EvCommand{};
  c.stamp = msgs::Stamp{l.values[0], l.stamp_step, l.sequence};
  c.driveTauRef_Nm = l.values[1];
  return true;
}

bool InputsLogReader::next(std::int64_t& step, msgs::PsdCommand& c) {
  InputsLogLine l;
  if (family_ != "psd" || !next_line(l)) return false;
  step = l.step;
  c = msgs::PsdCommand{};
  c.stamp = msgs::Stamp{l.values[0], l.stamp_step, l.sequence};
  c.icePowRef_W = l.values[1];
  c.iceTauRef_Nm = l.values[2];
  c.genTauRef_Nm = l.values[3];
  c.motTauRef_Nm = l.values[4];
  c.iceON = l.values[5] != 0.0;
  return true;
}

bool InputsLogReader::next(std::int64_t& step, msgs::ShevCommand& c) {
  InputsLogLine l;
  if (family_ != "shev" || !next_line(l)) return false;
  step = l.step;
  c = msgs::ShevCommand{};
  c.stamp = msgs::Stamp{l.values[0], l.stamp_step, l.sequence};
  c.driveTauRef_Nm = l.values[1];
  c.gensetPowRef_W = l.values[2];
  c.gensetON = l.values[3] != 0.0;
  return true;
}

}  // namespace ehpt::hil
