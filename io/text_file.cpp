// SPDX-License-Identifier: BSD-3-Clause
#include "io/text_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace ehpt::io {

namespace {
std::string kind_of(mode_t mode) {
  if (S_ISREG(mode)) return "a file";
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}
}  // namespace

std::string describe_path(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return errno == ENOENT ? "missing" : std::strerror(errno);
  return kind_of(st.st_mode);
}

bool read_text_file(const std::string& path, std::string& out, std::string& reason, std::size_t max_bytes) {
  out.clear();
  // O_NONBLOCK: opening a FIFO with no writer would otherwise block forever
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) {
    reason = errno == ENOENT ? "no such file" : std::strerror(errno);
    return false;
  }
  struct stat st {};
  bool ok = ::fstat(fd, &st) == 0;
  if (!ok) {
    reason = std::strerror(errno);
  } else if (!S_ISREG(st.st_mode)) {
    reason = "is " + kind_of(st.st_mode) + ", not a regular file";
    ok = false;
  } else if (static_cast<unsigned long long>(st.st_size) > max_bytes) {
    reason = "is " + std::to_string(st.st_size) + " bytes, more than the limit of " + std::to_string(max_bytes) +
             " bytes for an input file";
    ok = false;
  }
  if (ok) {
    out.resize(static_cast<std::size_t>(st.st_size));
    std::size_t have = 0;
    // read what fstat promised; a file that grows meanwhile is read up to the bound only
    for (;;) {
      if (have == out.size()) {
        if (out.size() >= max_bytes + 1) break;
        out.resize(std::min(max_bytes + 1, out.size() + 65536));
      }
      const ssize_t n = ::read(fd, out.data() + have, out.size() - have);
      if (n < 0) {
        if (errno == EINTR) continue;
        reason = std::strerror(errno);
        ok = false;
        break;
      }
      if (n == 0) break;
      have += static_cast<std::size_t>(n);
    }
    out.resize(have);
    if (ok && have > max_bytes) {
      reason = "is larger than the limit of " + std::to_string(max_bytes) + " bytes for an input file";
      ok = false;
    }
  }
  ::close(fd);
  if (!ok) out.clear();
  return ok;
}

TextFileWriter::~TextFileWriter() {
  if (fd_ >= 0) ::close(fd_);
}

bool TextFileWriter::open(const std::string& path, std::string& error) {
  path_ = path;
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd_ < 0) error = path + ": cannot create: " + std::strerror(errno);
  return fd_ >= 0;
}

bool TextFileWriter::write(std::string_view text, std::string& error) {
  if (discard_) return true;
  if (fd_ < 0) {
    error = path_ + ": write failed: not open";
    return false;
  }
  while (!text.empty()) {
    const ssize_t n = ::write(fd_, text.data(), text.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error = path_ + ": write failed: " + (n < 0 ? std::strerror(errno) : "no progress");
      return false;
    }
    text.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

bool TextFileWriter::close(std::string& error) {
  if (fd_ < 0) return true;
  // on disk before the run is committed: a committed folder never holds a truncated file
  const bool synced = ::fsync(fd_) == 0;
  const int rc = ::close(fd_);
  fd_ = -1;
  if (rc != 0 || !synced) error = path_ + ": write failed: " + std::strerror(errno);
  return rc == 0 && synced;
}

}  // namespace ehpt::io
