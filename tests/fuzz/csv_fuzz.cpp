// SPDX-License-Identifier: BSD-3-Clause
// Fuzz harness for io::read_csv_table: the input bytes are a CSV file.
// Any bytes must give an answer (true, or false with messages), never a crash, a hang or an
// exception: the call is made without try/catch so that an escaping exception is a finding.
// Built with libFuzzer under clang (tools/fuzz.sh), else with standalone_main.cpp (ctest smoke).

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "fuzz_checks.hpp"
#include "io/csv_table.hpp"

namespace {

namespace fs = std::filesystem;

// The loader takes a path, so every input goes through a file. One folder per process, so that
// parallel fuzzing jobs never read each other's inputs; removed at exit (after a crash it stays,
// in the system temp folder only).
class TempFolder {
 public:
  TempFolder() {
    const std::string base = "ehpt_fuzz_csv_" + std::to_string(::getpid());
    // a folder left by an earlier process with the same pid is not ours: never reuse or remove it
    for (int n = 0;; ++n) {
      path_ = fs::temp_directory_path() / (n == 0 ? base : base + "_" + std::to_string(n));
      if (fs::create_directory(path_)) break;
    }
  }
  ~TempFolder() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

void write_file(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) {
    // a harness that cannot write its input tests nothing: stop loudly, not silently
    std::fprintf(stderr, "csv_fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
}

void report(bool ok, const std::vector<std::string>& errors) { ehpt::fuzz::report("csv_fuzz", ok, errors); }
void require(bool condition, const char* what) { ehpt::fuzz::require("csv_fuzz", condition, what); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const TempFolder folder;
  static const std::string path = folder.file("input.csv");
  write_file(path, data, size);

  ehpt::io::CsvTable table;
  std::vector<std::string> errors;
  const bool ok = ehpt::io::read_csv_table(path, table, errors);
  report(ok, errors);

  require(ok == errors.empty(), "returns true exactly when it reports no problem");
  require(table.columns.size() == table.header.size(), "one column per header field");
  for (const auto& column : table.columns) {
    require(column.size() == table.rows(), "every column has one value per row");
  }
  if (ok) require(table.rows() > 0, "an accepted table has data rows");
  for (std::size_t r = 1; r < table.lines.size(); ++r) {
    require(table.lines[r] > table.lines[r - 1], "row line numbers increase");
  }
  return 0;
}
