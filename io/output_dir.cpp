#include "io/output_dir.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "io/number_format.hpp"

namespace fs = std::filesystem;

namespace ehpt::io {

namespace {
// Empty, or written by an earlier run: the only folders commit() may replace.
bool replaceable(const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return true;
  if (!fs::is_directory(dir, ec)) return false;
  if (fs::is_empty(dir, ec)) return true;
  return fs::exists(dir + "/summary.json", ec) || fs::exists(dir + "/timeseries.csv", ec);
}
}  // namespace

bool OutputDir::open(const std::string& final_dir, std::string& error) {
  final_ = final_dir;
  while (final_.size() > 1 && final_.back() == '/') final_.pop_back();
  partial_ = final_ + ".partial";
  if (!replaceable(final_)) {
    error = final_ + ": exists and is not an ehpt output folder (no summary.json or timeseries.csv); "
                     "choose another --out, nothing was run";
    return false;
  }
  std::error_code ec;
  fs::remove_all(partial_, ec);
  fs::create_directories(partial_, ec);
  if (ec) {
    error = partial_ + ": cannot create output folder: " + ec.message();
    return false;
  }
  return true;
}

bool OutputDir::commit(std::string& error) {
  std::error_code ec;
  const std::string old = final_ + ".replaced";
  fs::remove_all(old, ec);
  if (!replaceable(final_)) {
    error = final_ + ": appeared during the run and is not an ehpt output folder; results kept in " + partial_;
    return false;
  }
  if (fs::exists(final_)) {
    fs::rename(final_, old, ec);
    if (ec) {
      error = final_ + ": cannot move the previous output aside: " + ec.message() + " (results kept in " +
              partial_ + ")";
      return false;
    }
  }
  fs::rename(partial_, final_, ec);
  if (ec) {
    error = final_ + ": cannot rename " + partial_ + ": " + ec.message() + " (results kept there)";
    return false;
  }
  fs::remove_all(old, ec);
  return true;
}

std::string json_escape(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
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
        } else {
          out += c;
        }
    }
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

std::string JsonObject::str(int indent) const {
  const std::string pad(static_cast<std::size_t>(indent) + 2, ' ');
  std::string out = "{\n";
  for (std::size_t i = 0; i < items_.size(); ++i) {
    out += pad + json_escape(items_[i].first) + ": " + items_[i].second;
    out += i + 1 < items_.size() ? ",\n" : "\n";
  }
  return out + std::string(static_cast<std::size_t>(indent), ' ') + "}";
}

bool write_file_atomically(const std::string& path, const std::string& content, std::string& error) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    out << content;
    out.flush();
    if (!out) {
      error = tmp + ": write failed";
      return false;
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    error = path + ": rename failed: " + ec.message();
    return false;
  }
  return true;
}

}  // namespace ehpt::io
