// SPDX-License-Identifier: BSD-3-Clause
#include "io/process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string_view>

extern char** environ;

namespace ehpt::io {

namespace {

double monotonic_s() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

int wait_status(int pid, std::string& reason) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      reason = std::string("waitpid: ") + std::strerror(errno);
      return -1;
    }
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

// posix_spawn of argv: stdin /dev/null; stdout and stderr to the files named ("" keeps ours),
// or both to out_fd when it is >= 0; SIGPIPE at its default; optionally a process group of
// its own; our environment with extra_env's names replaced. The pid, or -1 (reason set).
int spawn(const std::vector<std::string>& argv, const std::string& stdout_path, const std::string& stderr_path,
          int out_fd, bool new_group, const std::vector<std::string>& extra_env, std::string& reason) {
  if (argv.empty()) {
    reason = "no program";
    return -1;
  }
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t files;
  posix_spawnattr_t attr;
  posix_spawn_file_actions_init(&files);
  posix_spawnattr_init(&attr);
  posix_spawn_file_actions_addopen(&files, 0, "/dev/null", O_RDONLY, 0);
  constexpr int kOut = O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW;
  if (out_fd >= 0) {
    posix_spawn_file_actions_adddup2(&files, out_fd, 1);
    posix_spawn_file_actions_adddup2(&files, out_fd, 2);
  }
  if (!stdout_path.empty()) posix_spawn_file_actions_addopen(&files, 1, stdout_path.c_str(), kOut, 0644);
  if (!stderr_path.empty()) posix_spawn_file_actions_addopen(&files, 2, stderr_path.c_str(), kOut, 0644);
  // SIGPIPE ignored here (ehpt's main) would stay ignored in the child: give it the default
  sigset_t defaults;
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGPIPE);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  short flags = POSIX_SPAWN_SETSIGDEF;
  if (new_group) {
    posix_spawnattr_setpgroup(&attr, 0);
    flags |= POSIX_SPAWN_SETPGROUP;
  }
  posix_spawnattr_setflags(&attr, flags);
  pid_t pid = 0;
  // the environment: ours, minus the names extra_env sets, plus extra_env
  std::vector<char*> env;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    const std::string_view entry(*e);
    const bool replaced = std::any_of(extra_env.begin(), extra_env.end(), [&](const std::string& x) {
      const std::size_t eq = x.find('=');
      return eq != std::string::npos && entry.size() > eq && entry.substr(0, eq + 1) == std::string_view(x).substr(0, eq + 1);
    });
    if (!replaced) env.push_back(*e);
  }
  for (const std::string& x : extra_env) env.push_back(const_cast<char*>(x.c_str()));
  env.push_back(nullptr);
  const int rc = ::posix_spawn(&pid, args[0], &files, &attr, args.data(), env.data());
  posix_spawn_file_actions_destroy(&files);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) {
    reason = argv[0] + ": " + std::strerror(rc);
    return -1;
  }
  return pid;
}

}  // namespace

int run_program(const std::vector<std::string>& argv, std::string& reason) {
  const int pid = start_program(argv, "", "", false, reason);
  if (pid < 0) return -1;
  return wait_status(pid, reason);
}

int capture_program(const std::vector<std::string>& argv, std::string& output, double timeout_s,
                    std::string& reason, std::size_t max_bytes) {
  output.clear();
  if (argv.empty()) {
    reason = "no program";
    return -1;
  }
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    reason = std::string("pipe: ") + std::strerror(errno);
    return -1;
  }
  const int pid = spawn(argv, "", "", fds[1], false, {}, reason);
  ::close(fds[1]);
  if (pid < 0) {
    ::close(fds[0]);
    return -1;
  }
  const double deadline = monotonic_s() + timeout_s;
  bool timed_out = false;
  char buf[4096];
  for (;;) {
    const double left_s = deadline - monotonic_s();
    if (left_s <= 0.0) {
      timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int n = ::poll(&p, 1, static_cast<int>(std::ceil(std::min(left_s, 1e6) * 1000.0)));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) continue;  // the deadline is checked above
    const ssize_t got = ::read(fds[0], buf, sizeof buf);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) break;  // end of output: the program (and whatever it started) closed it
    const std::size_t room = max_bytes - std::min(max_bytes, output.size());
    output.append(buf, std::min(room, static_cast<std::size_t>(got)));
  }
  ::close(fds[0]);
  if (timed_out) {
    ::kill(pid, SIGKILL);
    std::string ignored;
    (void)wait_status(pid, ignored);
    reason = argv[0] + ": timed out after " + std::to_string(static_cast<long long>(timeout_s)) + " s";
    return -1;
  }
  return wait_status(pid, reason);
}

std::string find_program(const std::string& name) {
  if (name.empty()) return "";
  if (name.find('/') != std::string::npos) return ::access(name.c_str(), X_OK) == 0 ? name : "";
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/local/bin:/usr/bin:/bin";
  std::size_t at = 0;
  while (at <= dirs.size()) {
    const std::size_t end = std::min(dirs.find(':', at), dirs.size());
    const std::string dir = end > at ? dirs.substr(at, end - at) : ".";
    const std::string candidate = dir + "/" + name;
    std::error_code ec;
    if (::access(candidate.c_str(), X_OK) == 0 && std::filesystem::is_regular_file(candidate, ec)) {
      return std::filesystem::absolute(candidate, ec).string();
    }
    at = end + 1;
  }
  return "";
}

std::string self_executable() {
  std::error_code ec;
  const std::filesystem::path p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? "/proc/self/exe" : p.string();
}

int start_program(const std::vector<std::string>& argv, const std::string& stdout_path,
                  const std::string& stderr_path, bool new_group, std::string& reason,
                  const std::vector<std::string>& extra_env) {
  return spawn(argv, stdout_path, stderr_path, -1, new_group, extra_env, reason);
}

}  // namespace ehpt::io
