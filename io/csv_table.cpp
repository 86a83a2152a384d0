// SPDX-License-Identifier: BSD-3-Clause
#include "io/csv_table.hpp"

#include "io/number_format.hpp"
#include "io/text_file.hpp"

namespace ehpt::io {

namespace {

bool blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && blank(s[b])) ++b;
  while (e > b && blank(s[e - 1])) --e;
  return s.substr(b, e - b);
}

// One line into fields (RFC 4180 quoting within the line). False if a quote is not closed.
bool split(const std::string& line, std::vector<std::string>& fields) {
  fields.clear();
  std::size_t i = 0;
  for (;;) {
    std::string field;
    while (i < line.size() && blank(line[i])) ++i;
    if (i < line.size() && line[i] == '"') {
      ++i;
      bool closed = false;
      while (i < line.size()) {
        if (line[i] == '"') {
          if (i + 1 < line.size() && line[i + 1] == '"') {
            field += '"';
            i += 2;
            continue;
          }
          ++i;
          closed = true;
          break;
        }
        field += line[i++];
      }
      if (!closed) return false;
      // anything but blanks between the closing quote and the comma is kept, to be reported
      const std::size_t comma = line.find(',', i);
      const std::string rest = trim(line.substr(i, comma == std::string::npos ? std::string::npos : comma - i));
      if (!rest.empty()) field = "\"" + field + "\"" + rest;
      i = comma == std::string::npos ? line.size() : comma;
    } else {
      const std::size_t comma = line.find(',', i);
      field = trim(line.substr(i, comma == std::string::npos ? std::string::npos : comma - i));
      i = comma == std::string::npos ? line.size() : comma;
    }
    fields.push_back(std::move(field));
    if (i >= line.size()) return true;
    ++i;  // past the comma: a trailing comma gives one more, empty, field
  }
}

}  // namespace

int CsvTable::column_index(const std::string& name) const {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<int>(i);
  }
  return -1;
}

bool parse_csv_table(const std::string& path, const std::string& content, CsvTable& out,
                     std::vector<std::string>& errors, bool numbers) {
  out = CsvTable{};
  out.path = path;
  const std::size_t errors_before = errors.size();
  // a file of garbage would give a message per line: list the first ones, count the rest
  constexpr std::size_t kMaxMessages = 20;
  std::size_t problems = 0;
  const auto report = [&](std::string message) {
    if (++problems <= kMaxMessages) errors.push_back(std::move(message));
  };
  std::size_t at = content.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;  // UTF-8 byte-order mark
  int line_no = 0;
  bool have_header = false;
  std::vector<std::string> fields;
  std::vector<double> row;
  while (at < content.size()) {
    std::size_t end = content.find('\n', at);
    if (end == std::string::npos) end = content.size();
    const std::string line = content.substr(at, end - at);
    at = end + 1;
    ++line_no;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (t.find('\0') != std::string::npos) {
      report(where + "a NUL byte: this is not a text file");
      break;
    }
    if (!split(line, fields)) {
      report(where + "a quote is opened and not closed");
      continue;
    }
    if (!have_header) {
      out.header = fields;
      out.header_line = line_no;
      out.columns.resize(out.header.size());
      out.text.resize(out.header.size());
      have_header = true;
      continue;
    }
    if (fields.size() != out.header.size()) {
      report(where + std::to_string(fields.size()) + " fields, expected " +
                       std::to_string(out.header.size()) + " as in the header");
      continue;
    }
    bool row_ok = true;
    row.assign(fields.size(), 0.0);
    for (std::size_t c = 0; c < fields.size() && numbers; ++c) {
      if (!parse_number(fields[c], row[c])) {
        report(where + "column " + out.header[c] + ": \"" + fields[c] + "\" is not a number");
        row_ok = false;
      }
    }
    if (!row_ok) continue;
    for (std::size_t c = 0; c < row.size(); ++c) {
      if (numbers) out.columns[c].push_back(row[c]);
      out.text[c].push_back(fields[c]);
    }
    out.lines.push_back(line_no);
  }
  if (problems > kMaxMessages) {
    errors.push_back(path + ": " + std::to_string(problems - kMaxMessages) + " more problems in this file");
  }
  if (!have_header) {
    errors.push_back(path + ": empty file (expected a header row and data rows)");
  } else if (out.rows() == 0 && errors.size() == errors_before) {
    errors.push_back(path + ": no data rows after the header");
  }
  return errors.size() == errors_before;
}

bool read_csv_table(const std::string& path, CsvTable& out, std::vector<std::string>& errors, bool numbers) {
  std::string content, reason;
  if (!read_text_file(path, content, reason)) {
    out = CsvTable{};
    errors.push_back(path + ": cannot read: " + reason);
    return false;
  }
  return parse_csv_table(path, content, out, errors, numbers);
}

}  // namespace ehpt::io
