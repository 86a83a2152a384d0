// SPDX-License-Identifier: BSD-3-Clause
#include "io/output_dir.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <stdio.h>  // renameat2, RENAME_NOREPLACE (glibc >= 2.28)
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <set>
#include <system_error>


namespace fs = std::filesystem;

namespace ehpt::io {

namespace {

constexpr const char* kLockMagic = "ehpt lock, pid ";

std::string errno_text() { return std::strerror(errno); }

// rename that fails with EEXIST instead of replacing whatever is at `to`
bool rename_no_replace(const std::string& from, const std::string& to) {
  if (::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) == 0) return true;
  if (errno != EINVAL) return false;
  // the filesystem has no RENAME_NOREPLACE (9p, some NFS): a folder's plain rename replaces
  // at most an empty folder (a full one gives ENOTEMPTY, a file ENOTDIR); a file is linked
  // (EEXIST if the name is taken) and then unlinked
  struct stat st {};
  if (::lstat(from.c_str(), &st) != 0) return false;
  if (S_ISDIR(st.st_mode)) {
    if (::lstat(to.c_str(), &st) == 0) {
      errno = EEXIST;
      return false;
    }
    return ::rename(from.c_str(), to.c_str()) == 0;
  }
  if (::link(from.c_str(), to.c_str()) != 0) return false;
  ::unlink(from.c_str());
  return true;
}

bool plain_name(const std::string& n) {
  return !n.empty() && n != "." && n != ".." && n.find('/') == std::string::npos && n.find('\0') == std::string::npos &&
         n.find('\n') == std::string::npos;
}

bool same_file(const struct stat& a, const struct stat& b) { return a.st_dev == b.st_dev && a.st_ino == b.st_ino; }

// Flushes a file or folder to disk, so that a committed run survives a power cut.
void sync_path(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

std::string parent_of(const std::string& path) {
  const std::string p = fs::path(path).parent_path().string();
  return p.empty() ? "." : p;
}

// The names in the folder open as dirfd (not . and ..), with their type (lstat).
bool list_at(int dirfd, std::vector<std::pair<std::string, mode_t>>& entries, std::string& why) {
  entries.clear();
  const int fd = ::dup(dirfd);
  if (fd < 0) {
    why = errno_text();
    return false;
  }
  DIR* d = ::fdopendir(fd);
  if (d == nullptr) {
    why = errno_text();
    ::close(fd);
    return false;
  }
  ::rewinddir(d);
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name;
    if (name == "." || name == "..") continue;
    struct stat st {};
    const mode_t mode = ::fstatat(dirfd, e->d_name, &st, AT_SYMLINK_NOFOLLOW) == 0 ? st.st_mode : 0;
    entries.emplace_back(name, mode);
  }
  ::closedir(d);
  return true;
}

// The names listed in the manifest of the folder open as dirfd; false (why set) if there is
// no valid manifest. Read through the descriptor, never following a link.
bool read_manifest_at(int dirfd, std::vector<std::string>& names, std::string& why) {
  names.clear();
  const int fd = ::openat(dirfd, kManifestName, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  struct stat st {};
  if (fd < 0 || ::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size > (1 << 20)) {
    why = std::string("no ") + kManifestName + " (" + (fd < 0 ? (errno == ENOENT ? "no such file" : errno_text())
                                                               : std::string("not a small regular file")) + ")";
    if (fd >= 0) ::close(fd);
    return false;
  }
  std::string text(static_cast<std::size_t>(st.st_size), '\0');
  const ssize_t n = ::read(fd, text.data(), text.size());
  ::close(fd);
  text.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  std::size_t at = 0;
  bool first = true;
  while (at < text.size()) {
    std::size_t end = text.find('\n', at);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(at, end - at);
    at = end + 1;
    if (first) {
      if (line != kManifestMagic) {
        why = std::string(kManifestName) + " is not ehpt's";
        return false;
      }
      first = false;
    } else if (!line.empty()) {
      if (!plain_name(line)) {
        why = std::string(kManifestName) + " lists \"" + line + "\", not a plain file name";
        return false;
      }
      names.push_back(line);
    }
  }
  if (first) {
    why = std::string(kManifestName) + " is empty";
    return false;
  }
  return true;
}

// is_earlier_run() on a folder already open (so that what is checked is what is deleted).
bool is_earlier_run_at(int dirfd, std::vector<std::string>& files, std::string& why_not) {
  std::string no_manifest;
  if (!read_manifest_at(dirfd, files, no_manifest)) files.clear();
  const std::set<std::string> listed(files.begin(), files.end());
  std::vector<std::pair<std::string, mode_t>> entries;
  if (!list_at(dirfd, entries, why_not)) {
    why_not = "cannot list it: " + why_not;
    return false;
  }
  std::vector<std::string> foreign;
  for (const auto& [name, mode] : entries) {
    if (name == kManifestName) continue;
    if (S_ISREG(mode) && listed.count(name) != 0) continue;
    foreign.push_back(name + (S_ISDIR(mode) ? "/" : ""));
  }
  if (!foreign.empty()) {
    std::sort(foreign.begin(), foreign.end());
    why_not = (no_manifest.empty() ? "" : no_manifest + "; ") + "it holds files ehpt did not write: ";
    for (std::size_t i = 0; i < foreign.size() && i < 5; ++i) why_not += (i ? ", " : "") + foreign[i];
    if (foreign.size() > 5) why_not += " and " + std::to_string(foreign.size() - 5) + " more";
    return false;
  }
  if (!no_manifest.empty()) {
    why_not = no_manifest;
    return false;
  }
  return true;
}

bool is_empty_at(int dirfd) {
  std::vector<std::pair<std::string, mode_t>> entries;
  std::string why;
  return list_at(dirfd, entries, why) && entries.empty();
}

std::string manifest_text(const std::set<std::string>& names) {
  std::string text = std::string(kManifestMagic) + "\n";
  for (const std::string& n : names) text += n + "\n";
  return text;
}

}  // namespace

bool is_earlier_run(const std::string& dir, std::vector<std::string>& files, std::string& why_not) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) {
    why_not = errno == ELOOP ? "a symbolic link" : errno_text();
    files.clear();
    return false;
  }
  const bool ok = is_earlier_run_at(fd, files, why_not);
  ::close(fd);
  return ok;
}

