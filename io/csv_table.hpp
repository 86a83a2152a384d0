#pragma once
// Numeric CSV tables with a header row, as in data/ (cycles, maps). Start-up only.
// Blank lines and lines starting with '#' are skipped. Every problem is reported as
// "file:line: column NAME: "text" is not a number" and reading goes on, so a user sees
// all of them at once.

#include <string>
#include <vector>

namespace ehpt::io {

struct CsvTable {
  std::string path;
  std::vector<std::string> header;
  std::vector<std::vector<double>> columns;  // columns[c][row]
  std::vector<int> lines;                     // file line of each row (1-based)

  int column_index(const std::string& name) const;  // -1 if absent
  std::size_t rows() const { return lines.size(); }
};

// Returns false and appends messages to errors when the file is missing, empty or malformed.
bool read_csv_table(const std::string& path, CsvTable& out, std::vector<std::string>& errors);

}  // namespace ehpt::io
