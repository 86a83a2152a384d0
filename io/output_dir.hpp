// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// An output folder that never looks complete before it is, and never touches what is not
// ours (README "--out"):
//  * a lock (DirLock): open() takes an exclusive flock on "DIR.ehpt-lock" for the whole run
//    (for a DIR name near 255 bytes: the name cut short and a hash of it, see beside()),
//    so a second run with the same --out, or `ehpt plot DIR`, stops at once (exit 1)
//    instead of mixing files;
//  * a private temporary folder "DIR.partial-<pid>" made with mkdir (never an existing
//    path), into which the run writes; commit() adds the manifest and renames it to DIR;
//  * a marker: "ehpt-manifest.txt" names every file the run wrote. An existing DIR is
//    replaced only if it is empty or an earlier run: it holds that manifest and nothing
//    the manifest does not list. Replacing deletes exactly the listed files, through a
//    descriptor of the folder that was checked (if DIR is swapped meanwhile, nothing is
//    deleted).
// Nothing is removed that this process did not create (or, for an earlier run, that its
// manifest does not list). A crash leaves DIR.partial-<pid> with the data written so far;
// an exception (out of memory) removes it, since that run wrote nothing worth keeping.

#include <string>
#include <utility>
#include <vector>

// The JSON writer (JsonObject, json_escape) is io/json_writer.hpp; included here because every
// writer of an output folder writes its summary.json with it.
#include "io/json_writer.hpp"

namespace ehpt::io {

inline constexpr const char* kManifestName = "ehpt-manifest.txt";
inline constexpr const char* kManifestMagic = "ehpt output folder, version 1";

// True if dir is an earlier ehpt run that may be replaced. Otherwise why_not says why
// ("it holds files ehpt did not write: notes.txt, src/"). files gets the listed names.
// A symbolic link is never an earlier run.
bool is_earlier_run(const std::string& dir, std::vector<std::string>& files, std::string& why_not);

// Adds names to dir's manifest (atomically; the manifest must exist). Hold dir's lock.
bool add_to_manifest(const std::string& dir, const std::vector<std::string>& names, std::string& error);

// The exclusive lock of an output folder: an flock on "DIR.ehpt-lock", a file that is born
// with ehpt's text in it (written to a temporary name, then linked), so that whoever holds
// it last knows it is ehpt's and removes it. A file of that name without the text is locked
// but never removed.
class DirLock {
 public:
  DirLock() = default;
  ~DirLock() { release(); }
  DirLock(const DirLock&) = delete;
  DirLock& operator=(const DirLock&) = delete;
  // false and a message if another process holds it ("another ehpt run is writing ...").
  bool acquire(const std::string& final_dir, std::string& error);
  void release();
  bool held() const { return fd_ >= 0; }

 private:
  std::string path_;
  int fd_ = -1;
};

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
  // Writes the manifest, flushes the files to disk, moves an earlier run aside, renames the
  // partial folder to DIR, deletes the earlier run's listed files. With replace_earlier
  // false (an interrupted run), an existing non-empty DIR is left alone and the results stay
  // in partial_dir() (a warning says so). False on failure: the results stay in partial_dir().
  bool commit(std::string& error, bool replace_earlier = true);
  // Where the results are after commit(): DIR, or the partial folder.
  const std::string& results_dir() const { return committed_ ? final_ : partial_; }
  // Warnings from commit() that did not stop it (e.g. an earlier run's folder not empty).
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  bool committed();  // after the results are in place: flush the rename, release the lock

  std::string final_, partial_;
  DirLock lock_;
  bool created_partial_ = false, committed_ = false;
  int uncaught_at_open_ = 0;
  std::vector<std::string> warnings_;
};


// Writes content to path via a temporary name in the same folder and rename, so a reader
// never sees half a file. The temporary is made with O_EXCL (never an existing file).
bool write_file_atomically(const std::string& path, const std::string& content, std::string& error);

}  // namespace ehpt::io