bool add_to_manifest(const std::string& dir, const std::vector<std::string>& names, std::string& error) {
  std::vector<std::string> listed;
  std::string why;
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  const bool read = fd >= 0 && read_manifest_at(fd, listed, why);
  if (fd >= 0) ::close(fd);
  if (!read) {
    error = dir + ": " + (why.empty() ? errno_text() : why);
    return false;
  }
  std::set<std::string> all(listed.begin(), listed.end());
  for (const std::string& n : names) {
    if (!plain_name(n)) {
      error = dir + ": \"" + n + "\" is not a plain file name";
      return false;
    }
    all.insert(n);
  }
  return write_file_atomically(dir + "/" + kManifestName, manifest_text(all), error);
}

// ---- names beside DIR ---------------------------------------------------------------------

// A name beside DIR: DIR + suffix, or, where that last component would pass NAME_MAX (a --out
// name near 255 bytes, which is a valid folder name), DIR's name cut short and told apart by a
// hash of the whole name. Still beside DIR, and the same for the same DIR, so that the lock
// of a second run with the same --out is the first one's.
static std::string beside(std::string final_dir, const std::string& suffix) {
  constexpr std::size_t kNameMax = 255;
  // "out/run/" is the folder "out/run": its lock is beside it, not inside it
  while (final_dir.size() > 1 && final_dir.back() == '/') final_dir.pop_back();
  const fs::path p(final_dir);
  const std::string name = p.filename().string();
  if (name.size() + suffix.size() <= kNameMax) return final_dir + suffix;
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a: a stable, short tag, not a security measure
  for (const unsigned char c : name) h = (h ^ c) * 1099511628211ull;
  char tag[18];
  std::snprintf(tag, sizeof tag, "~%016llx", static_cast<unsigned long long>(h));
  const std::size_t keep = kNameMax - suffix.size() - (sizeof tag - 1);
  return (p.parent_path() / (name.substr(0, keep) + tag)).string() + suffix;
}

// ---- the lock ---------------------------------------------------------------------------

