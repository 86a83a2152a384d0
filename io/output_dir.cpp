#include "io/output_dir.hpp"

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

#include "io/number_format.hpp"
#include "io/text_file.hpp"

namespace fs = std::filesystem;

namespace ehpt::io {

namespace {

constexpr const char* kLockMagic = "ehpt lock, pid ";

std::string errno_text() { return std::strerror(errno); }

// rename that fails with EEXIST instead of replacing whatever is at `to`
bool rename_no_replace(const std::string& from, const std::string& to) {
  return ::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) == 0;
}

bool plain_name(const std::string& n) {
  return !n.empty() && n != "." && n != ".." && n.find('/') == std::string::npos && n.find('\0') == std::string::npos;
}

// The names listed in dir's manifest; false (why set) if there is no valid manifest.
bool read_manifest(const std::string& dir, std::vector<std::string>& names, std::string& why) {
  std::string text, reason;
  names.clear();
  if (!read_text_file(dir + "/" + kManifestName, text, reason, 1u << 20)) {
    why = std::string("no ") + kManifestName + " (" + reason + ")";
    return false;
  }
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

std::string manifest_text(const std::set<std::string>& names) {
  std::string text = std::string(kManifestMagic) + "\n";
  for (const std::string& n : names) text += n + "\n";
  return text;
}

}  // namespace

bool is_earlier_run(const std::string& dir, std::vector<std::string>& files, std::string& why_not) {
  std::string no_manifest;
  if (!read_manifest(dir, files, no_manifest)) files.clear();
  const std::set<std::string> listed(files.begin(), files.end());
  std::vector<std::string> foreign;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name == kManifestName) continue;
    std::error_code sec;
    const fs::file_status st = it->symlink_status(sec);
    if (st.type() == fs::file_type::regular && listed.count(name) != 0) continue;
    foreign.push_back(name + (st.type() == fs::file_type::directory ? "/" : ""));
  }
  if (ec) {
    why_not = "cannot list it: " + ec.message();
    return false;
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

bool add_to_manifest(const std::string& dir, const std::vector<std::string>& names, std::string& error) {
  std::vector<std::string> listed;
  std::string why;
  if (!read_manifest(dir, listed, why)) {
    error = dir + ": " + why;
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

OutputDir::~OutputDir() {
  // an exception (out of memory) is unwinding the run: its half-written folder is ours and
  // worth nothing; a plain return or a crash keeps it
  if (!committed_ && created_partial_ && std::uncaught_exceptions() > uncaught_at_open_) {
    std::error_code ec;
    fs::remove_all(partial_, ec);
  }
  unlock();
}

void OutputDir::unlock() {
  if (lock_fd_ < 0) return;
  // remove the lock file only if it is ours: made by this process, or carrying ehpt's text
  // (left by a run that crashed), and still the same file
  struct stat held {}, now {};
  if (::fstat(lock_fd_, &held) == 0 && ::lstat(lock_path_.c_str(), &now) == 0 && held.st_ino == now.st_ino &&
      held.st_dev == now.st_dev) {
    bool ours = created_lock_;
    if (!ours) {
      char buf[32] = {};
      ours = ::pread(lock_fd_, buf, sizeof buf - 1, 0) > 0 && std::strncmp(buf, kLockMagic, std::strlen(kLockMagic)) == 0;
    }
    if (ours) ::unlink(lock_path_.c_str());
  }
  ::close(lock_fd_);
  lock_fd_ = -1;
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
  lock_path_ = final_ + ".ehpt-lock";
  for (int attempt = 0; attempt < 10 && lock_fd_ < 0; ++attempt) {
    int fd = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    bool created = fd >= 0;
    if (fd < 0 && errno == EEXIST) fd = ::open(lock_path_.c_str(), O_RDWR | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) {
      error = lock_path_ + ": cannot open the lock file: " + errno_text();
      return false;
    }
    struct stat held {};
    if (::fstat(fd, &held) != 0 || !S_ISREG(held.st_mode)) {
      ::close(fd);
      error = lock_path_ + ": exists and is not a lock file; choose another --out, nothing was run";
      return false;
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const bool busy = errno == EWOULDBLOCK;
      ::close(fd);
      error = busy ? final_ + ": another ehpt run is writing this folder (it holds " + lock_path_ +
                         "); wait for it or choose another --out, nothing was run"
                   : lock_path_ + ": cannot lock: " + errno_text();
      return false;
    }
    // the holder before us may have removed the file after we opened it: lock the new one
    struct stat now {};
    if (::lstat(lock_path_.c_str(), &now) != 0 || now.st_ino != held.st_ino || now.st_dev != held.st_dev) {
      ::close(fd);
      continue;
    }
    lock_fd_ = fd;
    created_lock_ = created;
    if (created) {
      const std::string text = std::string(kLockMagic) + std::to_string(::getpid()) + "\n";
      if (::write(fd, text.data(), text.size()) < 0) { /* informative only */ }
    }
  }
  if (lock_fd_ < 0) {
    error = lock_path_ + ": cannot lock (the file keeps changing)";
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
      unlock();
      return false;
    }
  } else if (errno != ENOENT) {
    error = final_ + ": " + errno_text();
    unlock();
    return false;
  }

  // 3. a partial folder of our own: mkdir fails rather than reuse an existing path
  const std::string base = final_ + ".partial-" + std::to_string(::getpid());
  for (int i = 0; i < 100 && !created_partial_; ++i) {
    partial_ = i == 0 ? base : base + "-" + std::to_string(i);
    if (::mkdir(partial_.c_str(), 0777) == 0) {
      created_partial_ = true;
    } else if (errno != EEXIST) {
      error = partial_ + ": cannot create output folder: " + errno_text();
      unlock();
      return false;
    }
  }
  if (!created_partial_) {
    error = base + ": cannot find a free name for the temporary folder";
    unlock();
    return false;
  }
  return true;
}

bool OutputDir::commit(std::string& error) {
  if (!created_partial_ || committed_) {
    error = final_ + ": nothing to commit";
    return false;
  }
  const std::string kept = " (results kept in " + partial_ + ")";
  // the manifest: every regular file in our folder (we wrote them all)
  std::set<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(partial_, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code sec;
    if (it->symlink_status(sec).type() == fs::file_type::regular) names.insert(it->path().filename().string());
  }
  names.erase(kManifestName);
  if (ec || !write_file_atomically(partial_ + "/" + kManifestName, manifest_text(names), error)) {
    if (ec) error = partial_ + ": cannot list: " + ec.message();
    error += kept;
    return false;
  }

  struct stat st {};
  std::string aside;  // an earlier run moved out of the way
  std::vector<std::string> old_files;
  if (::lstat(final_.c_str(), &st) == 0) {
    std::string why;
    if (S_ISDIR(st.st_mode) && fs::is_empty(final_, ec)) {
      // rename replaces an empty folder atomically, and fails if it filled up meanwhile
      if (::rename(partial_.c_str(), final_.c_str()) != 0) {
        error = final_ + ": cannot rename the results into place: " + errno_text() + kept;
        return false;
      }
      committed_ = true;
      unlock();
      return true;
    }
    if (!S_ISDIR(st.st_mode) || S_ISLNK(st.st_mode) || !is_earlier_run(final_, old_files, why)) {
      error = final_ + ": changed during the run and is no longer an earlier ehpt run (" +
              (why.empty() ? std::string("not a folder") : why) + ")" + kept;
      return false;
    }
    const std::string base = final_ + ".replaced-" + std::to_string(::getpid());
    for (int i = 0; i < 100 && aside.empty(); ++i) {
      const std::string candidate = i == 0 ? base : base + "-" + std::to_string(i);
      if (rename_no_replace(final_, candidate)) {
        aside = candidate;
      } else if (errno != EEXIST) {
        error = final_ + ": cannot move the earlier run aside: " + errno_text() + kept;
        return false;
      }
    }
    if (aside.empty()) {
      error = base + ": cannot find a free name to move the earlier run aside" + kept;
      return false;
    }
  } else if (errno != ENOENT) {
    error = final_ + ": " + errno_text() + kept;
    return false;
  }

  if (!rename_no_replace(partial_, final_)) {
    error = final_ + ": cannot rename the results into place: " + errno_text() + kept;
    if (!aside.empty() && !rename_no_replace(aside, final_)) error += "; the earlier run is in " + aside;
    return false;
  }
  committed_ = true;
  if (!aside.empty()) {
    // delete exactly what the earlier run's manifest lists, then the folder if now empty
    for (const std::string& f : old_files) ::unlink((aside + "/" + f).c_str());
    ::unlink((aside + "/" + kManifestName).c_str());
    if (::rmdir(aside.c_str()) != 0) {
      warnings_.push_back("the earlier run's folder was kept as " + aside + " (" + errno_text() +
                          "): it held files ehpt did not write");
    }
  }
  unlock();
  return true;
}

std::string json_escape(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

void JsonObject::number(const std::string& key, double value) {
  items_.emplace_back(key, std::isfinite(value) ? number_text(value) : "null");
}
void JsonObject::integer(const std::string& key, long long value) { items_.emplace_back(key, std::to_string(value)); }
void JsonObject::text(const std::string& key, const std::string& value) { items_.emplace_back(key, json_escape(value)); }
void JsonObject::boolean(const std::string& key, bool value) { items_.emplace_back(key, value ? "true" : "false"); }
void JsonObject::null(const std::string& key) { items_.emplace_back(key, "null"); }
void JsonObject::object(const std::string& key, const JsonObject& value) { items_.emplace_back(key, value.str(2)); }
void JsonObject::strings(const std::string& key, const std::vector<std::string>& values) {
  std::string raw = "[";
  for (std::size_t i = 0; i < values.size(); ++i) raw += (i ? ", " : "") + json_escape(values[i]);
  items_.emplace_back(key, raw + "]");
}

std::string JsonObject::str(int indent) const {
  const std::string pad(static_cast<std::size_t>(indent) + 2, ' ');
  std::string out = "{\n";
  for (std::size_t i = 0; i < items_.size(); ++i) {
    out += pad + json_escape(items_[i].first) + ": " + items_[i].second;
    out += i + 1 < items_.size() ? ",\n" : "\n";
  }
  return out + std::string(static_cast<std::size_t>(indent), ' ') + "}";
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
  if (::close(fd) != 0) {
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
