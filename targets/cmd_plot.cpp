// SPDX-License-Identifier: BSD-3-Clause
// `ehpt plot DIR`: the figures of a run (or of a sweep) with the plot tool, moved into DIR
// without replacing what is not ehpt's; and the plot tool for `ehpt run --plot`.
#include <fcntl.h>   // AT_FDCWD
#include <stdio.h>   // renameat2, RENAME_NOREPLACE
#include <stdlib.h>  // mkdtemp

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <system_error>

#include "hil/campaign/sweep_folder.hpp"
#include "hil/config/scenario.hpp"
#include "io/output_dir.hpp"
#include "io/process.hpp"
#include "targets/cli.hpp"

namespace fs = std::filesystem;

namespace ehpt::cli {

namespace {

const char* kPlotHelp =
    "usage: ehpt plot DIR\n"
    "Draws PNG figures (speed, torques and limiter state, powers, SOC, locked flag) from\n"
    "DIR/timeseries.csv into DIR with plot.py under /usr/bin/python3 (matplotlib). plot.py\n"
    "is taken from $EHPT_TOOLS_DIR, else <prefix>/libexec/ehpt for an installed ehpt\n"
    "(/usr/libexec/ehpt from the Debian package), else the source tree's tools/ for an ehpt\n"
    "run from its build folder. A figure replaces a file of the same name only if DIR's\n"
    "ehpt-manifest.txt lists it.\n"
    "On a sweep folder ('ehpt sweep --out DIR'): fuel (or battery Wh/km) against final SOC,\n"
    "one panel per scenario, coloured by each swept parameter (sweep_*.png).\n";

// The help ends with the plot tool this ehpt runs (build folder or installed).
std::string plot_help() {
  const std::string tools = ehpt::hil::tools_dir();
  return std::string(kPlotHelp) + "This ehpt: " + (tools.empty() ? "no plot tool found" : tools + "/plot.py") + "\n";
}

// `ehpt plot DIR`: draw into a private folder inside DIR, then move each figure into DIR.
// An existing file is replaced only if DIR is an ehpt run whose manifest lists it.
int plot_existing(const std::string& dir, bool quiet) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    std::cerr << "error: " << dir << ": not a folder (give a run's output folder)\n";
    return 1;
  }
  // the folder's lock: no run may commit into it, and no other plot update its manifest,
  // while the figures move in
  ehpt::io::DirLock lock;
  std::string error;
  if (!lock.acquire(dir, error)) {
    std::cerr << "error: " << error << "\n";
    return 1;
  }
  std::vector<std::string> listed;
  std::string why;
  const bool ehpt_run = ehpt::io::is_earlier_run(dir, listed, why);
  // a sweep folder's figures (sweep_*.png, from results.csv) are ehpt's too
  const bool sweep = ehpt::hil::is_sweep_folder(dir);
  std::string tmpl = dir + "/.ehpt-plot-XXXXXX";
  if (::mkdtemp(tmpl.data()) == nullptr) {
    std::cerr << "error: " << dir << ": cannot create a temporary folder: " << std::strerror(errno) << "\n";
    return 1;
  }
  const std::string tmp = tmpl;  // ours: made by mkdtemp in this process
  bool ok = run_plot_tool(dir, tmp, dir, quiet);
  std::vector<std::string> moved;
  std::error_code list_ec;
  for (fs::directory_iterator it(tmp, list_ec), end; ok && !list_ec && it != end; it.increment(list_ec)) {
    const std::string name = it->path().filename().string();
    const std::string target = dir + "/" + name;
    const bool ours = (ehpt_run && std::find(listed.begin(), listed.end(), name) != listed.end()) ||
                      (sweep && name.starts_with("sweep_") && name.ends_with(".png"));
    // a listed figure of ours is replaced; any other name only if it is free (no replace)
    const bool renamed = ours ? ::rename(it->path().c_str(), target.c_str()) == 0
                              : ::renameat2(AT_FDCWD, it->path().c_str(), AT_FDCWD, target.c_str(), RENAME_NOREPLACE) == 0;
    if (!renamed) {
      if (errno == EEXIST) {
        std::cerr << "error: " << target << ": exists and is not a figure ehpt made; kept, the new figure is not written\n";
      } else {
        std::cerr << "error: " << target << ": " << std::strerror(errno) << "\n";
      }
      ok = false;
      continue;
    }
    moved.push_back(name);
  }
  if (list_ec) {
    std::cerr << "error: " << tmp << ": " << list_ec.message() << "\n";
    ok = false;
  }
  fs::remove_all(tmp, ec);
  if (ehpt_run && !moved.empty() && !ehpt::io::add_to_manifest(dir, moved, error)) {
    std::cerr << "error: " << error << "\n";
    ok = false;
  }
  return ok ? 0 : 1;
}

}  // namespace

// Draws the figures of the run in src_dir into out_dir with the plot tool (no shell: an
// argument vector), naming them as if in shown_dir. True on success.
bool run_plot_tool(const std::string& src_dir, const std::string& out_dir, const std::string& shown_dir, bool quiet) {
  // a folder named "-x" must not be taken for an option
  const auto safe = [](const std::string& p) { return !p.empty() && p[0] == '-' ? "./" + p : p; };
  const std::string tools = ehpt::hil::tools_dir();
  if (tools.empty()) {
    std::cerr << "error: plotting failed: no plot tool found (not installed in <prefix>/libexec/ehpt next to this "
                 "ehpt; set EHPT_TOOLS_DIR to the folder of plot.py)\n";
    return false;
  }
  std::vector<std::string> argv = {"/usr/bin/python3", tools + "/plot.py", safe(src_dir),
                                   "--out-dir", safe(out_dir), "--as", shown_dir};
  if (quiet) argv.push_back("--quiet");
  std::string reason;
  const int rc = ehpt::io::run_program(argv, reason);
  if (rc == 0) return true;
  if (rc < 0) {
    std::cerr << "error: plotting failed: cannot start " << reason << "\n";
  } else {
    std::cerr << "error: plotting failed (the plot tool exited with " << rc << ")\n";
  }
  return false;
}

bool run_expect_figures(const std::string& dir, bool quiet) {
  const std::string tools = ehpt::hil::tools_dir();
  if (tools.empty()) {
    std::cerr << "warning: no figures of the failed expectations: the plot tool is not installed (set EHPT_TOOLS_DIR "
                 "to the folder of plot_expect.py)\n";
    return true;  // the verdict stands without its figure
  }
  const std::string safe = !dir.empty() && dir[0] == '-' ? "./" + dir : dir;
  std::vector<std::string> argv = {"/usr/bin/python3", tools + "/plot_expect.py", safe, "--quiet"};
  (void)quiet;  // the figures are named in summary.json's folder; nothing to print
  std::string reason;
  const int rc = ehpt::io::run_program(argv, reason);
  if (rc == 0) return true;
  std::cerr << "error: the figures of the failed expectations were not drawn ("
            << (rc < 0 ? "cannot start " + reason : "plot_expect.py exited with " + std::to_string(rc)) << ")\n";
  return false;
}

int cmd_plot(const std::vector<std::string>& args) {
  if (wants_help(args) || args.size() != 1) {
    if (args.size() != 1) {
      std::cerr << plot_help();
      return 1;
    }
    return out(plot_help()) ? 0 : 1;
  }
  return plot_existing(args[0], false);
}

}  // namespace ehpt::cli