bool DirLock::acquire(const std::string& final_dir, std::string& error) {
  release();
  path_ = beside(final_dir, ".ehpt-lock");
  const std::string pid = std::to_string(::getpid());
  for (int attempt = 0; attempt < 10 && fd_ < 0; ++attempt) {
    int fd = ::open(path_.c_str(), O_RDWR | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0 && errno == ENOENT) {
      // born with ehpt's text: a temporary file, then a hard link (atomic, never replaces)
      const std::string tmp = beside(final_dir, ".ehpt-lock.tmp-" + pid);
      const int tfd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
      if (tfd < 0) {
        error = tmp + ": cannot create the lock file: " + errno_text();
        return false;
      }
      const std::string text = kLockMagic + pid + "\n";
      const bool wrote = ::write(tfd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
      ::close(tfd);
      const bool linked = wrote && ::link(tmp.c_str(), path_.c_str()) == 0;
      const int link_errno = errno;
      ::unlink(tmp.c_str());
      if (!linked && link_errno != EEXIST) {
        error = path_ + ": cannot create the lock file: " + std::strerror(link_errno);
        return false;
      }
      continue;  // open what is there now
    }
    if (fd < 0) {
      error = path_ + ": cannot open the lock file: " + (errno == ELOOP ? "a symbolic link" : errno_text());
      return false;
    }
    struct stat held {};
    if (::fstat(fd, &held) != 0 || !S_ISREG(held.st_mode)) {
      ::close(fd);
      error = path_ + ": exists and is not a lock file; choose another --out";
      return false;
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const bool busy = errno == EWOULDBLOCK;
      ::close(fd);
      error = busy ? final_dir + ": another ehpt run is writing this folder (it holds " + path_ +
                         "); wait for it or choose another --out"
                   : path_ + ": cannot lock: " + errno_text();
      return false;
    }
    // the holder before us may have removed the file after we opened it: lock the new one
    struct stat now {};
    if (::lstat(path_.c_str(), &now) != 0 || !same_file(now, held)) {
      ::close(fd);
      continue;
    }
    fd_ = fd;
  }
  if (fd_ < 0) {
    error = path_ + ": cannot lock (the file keeps changing)";
    return false;
  }
  return true;
}

void DirLock::release() {
  if (fd_ < 0) return;
  // remove the file only if it carries ehpt's text and is still the one we hold
  struct stat held {}, now {};
  char buf[32] = {};
  if (::fstat(fd_, &held) == 0 && ::lstat(path_.c_str(), &now) == 0 && same_file(held, now) &&
      ::pread(fd_, buf, sizeof buf - 1, 0) > 0 && std::strncmp(buf, kLockMagic, std::strlen(kLockMagic)) == 0) {
    ::unlink(path_.c_str());
  }
  ::close(fd_);
  fd_ = -1;
}

// ---- the output folder ------------------------------------------------------------------

OutputDir::~OutputDir() {
  // an exception (out of memory) is unwinding the run: its half-written folder is ours and
  // worth nothing; a plain return or a crash keeps it
  if (!committed_ && created_partial_ && std::uncaught_exceptions() > uncaught_at_open_) {
    std::error_code ec;
    fs::remove_all(partial_, ec);
  }
}

bool OutputDir::open(const std::string& final_dir, std::string& error) {
  final_ = final_dir;
  while (final_.size() > 1 && final_.back() == '/') final_.pop_back();
  const std::string leaf = fs::path(final_).filename().string();
  if (final_.empty() || final_ == "/" || leaf == "." || leaf == "..") {
    error = "--out \"" + final_dir + "\": name a new or earlier output folder, not . or .. or /";
    return false;
  }
  uncaught_at_open_ = std::uncaught_exceptions();

  // the parent folder (e.g. out/) is created if missing
  std::error_code ec;
  const fs::path parent = fs::path(final_).parent_path();
  if (!parent.empty()) fs::create_directories(parent, ec);
  if (ec) {
    error = parent.string() + ": cannot create the folder: " + ec.message();
    return false;
  }

  // 1. the lock, held until commit: a second run with the same --out stops here
  if (!lock_.acquire(final_, error)) {
    error += ", nothing was run";
    return false;
  }

  // 2. DIR: absent, empty, or an earlier run
  struct stat st {};
  if (::lstat(final_.c_str(), &st) == 0) {
    std::vector<std::string> files;
    std::string why, refused;
    if (S_ISLNK(st.st_mode)) {
      refused = final_ + ": is a symbolic link; give the folder itself as --out, nothing was run";
    } else if (!S_ISDIR(st.st_mode)) {
      refused = final_ + ": exists and is not a folder; choose another --out, nothing was run";
    } else if (!fs::is_empty(final_, ec) && !is_earlier_run(final_, files, why)) {
      refused = final_ + ": exists and is not an earlier ehpt run (" + why + "); choose another --out, nothing was run";
    }
    if (!refused.empty()) {
      error = refused;
      lock_.release();
      return false;
    }
  } else if (errno != ENOENT) {
    error = final_ + ": " + errno_text();
    lock_.release();
    return false;
  }

  // 3. a partial folder of our own: mkdir fails rather than reuse an existing path
  const std::string base = beside(final_, ".partial-" + std::to_string(::getpid()));
  for (int i = 0; i < 100 && !created_partial_; ++i) {
    partial_ = i == 0 ? base : beside(final_, ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(i));
    if (::mkdir(partial_.c_str(), 0777) == 0) {
      created_partial_ = true;
    } else if (errno != EEXIST) {
      error = partial_ + ": cannot create output folder: " + errno_text();
      lock_.release();
      return false;
    }
  }
  if (!created_partial_) {
    error = base + ": cannot find a free name for the temporary folder";
    lock_.release();
    return false;
  }
  return true;
}

bool OutputDir::committed() {
  committed_ = true;
  sync_path(parent_of(final_));  // the rename itself on disk
  lock_.release();
  return true;
}

bool OutputDir::commit(std::string& error, bool replace_earlier) {
  if (!created_partial_ || committed_) {
    error = final_ + ": nothing to commit";
    return false;
  }
  const std::string kept = " (results kept in " + partial_ + ")";
  // the manifest: every regular file in our folder (we wrote them all), all flushed to disk
  std::set<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(partial_, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code sec;
    if (it->symlink_status(sec).type() == fs::file_type::regular) names.insert(it->path().filename().string());
  }
  names.erase(kManifestName);
  if (ec) {
    error = partial_ + ": cannot list: " + ec.message() + kept;
    return false;
  }
  if (!write_file_atomically(partial_ + "/" + kManifestName, manifest_text(names), error)) {
    error += kept;
    return false;
  }
  for (const std::string& n : names) sync_path(partial_ + "/" + n);
  sync_path(partial_);

  struct stat st {};
  if (::lstat(final_.c_str(), &st) != 0) {
    if (errno != ENOENT) {
      error = final_ + ": " + errno_text() + kept;
      return false;
    }
    if (!rename_no_replace(partial_, final_)) {
      error = final_ + ": cannot rename the results into place: " + errno_text() + kept;
      return false;
    }
    return committed();
  }

  // DIR exists: check it through a descriptor, so that what was checked is what is removed
  const int dirfd = ::open(final_.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (dirfd < 0) {
    error = final_ + ": changed during the run and is no longer a folder ehpt may replace" + kept;
    return false;
  }
  struct stat checked {};
  ::fstat(dirfd, &checked);
  if (is_empty_at(dirfd)) {
    ::close(dirfd);
    // rename replaces an empty folder atomically, and fails if it filled up meanwhile
    if (::rename(partial_.c_str(), final_.c_str()) != 0) {
      error = final_ + ": cannot rename the results into place: " + errno_text() + kept;
      return false;
    }
    return committed();
  }
  if (!replace_earlier) {
    ::close(dirfd);
    warnings_.push_back("the earlier run in " + final_ + " was kept; this run's outputs are in " + partial_);
    lock_.release();
    return true;
  }
  std::vector<std::string> old_files;
  std::string why;
  if (!is_earlier_run_at(dirfd, old_files, why)) {
    ::close(dirfd);
    error = final_ + ": changed during the run and is no longer an earlier ehpt run (" + why + ")" + kept;
    return false;
  }
  // move it aside under a name of ours, and make sure it is the folder we checked
  const std::string base = ".replaced-" + std::to_string(::getpid());
  std::string aside;
  for (int i = 0; i < 100 && aside.empty(); ++i) {
    const std::string candidate = beside(final_, i == 0 ? base : base + "-" + std::to_string(i));
    if (rename_no_replace(final_, candidate)) {
      aside = candidate;
    } else if (errno != EEXIST) {
      ::close(dirfd);
      error = final_ + ": cannot move the earlier run aside: " + errno_text() + kept;
      return false;
    }
  }
  struct stat moved {};
  if (aside.empty() || ::lstat(aside.c_str(), &moved) != 0 || !same_file(moved, checked)) {
    if (!aside.empty()) rename_no_replace(aside, final_);  // not the folder we checked: put it back
    ::close(dirfd);
    error = final_ + ": changed during the run; nothing of it was touched" + kept;
    return false;
  }
  if (!rename_no_replace(partial_, final_)) {
    error = final_ + ": cannot rename the results into place: " + errno_text() + kept;
    if (!rename_no_replace(aside, final_)) error += "; the earlier run is in " + aside;
    ::close(dirfd);
    return false;
  }
  committed_ = true;
  sync_path(parent_of(final_));
  // delete exactly what the earlier run's manifest lists, through the checked folder's
  // descriptor, then the folder if it is empty now
  for (const std::string& f : old_files) ::unlinkat(dirfd, f.c_str(), 0);
  ::unlinkat(dirfd, kManifestName, 0);
  ::close(dirfd);
  if (::rmdir(aside.c_str()) != 0) {
    warnings_.push_back("the earlier run's folder was kept as " + aside + " (" + errno_text() +
                        "): it held files ehpt did not write");
  }
  lock_.release();
  return true;
}

bool write_file_atomically(const std::string& path, const std::string& content, std::string& error) {
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) {
    error = tmp + ": cannot create: " + errno_text();
    return false;
  }
  std::size_t done = 0;
  while (done < content.size()) {
    const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error = tmp + ": write failed: " + errno_text();
      ::close(fd);
      ::unlink(tmp.c_str());
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  // on disk before the rename, so that the name never points at a half-written file
  const bool synced = ::fsync(fd) == 0;
  if (::close(fd) != 0 || !synced) {
    error = tmp + ": write failed: " + errno_text();
    ::unlink(tmp.c_str());
    return false;
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    error = path + ": rename failed: " + errno_text();
    ::unlink(tmp.c_str());
    return false;
  }
  return true;
}

}  // namespace ehpt::io
