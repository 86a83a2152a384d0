#pragma once
// An output folder that never looks complete before it is, and never touches what is not
// ours (README "--out"):
//  * a lock: open() takes an exclusive flock on "DIR.ehpt-lock" for the whole run, so a
//    second run with the same --out stops at once (exit 1) instead of mixing files;
//  * a private temporary folder "DIR.partial-<pid>" made with mkdir (never an existing
//    path), into which the run writes; commit() adds the manifest and renames it to DIR;
//  * a marker: "ehpt-manifest.txt" names every file the run wrote. An existing DIR is
//    replaced only if it is empty or an earlier run: it holds that manifest and nothing
//    the manifest does not list. Replacing deletes exactly the listed files.
// Nothing is removed that this process did not create (or, for an earlier run, that its
// manifest does not list). A crash leaves DIR.partial-<pid> with the data written so far;
// an exception (out of memory) removes it, since that run wrote nothing worth keeping.

#include <string>
#include <utility>
#include <vector>

namespace ehpt::io {

inline constexpr const char* kManifestName = "ehpt-manifest.txt";
inline constexpr const char* kManifestMagic = "ehpt output folder, version 1";

// True if dir is an earlier ehpt run that may be replaced. Otherwise why_not says why
// ("holds files ehpt did not write: notes.txt, src/"). files gets the listed names.
bool is_earlier_run(const std::string& dir, std::vector<std::string>& files, std::string& why_not);

// Adds names to dir's manifest (atomically; the manifest must exist).
bool add_to_manifest(const std::string& dir, const std::vector<std::string>& names, std::string& error);

class OutputDir {
 public:
  OutputDir() = default;
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;

  // Locks DIR, checks that it may be replaced, creates the private partial folder.
  bool open(const std::string& final_dir, std::string& error);
  std::string file(const std::string& name) const { return partial_ + "/" + name; }
  const std::string& final_dir() const { return final_; }
  const std::string& partial_dir() const { return partial_; }
  // Writes the manifest, moves an earlier run aside, renames the partial folder to DIR,
  // deletes the earlier run's listed files. On failure the results stay in partial_dir().
  bool commit(std::string& error);
  // Warnings from commit() that did not stop it (e.g. an earlier run's folder not empty).
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  void unlock();

  std::string final_, partial_, lock_path_;
  int lock_fd_ = -1;
  bool created_lock_ = false, created_partial_ = false, committed_ = false;
  int uncaught_at_open_ = 0;
  std::vector<std::string> warnings_;
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
  void strings(const std::string& key, const std::vector<std::string>& values);
  std::string str(int indent = 0) const;

 private:
  std::vector<std::pair<std::string, std::string>> items_;  // key, raw JSON text
};

std::string json_escape(const std::string& s);

// Writes content to path via a temporary name in the same folder and rename, so a reader
// never sees half a file. The temporary is made with O_EXCL (never an existing file).
bool write_file_atomically(const std::string& path, const std::string& content, std::string& error);

}  // namespace ehpt::io
