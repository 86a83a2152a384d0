// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Reading input files at start-up without surprises: only regular files (a FIFO, a device
// such as /dev/zero or a folder is refused before it is read, so the loader cannot hang),
// and only up to a size bound (a huge file is refused instead of exhausting memory).

#include <cstddef>
#include <string>
#include <string_view>

namespace ehpt::io {

// Input files (scenarios, vehicles, cycles, maps) are small; 64 MiB is ~100x the largest
// cycle shipped and still loads in well under a second.
inline constexpr std::size_t kMaxInputFileBytes = 64u << 20;

// Reads the whole file into out. On failure returns false and sets reason to a short
// phrase without the path ("no such file", "is a FIFO, not a regular file", ...).
bool read_text_file(const std::string& path, std::string& out, std::string& reason,
                    std::size_t max_bytes = kMaxInputFileBytes);

// What a path is, for messages: "a folder", "a FIFO", "a device", "missing", "a file", ...
std::string describe_path(const std::string& path);

// Writes a new file with plain write(2), so that a failure says why (disk full, ...).
class TextFileWriter {
 public:
  TextFileWriter() = default;
  ~TextFileWriter();
  TextFileWriter(const TextFileWriter&) = delete;
  TextFileWriter& operator=(const TextFileWriter&) = delete;
  bool open(const std::string& path, std::string& error);  // O_EXCL: never an existing file
  // instead of open: every write succeeds and goes nowhere (a run that keeps its summary only)
  void discard() { discard_ = true; }
  bool write(std::string_view text, std::string& error);
  bool close(std::string& error);

 private:
  std::string path_;
  int fd_ = -1;
  bool discard_ = false;
};

}  // namespace ehpt::io
