// SPDX-License-Identifier: BSD-3-Clause
// `ehpt bench` section (c): the real-time loop's wake-up latency next to cyclictest's.
#include "targets/bench/sections.hpp"
#include "targets/bench/supervisor.hpp"

namespace ehpt::bench {

namespace {

// cyclictest -q -h: "NNNNNN CCCCCC" per 1 us bin, then "# Total:", "# Max Latencies:",
// "# Avg Latencies:", "# Histogram Overflows:". Quantiles are the upper edge of their bin
// (bin + 1 us), as ehpt's histogram reports the upper edge of its own.
bool parse_cyclictest(const std::string& text, Latency& l) {
  std::istringstream in(text);
  std::string line;
  std::vector<std::pair<long, long long>> bins;
  long long total_in_bins = 0;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '#') {
      const auto colon = line.find(':');
      const std::string value = colon == std::string::npos ? "" : trim(line.substr(colon + 1));
      if (line.rfind("# Max Latencies", 0) == 0) l.max = std::strtod(value.c_str(), nullptr);
      if (line.rfind("# Avg Latencies", 0) == 0) l.mean = std::strtod(value.c_str(), nullptr);
      if (line.rfind("# Histogram Overflows", 0) == 0) l.overflows = std::strtoll(value.c_str(), nullptr, 10);
      if (const auto at = line.find("cpu_dma_latency set to "); at != std::string::npos) {
        l.dma_latency = trim(line.substr(at + std::strlen("cpu_dma_latency set to ")));
      }
      continue;
    }
    long bin = 0;
    long long count = 0;
    if (std::sscanf(line.c_str(), "%ld %lld", &bin, &count) == 2 && count > 0) {
      bins.emplace_back(bin, count);
      total_in_bins += count;
    }
  }
  l.samples = total_in_bins + l.overflows;
  if (l.samples == 0) return false;
  const auto quantile = [&](double q) {
    const auto need = std::max<long long>(1, static_cast<long long>(std::ceil(q * static_cast<double>(l.samples))));
    long long seen = 0;
    for (const auto& [bin, count] : bins) {
      seen += count;
      if (seen >= need) return std::min(static_cast<double>(bin + 1), std::isfinite(l.max) ? l.max : 1e300);
    }
    return l.max;  // in the overflow: the largest seen
  };
  l.p50 = quantile(0.5);
  l.p99 = quantile(0.99);
  l.p99_9 = quantile(0.999);
  return true;
}
}  // namespace

// (c)
void section_latency(Bench& b) {
  b.progress("(c) wake-up latency at 1 ms, SCHED_FIFO " + std::to_string(b.opt.priority) + ", CPU " +
             std::to_string(b.cpu) + ": cyclictest, then ehpt run --realtime, " + std::to_string(b.seconds) +
             " s each (about " + std::to_string(2 * b.seconds + 2) + " s)");
  const std::string cyclictest = ehpt::io::find_program("cyclictest");
  if (cyclictest.empty()) {
    b.cyclictest.status = "cyclictest not found (Debian package rt-tests)";
  } else {
    const Outcome o = run_child({cyclictest, "-m", "-p", std::to_string(b.opt.priority), "-i", "1000", "-a",
                                 std::to_string(b.cpu), "-t1", "-q", "-D", std::to_string(b.seconds), "-h", "5000"},
                                b.logs, "cyclictest", b.seconds + 30.0);
    if (o.stopped) return;
    // an outside tool that cannot run here (not root, no SCHED_FIFO) is said, not a failure
    if (!o.ok()) {
      b.cyclictest.status = "cyclictest failed: " + o.why;
    } else if (!parse_cyclictest(read_small_file(b.logs + "/cyclictest.out"), b.cyclictest)) {
      b.cyclictest.status = "cyclictest printed no histogram (logs/cyclictest.out)";
    } else {
      b.cyclictest.status = "ok";
    }
  }
  if (stopping()) return;
  SubRun& r = b.run("realtime");
  std::vector<std::string> argv = {b.exe, "run", kRtScenario, "--realtime", "--period", "1ms", "--cpu", std::to_string(b.cpu),
                                   "--priority", std::to_string(b.opt.priority), "--out", b.dir + "/realtime", "--quiet"};
  for (const auto& a : b.duration_set(b.seconds)) argv.push_back(a);
  const Outcome o = run_child(argv, b.logs, "realtime", b.seconds + 60.0);
  r.wall_s = o.wall_s;
  Json j;
  std::string why;
  if (o.stopped) {
    r.status = "stopped";
    return;
  }
  if (!o.ok()) {
    fail(b, r, o.why);
    b.rt_loop.status = r.status;
  } else if (!read_summary(b.dir + "/realtime", b.started_at, j, why)) {
    fail(b, r, why);
    b.rt_loop.status = r.status;
  } else {
    take_summary(b, r, j);
    Latency& l = b.rt_loop;
    l.p50 = json_num(j, "realtime.wakeup_latency_us.p50");
    l.p99 = json_num(j, "realtime.wakeup_latency_us.p99");
    l.p99_9 = json_num(j, "realtime.wakeup_latency_us.p99_9");
    l.max = json_num(j, "realtime.wakeup_latency_us.max");
    l.mean = json_num(j, "realtime.wakeup_latency_us.mean");
    l.samples = static_cast<long long>(json_num(j, "realtime.ticks"));
    l.status = std::isfinite(l.p99) ? "ok" : "failed: no realtime figures in realtime/summary.json";
    b.ticks = l.samples;
    b.overruns = static_cast<long long>(json_num(j, "realtime.overruns"));
    b.missed_ticks = static_cast<long long>(json_num(j, "realtime.missed_ticks"));
    b.rt_scheduler = json_str(j, "realtime.scheduler");
    if (const Json* w = json_at(j, "realtime.setup_warnings"); w != nullptr) {
      for (const auto& i : w->items) b.rt_warnings.push_back(i.text);
    }
  }
  b.latency_status = "ok";
}

}  // namespace ehpt::bench
