// SPDX-License-Identifier: BSD-3-Clause
// The bench's output folder (folder.hpp).
#include "targets/bench/folder.hpp"

#include "targets/bench/common.hpp"

namespace ehpt::bench {

namespace {

bool all_digits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// Names ehpt itself leaves beside a run folder when stopped hard: NAME.partial-PID,
// NAME.ehpt-lock (and its .tmp-PID), FILE.tmp-PID of an atomic write.
bool leftover_of(const std::string& entry, const std::string& name) {
  if (entry.rfind(name + ".", 0) != 0) return false;
  const std::string rest = entry.substr(name.size() + 1);
  if (rest.rfind("partial-", 0) == 0) return all_digits(rest.substr(8));
  if (rest == "ehpt-lock") return true;
  if (rest.rfind("ehpt-lock.tmp-", 0) == 0) return all_digits(rest.substr(14));
  if (rest.rfind("tmp-", 0) == 0) return all_digits(rest.substr(4));
  return false;
}

// Whether DIR (an existing folder) holds an earlier bench and nothing else; why_not if not.
bool is_earlier_bench(const std::string& dir, std::string& why_not) {
  Json j;
  struct stat st {};
  if (::lstat((dir + "/bench.json").c_str(), &st) != 0 || !S_ISREG(st.st_mode) || !read_json(dir + "/bench.json", j) ||
      json_str(j, "format") != kBenchFormat) {
    why_not = "it is not empty and not an earlier ehpt bench (no bench.json of ours)";
    return false;
  }
  std::vector<std::string> foreign;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const fs::file_status s = it->symlink_status(ec);
    const bool is_dir = fs::is_directory(s), is_file = fs::is_regular_file(s);
    bool ours = false;
    if (is_file && (name == "bench.json" || name == "bench.txt" || leftover_of(name, "bench.json") ||
                    leftover_of(name, "bench.txt"))) {
      ours = true;
    } else if (is_file && std::any_of(kInputFiles.begin(), kInputFiles.end(), [&](const std::string& f) {
                 return name == f || leftover_of(name, f);
               })) {
      ours = true;
    } else if (is_dir && name == "logs") {
      ours = true;
      for (fs::directory_iterator l(it->path(), ec), lend; !ec && l != lend; l.increment(ec)) {
        const std::string n = l->path().filename().string();
        const bool log = n.size() > 4 && (n.ends_with(".out") || n.ends_with(".err"));
        if (!fs::is_regular_file(l->symlink_status(ec)) || !log) foreign.push_back("logs/" + n);
      }
    } else {
      for (const std::string& r : kRunDirs) {
        if (is_dir && name == r) {
          std::vector<std::string> files;
          std::string why;
          ours = true;
          if (!ehpt::io::is_earlier_run(it->path().string(), files, why)) foreign.push_back(name + "/ (" + why + ")");
        } else if (leftover_of(name, r)) {
          ours = true;
        }
      }
    }
    if (!ours) foreign.push_back(name + (is_dir ? "/" : ""));
  }
  if (ec) {
    why_not = "cannot list it: " + ec.message();
    return false;
  }
  if (!foreign.empty()) {
    why_not = "an earlier bench, but it holds what ehpt bench did not write: ";
    for (std::size_t i = 0; i < foreign.size() && i < 5; ++i) why_not += (i ? ", " : "") + foreign[i];
    if (foreign.size() > 5) why_not += " and " + std::to_string(foreign.size() - 5) + " more";
    return false;
  }
  return true;
}

}  // namespace

// May DIR be used? "" if yes (exists = it is there already), else the one-line reason.
std::string check_out_dir(const std::string& dir, bool& exists) {
  struct stat st {};
  exists = false;
  if (::lstat(dir.c_str(), &st) != 0) {
    if (errno != ENOENT) return dir + ": " + std::strerror(errno);
    // made by mkdir later: its parent must be a folder already (no parents are made)
    std::string parent = fs::path(dir).parent_path().string();
    if (parent.empty()) parent = ".";
    if (::stat(parent.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
      return dir + ": its parent " + parent + " is not a folder (" + ehpt::io::describe_path(parent) + "); choose another --out";
    }
    return "";
  }
  exists = true;
  if (S_ISLNK(st.st_mode)) return dir + ": a symbolic link; give a folder of its own (--out)";
  if (!S_ISDIR(st.st_mode)) return dir + ": exists and is " + ehpt::io::describe_path(dir) + ", not a folder; choose another --out";
  std::error_code ec;
  if (fs::is_empty(dir, ec) && !ec) return "";
  std::string why;
  if (!is_earlier_bench(dir, why)) return dir + ": " + why + "; nothing was touched: choose another --out";
  return "";
}

}  // namespace ehpt::bench
