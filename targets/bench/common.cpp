// SPDX-License-Identifier: BSD-3-Clause
// The bench's shared helpers (common.hpp).
#include "targets/bench/common.hpp"

namespace ehpt::bench {

std::atomic<int> g_stop{0};

bool stopping() { return g_stop.load() != 0; }

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void sleep_s(double s) {
  timespec ts{static_cast<time_t>(s), static_cast<long>((s - std::floor(s)) * 1e9)};
  ::nanosleep(&ts, nullptr);  // a signal cuts it short: the callers look at g_stop
}

bool write_stdout(const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(STDOUT_FILENO, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      std::fprintf(stderr, "error: cannot write to standard output: %s\n", n < 0 ? std::strerror(errno) : "no progress");
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

std::string fmt(const char* f, double v) {
  if (!std::isfinite(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

std::string read_small_file(const std::string& path) {
  std::string text, reason;
  if (!ehpt::io::read_text_file(path, text, reason, 16u << 20)) return "";
  return text;
}

// The last non-empty line of a text file (a child's stderr), at most 300 characters.
std::string last_line(const std::string& path) {
  std::istringstream in(read_small_file(path));
  std::string line, last;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  }
  if (last.size() > 300) last = last.substr(0, 300) + "...";
  return last;
}

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
  return s;
}


// a.b.c through nested objects; nullptr if a part is missing
const Json* json_at(const Json& j, std::string_view path) {
  const Json* v = &j;
  while (v != nullptr && !path.empty()) {
    const auto dot = path.find('.');
    v = v->find(path.substr(0, dot));
    path = dot == std::string_view::npos ? std::string_view() : path.substr(dot + 1);
  }
  return v;
}

// The number at path, NaN if it is missing or not a number.
double json_num(const Json& j, std::string_view path) {
  const Json* v = json_at(j, path);
  double x = NAN;
  return v != nullptr && v->kind == Json::Kind::kNumber && ehpt::io::parse_number(v->text, x) ? x : NAN;
}

std::string json_str(const Json& j, std::string_view path) {
  const Json* v = json_at(j, path);
  return v != nullptr && v->kind == Json::Kind::kString ? v->text : std::string();
}

bool read_json(const std::string& path, Json& out) {
  const std::string text = read_small_file(path);
  std::string error;
  return !text.empty() && ehpt::io::parse_json(text, out, error);
}

// Loads a scenario with overrides; "" or every problem on one line.
std::string load(const std::string& name, const std::vector<std::string>& sets, ehpt::hil::Scenario& sc) {
  std::string reason;
  const std::string path = ehpt::hil::resolve_scenario(name, reason);
  if (path.empty()) return name + ": " + reason;
  std::vector<std::string> errors;
  if (!ehpt::hil::load_scenario(path, sets, sc, errors)) {
    std::string s;
    for (const auto& e : errors) s += (s.empty() ? "" : "; ") + e;
    return s;
  }
  return "";
}


Spread spread(std::vector<double> v) {
  Spread s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  s.median = n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  s.min = v.front();
  s.max = v.back();
  return s;
}

ehpt::io::JsonObject spread_json(const Spread& s) {
  ehpt::io::JsonObject j;
  j.number("median", s.median);
  j.number("min", s.min);
  j.number("max", s.max);
  return j;
}

// A fixed-width table; align holds one letter per column: 'l' left, 'r' right.
std::string table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows,
                  const std::string& align) {
  std::vector<std::size_t> w(header.size(), 0);
  for (std::size_t c = 0; c < header.size(); ++c) w[c] = header[c].size();
  for (const auto& r : rows) {
    for (std::size_t c = 0; c < r.size() && c < w.size(); ++c) w[c] = std::max(w[c], r[c].size());
  }
  const auto line = [&](const std::vector<std::string>& r) {
    std::string s;
    for (std::size_t c = 0; c < w.size(); ++c) {
      const std::string cell = c < r.size() ? r[c] : "";
      const std::string pad(w[c] - std::min(w[c], cell.size()), ' ');
      s += (c ? "  " : "") + (c < align.size() && align[c] == 'l' ? cell + pad : pad + cell);
    }
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s + "\n";
  };
  std::string s = line(header);
  for (const auto& r : rows) s += line(r);
  return s;
}

double rel_pct(std::optional<double> a, std::optional<double> b) {
  if (!a || !b || *b == 0.0) return NAN;
  return 100.0 * (*a - *b) / std::abs(*b);
}

}  // namespace ehpt::bench
