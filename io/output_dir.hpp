#pragma once
// An output folder that never looks complete before it is: files are written into
// "DIR.partial" and the folder is renamed to DIR only by commit(). A crash leaves DIR.partial
// (clearly unfinished, data written so far kept); an older DIR is replaced only at commit,
// and only if it is empty or an earlier run's output (it holds summary.json or
// timeseries.csv): open() refuses any other existing DIR, so --out can never wipe a folder
// of someone's files.

#include <string>
#include <utility>
#include <vector>

namespace ehpt::io {

class OutputDir {
 public:
  bool open(const std::string& final_dir, std::string& error);
  std::string file(const std::string& name) const { return partial_ + "/" + name; }
  const std::string& final_dir() const { return final_; }
  bool commit(std::string& error);

 private:
  std::string final_, partial_;
};

// Minimal ordered JSON object writer for summary.json (numbers exact, NaN as null).
class JsonObject {
 public:
  void number(const std::string& key, double value);
  void integer(const std::string& key, long long value);
  void text(const std::string& key, const std::string& value);
  void boolean(const std::string& key, bool value);
  void null(const std::string& key);
  void object(const std::string& key, const JsonObject& value);
  std::string str(int indent = 0) const;

 private:
  std::vector<std::pair<std::string, std::string>> items_;  // key, raw JSON text
};

std::string json_escape(const std::string& s);

// Writes content to path via path + ".tmp" and rename, so a reader never sees half a file.
bool write_file_atomically(const std::string& path, const std::string& content, std::string& error);

}  // namespace ehpt::io
