// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Starting a helper program (the plot tool) without a shell: the arguments go to the program
// as a vector, so no character in a path can be taken as a command.

#include <string>
#include <vector>

namespace ehpt::io {

// Runs argv[0] (an absolute path) with argv, waits for it (start_program with our stdout and
// stderr, stdin from /dev/null). Returns its exit status (0..255), 128 + N when it was killed
// by signal N, or -1 when it could not start (reason set).
int run_program(const std::vector<std::string>& argv, std::string& reason);

// Starts argv[0] (an absolute path) with argv and returns at once (the caller waits for it:
// waitpid). stdin reads /dev/null; stdout and stderr go to the files named (created or
// truncated; "" keeps ours). new_group: the child leads a process group of its own, so that
// killpg(pid, ...) reaches it and whatever it starts. Returns the pid, or -1 (reason set).
// extra_env: "NAME=value" entries added to (and overriding) our environment for the child.
int start_program(const std::vector<std::string>& argv, const std::string& stdout_path,
                  const std::string& stderr_path, bool new_group, std::string& reason,
                  const std::vector<std::string>& extra_env = {});

// Runs argv[0] (an absolute path) with argv and returns its exit status as run_program does;
// its stdout and stderr together are returned in output (at most max_bytes; the rest is read
// and dropped). A program still running after timeout_s is killed (SIGKILL): -1, reason
// "timed out after N s". For short client commands (sbatch, squeue, sinfo) that could hang.
int capture_program(const std::vector<std::string>& argv, std::string& output, double timeout_s,
                    std::string& reason, std::size_t max_bytes = 1 << 20);

// The absolute path of a program found on $PATH (names with a '/' as given), "" if none is
// executable.
std::string find_program(const std::string& name);

// This binary, as a path that stays valid in children (not /proc/self/exe: in unshare or
// any other program it would name that program).
std::string self_executable();

}  // namespace ehpt::io
