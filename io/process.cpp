#include "io/process.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstring>

extern char** environ;

namespace ehpt::io {

int run_program(const std::vector<std::string>& argv, std::string& reason) {
  const int pid = start_program(argv, "", "", false, reason);
  if (pid < 0) return -1;
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

int start_program(const std::vector<std::string>& argv, const std::string& stdout_path,
                  const std::string& stderr_path, bool new_group, std::string& reason) {
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
  const int rc = ::posix_spawn(&pid, args[0], &files, &attr, args.data(), environ);
  posix_spawn_file_actions_destroy(&files);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) {
    reason = argv[0] + ": " + std::strerror(rc);
    return -1;
  }
  return pid;
}

}  // namespace ehpt::io
