// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/session_log.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "io/sha256.hpp"
#include "io/text_file.hpp"

namespace ehpt::hil {

namespace {

// A session of hours at 100 commands per second is tens of MB: more than an input file.
constexpr std::size_t kMaxLogBytes = std::size_t{1} << 30;

}  // namespace

int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::EvCommand& c) {
  return std::snprintf(buf, size, "ev %lld %u %lld %.17g %.17g", static_cast<long long>(step), c.stamp.sequence,
                       static_cast<long long>(c.stamp.step), c.stamp.time_s, c.driveTauRef_Nm);
}

int format_command(char* buf, std::size_t size, std::int64_t step, const msgs::PsdCommand& c) {
  return std::snprintf(buf, size, "psd %lld %u %lld %.17g %.17g %.17g %.17g %.17g %d", static_cast<long long>(step),
                       c.stamp.sequence, static_cast<long long>(c.stamp.step), c.stamp.time_s, c.icePowRef_W,
                       c.iceTauRef_Nm, c.genTauRef_Nm, c.motTauRef_Nm, c.iceON ? 1 : 0);
}

std::string inputs_log_header(const std::string& scenario_path, const std::vector<std::string>& overrides,
                              const char* family, const char* pacing) {
  std::string h = "# ehpt inputs log 1\n# scenario " + scenario_path + "\n";
  for (const std::string& o : overrides) h += "# set " + o + "\n";
  h += std::string("# family ") + family + "\n# pacing " + pacing + "\n";
  return h;
}

bool read_inputs_log(const std::string& path, InputsLog& out, std::vector<std::string>& problems) {
  std::string text, reason;
  if (!io::read_text_file(path, text, reason, kMaxLogBytes)) {
    problems.push_back(path + ": " + reason);
    return false;
  }
  out.file = InputFile{path, io::sha256_hex(text), text.size()};
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  std::int64_t last_step = 0;
  bool version = false;
  const auto bad = [&](const std::string& what) {
    if (problems.size() < 20) problems.push_back(path + ":" + std::to_string(line_no) + ": " + what);
  };
  bool commands_seen = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();  // a log saved with CRLF line ends
    if (line.empty()) continue;
    if (line[0] == '#') {
      const auto value = [&](const char* key) -> const char* {
        const std::string k = std::string("# ") + key + " ";
        return line.rfind(k, 0) == 0 ? line.c_str() + k.size() : nullptr;
      };
      // the header comes first and says each thing once: a later line must not change what
      // the commands above it were read as
      const auto header = [&](const char* key, std::string& field, const char* v) {
        if (commands_seen) {
          bad(std::string("'# ") + key + "' after the commands: the header comes before them");
        } else if (!field.empty()) {
          bad(std::string("a second '# ") + key + "' line (the first said '" + field + "')");
        } else {
          field = v;
        }
      };
      if (line == "# ehpt inputs log 1") {
        version = true;
      } else if (const char* v = value("scenario")) {
        header("scenario", out.scenario_path, v);
      } else if (const char* v2 = value("set")) {
        if (commands_seen) {
          bad("'# set' after the commands: the header comes before them");
        } else {
          out.overrides.emplace_back(v2);
        }
      } else if (const char* v3 = value("family")) {
        header("family", out.family, v3);
      } else if (const char* v4 = value("pacing")) {
        header("pacing", out.pacing, v4);
      }
      continue;
    }
    commands_seen = true;
    std::istringstream f(line);
    std::string kind;
    long long step = 0, stamp_step = 0;
    unsigned sequence = 0;
    f >> kind >> step >> sequence >> stamp_step;
    if (f.fail()) {
      bad("expected FAMILY STEP SEQUENCE STAMP_STEP and numbers");
      continue;
    }
    // numbers through strtod: exact for the 17 digits written (and inf/nan are refused)
    std::vector<double> values;
    for (std::string tok; f >> tok;) {
      char* end = nullptr;
      errno = 0;
      const double v = std::strtod(tok.c_str(), &end);
      if (end == tok.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v)) {
        values.clear();
        bad("'" + tok + "' is not a finite number");
        break;
      }
      values.push_back(v);
    }
    if (kind != out.family || (kind != "ev" && kind != "psd")) {
      bad("a command of family '" + kind + "' (the log's family is '" + out.family + "')");
      continue;
    }
    const std::size_t want = kind == "ev" ? 2 : 6;
    if (values.size() != want || step < last_step || step < 0) {
      bad(values.size() != want ? "expected " + std::to_string(want + 4) + " fields"
                                : "step " + std::to_string(step) + " before the previous command's " + std::to_string(last_step));
      continue;
    }
    last_step = step;
    msgs::Stamp stamp{values[0], stamp_step, sequence};
    if (kind == "ev") {
      msgs::EvCommand c;
      c.stamp = stamp;
      c.driveTauRef_Nm = values[1];
      out.ev.push_back({step, c});
    } else {
      msgs::PsdCommand c;
      c.stamp = stamp;
      c.icePowRef_W = values[1];
      c.iceTauRef_Nm = values[2];
      c.genTauRef_Nm = values[3];
      c.motTauRef_Nm = values[4];
      if (values[5] != 0.0 && values[5] != 1.0) bad("iceON must be 0 or 1");
      c.iceON = values[5] != 0.0;
      out.psd.push_back({step, c});
    }
  }
  if (!version) problems.insert(problems.begin(), path + ": not an ehpt inputs log (its first line is not '# ehpt inputs log 1')");
  if (out.scenario_path.empty() || out.family.empty()) {
    problems.push_back(path + ": the header lacks '# scenario' or '# family'");
  }
  return problems.empty();
}

}  // namespace ehpt::hil
