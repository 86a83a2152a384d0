#include "io/csv_table.hpp"

#include <fstream>
#include <sstream>

#include "io/number_format.hpp"

namespace ehpt::io {

namespace {
std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}
std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '"')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r' || s[e - 1] == '"')) --e;
  return s.substr(b, e - b);
}
}  // namespace

int CsvTable::column_index(const std::string& name) const {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<int>(i);
  }
  return -1;
}

bool read_csv_table(const std::string& path, CsvTable& out, std::vector<std::string>& errors) {
  out = CsvTable{};
  out.path = path;
  std::ifstream in(path);
  if (!in) {
    errors.push_back(path + ": cannot open file (missing or unreadable)");
    return false;
  }
  const std::size_t errors_before = errors.size();
  std::string line;
  int line_no = 0;
  bool have_header = false;
  while (std::getline(in, line)) {
    ++line_no;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const std::vector<std::string> fields = split(line);
    if (!have_header) {
      for (const auto& f : fields) out.header.push_back(trim(f));
      out.columns.resize(out.header.size());
      have_header = true;
      continue;
    }
    if (fields.size() != out.header.size()) {
      errors.push_back(path + ":" + std::to_string(line_no) + ": " + std::to_string(fields.size()) +
                       " fields, expected " + std::to_string(out.header.size()) + " as in the header");
      continue;
    }
    bool row_ok = true;
    std::vector<double> row(fields.size());
    for (std::size_t c = 0; c < fields.size(); ++c) {
      if (!parse_number(fields[c], row[c])) {
        errors.push_back(path + ":" + std::to_string(line_no) + ": column " + out.header[c] + ": \"" +
                         trim(fields[c]) + "\" is not a number");
        row_ok = false;
      }
    }
    if (!row_ok) continue;
    for (std::size_t c = 0; c < row.size(); ++c) out.columns[c].push_back(row[c]);
    out.lines.push_back(line_no);
  }
  if (!have_header) {
    errors.push_back(path + ": empty file (expected a header row and data rows)");
  } else if (out.rows() == 0 && errors.size() == errors_before) {
    errors.push_back(path + ": no data rows after the header");
  }
  return errors.size() == errors_before;
}

}  // namespace ehpt::io
