// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Numeric CSV tables with a header row, as in data/ (cycles, maps). Start-up only.
// Blank lines and lines starting with '#' are skipped; a UTF-8 byte-order mark is ignored;
// fields may be quoted ("1.5", as spreadsheets write them; "" is a quote inside one).
// Every problem is reported as 'file:line: column NAME: "text" is not a number' and
// reading goes on, so a user sees all of them at once.

#include <string>
#include <vector>

namespace ehpt::io {

struct CsvTable {
  std::string path;
  std::vector<std::string> header;
  std::vector<std::vector<double>> columns;      // columns[c][row]
  std::vector<std::vector<std::string>> text;    // text[c][row]: the field as written (for messages)
  std::vector<int> lines;                        // file line of each row (1-based)
  int header_line = 1;

  int column_index(const std::string& name) const;  // -1 if absent
  std::size_t rows() const { return lines.size(); }
};

// Parses CSV text read from path (path only names the file in messages). Returns false and
// appends messages to errors when it is empty or malformed. numbers = false: the fields are
// kept as text only (CsvTable::text; columns stay empty), e.g. a sweep's list of variants.
bool parse_csv_table(const std::string& path, const std::string& content, CsvTable& out,
                     std::vector<std::string>& errors, bool numbers = true);

// Reads (io::read_text_file: regular files only, size bounded) and parses the file.
bool read_csv_table(const std::string& path, CsvTable& out, std::vector<std::string>& errors, bool numbers = true);

}  // namespace ehpt::io
