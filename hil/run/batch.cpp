// SPDX-License-Identifier: BSD-3-Clause
#include "hil/run/batch.hpp"

#include <pthread.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <ostream>
#include <sstream>

#include "hil/diag/alloc_guard.hpp"
#include "hil/run/expectations.hpp"
#include "hil/run/pacer.hpp"
#include "hil/diag/provenance.hpp"
#include "hil/run/row_queue.hpp"
#include "hil/run/simulation.hpp"
#include "hil/run/trajectory_hash.hpp"
#include "io/number_format.hpp"
#include "io/text_file.hpp"

namespace ehpt::hil {

std::string fault_text(unsigned fault) {
  std::string s;
  const auto add = [&](unsigned bit, const char* text) {
    if (fault & bit) s += (s.empty() ? "" : ", ") + std::string(text);
  };
  add(plant::kFaultSocWindow, "SOC left [soc_min, soc_max]");
  add(plant::kFaultCellCurrent, "cell current reached cell_current_max_A");
  add(plant::kFaultPowerInfeasible, "the drive asked for more power than the battery can give");
  add(plant::kFaultNonFinite, "non-finite state (NaN or Inf)");
  add(plant::kFaultDriveSolve, "the drive's operating point did not converge");
  return s;
}

// The columns of timeseries.csv: the scenario's output.signals, or every signal.
std::vector<int> chosen_columns(const Scenario& sc, std::span<const SignalInfo> signals) {
  std::vector<int> columns;
  if (sc.output.signals.empty()) {
    for (std::size_t i = 0; i < signals.size(); ++i) columns.push_back(static_cast<int>(i));
    return columns;
  }
  for (const std::string& name : sc.output.signals) {
    for (std::size_t i = 0; i < signals.size(); ++i) {
      if (signals[i].name == name) columns.push_back(static_cast<int>(i));
    }
  }
  return columns;
}

namespace {

constexpr std::int64_t kChunkSteps = 50000;

// The steps of one chunk: kChunkSteps, or fewer when that many rows would pass 4 MiB (every
// step recorded with 40 columns: 50 000 rows were 16 MB of buffer alone). The trajectory does
// not depend on the chunk (the rows are drained between chunks, the run goes on where it was).
std::int64_t chunk_steps(const Scenario& sc, std::size_t width) {
  constexpr std::size_t kRowBudgetBytes = 4u << 20;
  const auto rows = static_cast<std::int64_t>(kRowBudgetBytes / (sizeof(double) * std::max<std::size_t>(width, 1)));
  const std::int64_t decimation = std::max<std::int64_t>(1, sc.output.decimation);
  // (rows - 4: the recorder keeps room for row 0, the last row and a fault's beyond the grid)
  const std::int64_t grid_rows = std::max<std::int64_t>(1, rows - 4);
  if (grid_rows >= kChunkSteps / decimation) return kChunkSteps;
  return grid_rows * decimation;  // < kChunkSteps: no overflow
}

std::string signal_name(int sig) {
  switch (sig) {
    case SIGINT: return "SIGINT";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP";
    default: return "signal " + std::to_string(sig);
  }
}

// What the real-time loop did (BatchOptions::realtime), for the summary.
struct RealtimeRun {
  RealtimeOptions requested;
  RealtimeSetup setup;
  std::int64_t steps_per_tick = 1;
  TickTiming timing;
  std::int64_t rows_dropped = 0;  // the writer thread fell behind by the whole queue
  std::size_t queue_rows = 0;
};

// How the stepping went: wall times, a signal that stopped it, a write error.
struct Streamed {
  int interrupted_by = 0;  // signal number
  double wall_s = 0.0, run_wall_s = 0.0;
  std::string csv_error;   // the first write error (the run stops there)
  TrajectoryHash hash;     // over every recorded value
  // heap allocations (malloc level, whole process) between start-up and the end of the loop;
  // nullopt: the binary has no allocation guard hooks
  std::optional<std::int64_t> heap_allocations;
  std::string first_allocation;  // where the first one was (a backtrace line)
  std::unique_ptr<RealtimeRun> realtime;  // set when the real-time loop ran
};

// The CSV text is written whenever this much is buffered: a fixed buffer, no growth in the loop.
constexpr std::size_t kCsvFlushBytes = 64 * 1024;
constexpr std::size_t kMaxNumberChars = 32;  // io::append_number writes at most 25, and a separator

void write_text(io::TextFileWriter& csv, std::string& text, std::string& error) {
  if (error.empty() && !text.empty()) csv.write(text, error);
  text.clear();
}

// The allocation guard (hil/diag/alloc_guard.hpp) counts from the end of start-up to the end of
// the loop, every thread of the process included (the writer thread, the bus).
void start_counting_allocations() {
  alloc_guard::reset();
  alloc_guard::arm();
}
template <class Out>
void stop_counting_allocations(Out& out) {
  alloc_guard::disarm();
  if (!alloc_guard::active()) return;
  out.heap_allocations = alloc_guard::count();
  if (*out.heap_allocations > 0) out.first_allocation = alloc_guard::describe_first();
}

// Rows -> CSV text; the hash sees the same values.
void append_rows(std::string& text, std::span<const double> rows, std::size_t columns, TrajectoryHash& hash) {
  hash.add(rows);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    io::append_number(text, rows[i]);
    text += (i + 1) % columns == 0 ? '\n' : ',';
  }
}

// Where stream() puts the recorded rows between chunks: timeseries.csv through a text buffer
// of fixed size (written whenever it fills), ...
class CsvSink {
 public:
  CsvSink(io::TextFileWriter& csv, std::string header, std::size_t columns)
      : csv_(csv), text_(std::move(header)), columns_(columns) {
    text_.reserve(kCsvFlushBytes + kMaxNumberChars * columns_ + text_.size());
  }
  void add(std::span<const double> rows, TrajectoryHash& hash, std::string& error) {
    for (std::size_t r = 0; r < rows.size(); r += columns_) {
      append_rows(text_, rows.subspan(r, columns_), columns_, hash);
      if (text_.size() >= kCsvFlushBytes) write_text(csv_, text_, error);
    }
    write_text(csv_, text_, error);
  }
  void close(std::string& error) {
    if (error.empty()) csv_.close(error);
  }

 private:
  io::TextFileWriter& csv_;
  std::string text_;
  std::size_t columns_;
};

// ... or memory (run_in_memory), as the doubles themselves: no text round trip. Null: the
// rows are only hashed (output.timeseries off).
class MemorySink {
 public:
  explicit MemorySink(std::vector<double>* rows) : rows_(rows) {}
  void add(std::span<const double> rows, TrajectoryHash& hash, std::string&) {
    hash.add(rows);
    if (rows_ != nullptr) rows_->insert(rows_->end(), rows.begin(), rows.end());
  }
  void close(std::string&) {}

 private:
  std::vector<double>* rows_;
};

// Runs the simulation in chunks and hands its rows to the sink between chunks (the run phase
// is inside Simulation::run: no I/O there), with the progress line.
template <class Sink>
Streamed stream(Simulation& sim, const Scenario& sc, Sink& sink, const BatchOptions& opt, std::ostream& log) {
  Streamed out;
  const auto wall_start = std::chrono::steady_clock::now();
  const auto write_rows = [&] {
    sink.add(sim.rows(), out.hash, out.csv_error);
    sim.clear_rows();
  };
  start_counting_allocations();
  for (bool first = true;; first = false) {
    const auto t0 = std::chrono::steady_clock::now();
    // (the wait for the ECU's first command counts as run time, as it always did)
    if (first && opt.driver != nullptr) opt.driver->start(sim, opt.stop_signal);
    sim.run(opt.stop_signal);  // with a driver, its port and pacer inside the runner's loop
    out.run_wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    write_rows();
    if (out.csv_error.empty() && opt.driver != nullptr) opt.driver->flush(out.csv_error);
    if (opt.progress) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "\r[%3d%%] t = %.1f s of %.1f s",
                    static_cast<int>(100.0 * sim.step_index() / std::max<std::int64_t>(1, sim.total_steps())),
                    sim.time_s(), sc.solver.duration_s);
      log << buf << std::flush;
    }
    if (sim.finished() || !out.csv_error.empty()) break;  // a write error ends the run: its rows are lost
    if (opt.stop_signal != nullptr && opt.stop_signal->load() != 0) {
      out.interrupted_by = opt.stop_signal->load();  // run() recorded the state it reached
      break;
    }
  }
  stop_counting_allocations(out);
  if (opt.progress) log << "\n";
  sink.close(out.csv_error);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return out;
}

// The writer thread of the real-time loop: pops the rows the loop pushed, formats and writes
// them (and the progress line), so that no file write ever blocks a tick. It runs under
// SCHED_OTHER with a small stack (mlockall would lock a default 8 MB one) and does not
// allocate: its text buffer is reserved before it starts.
class RowWriter {
 public:
  RowWriter(RowQueue& queue, io::TextFileWriter& csv, std::string header, TrajectoryHash& hash, bool progress,
            const Scenario& sc, const std::atomic<std::int64_t>& step, std::ostream& log, ExternalDriver* driver)
      : queue_(queue), csv_(csv), text_(std::move(header)), hash_(hash), progress_(progress), sc_(sc), step_(step),
        log_(log), driver_(driver) {
    text_.reserve(kCsvFlushBytes + kMaxNumberChars * queue.columns() + text_.size());
  }

  // Start-up: false (and why) if the thread cannot start.
  bool start(std::string& error) {
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    pthread_attr_setstacksize(&attr, 256 * 1024);
    // not the loop's SCHED_FIFO, whatever the creating thread has
    pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
    pthread_attr_setschedpolicy(&attr, SCHED_OTHER);
    sched_param sp{};
    pthread_attr_setschedparam(&attr, &sp);
    const int rc = pthread_create(&thread_, &attr, &RowWriter::main, this);
    pthread_attr_destroy(&attr);
    if (rc != 0) {
      error = std::string("cannot start the writer thread: ") + std::strerror(rc);
      return false;
    }
    started_ = true;
    return true;
  }
  // Shutdown: the rows left are written, the thread joined; the first write error, if any.
  std::string finish() {
    if (started_) {
      done_.store(true, std::memory_order_release);
      pthread_join(thread_, nullptr);
      started_ = false;
    }
    return error_;
  }
  ~RowWriter() { finish(); }

 private:
  static void* main(void* self) {
    static_cast<RowWriter*>(self)->loop();
    return nullptr;
  }
  void loop() {
    std::int64_t next_progress_ns = 0;
    for (;;) {
      const bool last = done_.load(std::memory_order_acquire);  // rows pushed before done: all popped now
      queue_.pop_all([&](std::span<const double> row) {
        append_rows(text_, row, row.size(), hash_);
        if (text_.size() >= kCsvFlushBytes) write();
      });
      write();
      if (driver_ != nullptr) driver_->background_flush();
      if (progress_) {
        timespec ts{};
        clock_gettime(CLOCK_MONOTONIC, &ts);
        const std::int64_t now = ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
        if (now >= next_progress_ns || last) {
          next_progress_ns = now + 500'000'000;
          const std::int64_t n = step_.load(std::memory_order_relaxed);
          char buf[96];
          std::snprintf(buf, sizeof buf, "\r[%3d%%] t = %.1f s of %.1f s (real time)",
                        static_cast<int>(100.0 * static_cast<double>(n) / static_cast<double>(std::max<std::int64_t>(1, sc_.solver.steps))),
                        static_cast<double>(n) * sc_.solver.step_s, sc_.solver.duration_s);
          log_ << buf << std::flush;
        }
      }
      if (last) break;
      const timespec nap{0, 2'000'000};  // 2 ms: the loop never waits for us
      nanosleep(&nap, nullptr);
    }
    if (progress_) log_ << "\n";
  }
  void write() {
    if (text_.empty()) return;
    if (error_.empty()) csv_.write(text_, error_);
    text_.clear();
  }

  RowQueue& queue_;
  io::TextFileWriter& csv_;
  std::string text_;
  TrajectoryHash& hash_;
  bool progress_;
  const Scenario& sc_;
  const std::atomic<std::int64_t>& step_;
  std::ostream& log_;
  ExternalDriver* driver_;  // its files, written here (background_flush)
  pthread_t thread_{};
  bool started_ = false;
  std::atomic<bool> done_{false};
  std::string error_;  // the writer's first write error
};

// The real-time loop: one tick per period on absolute deadlines (TickPacer over
// MonotonicClock), the loop's thread under SCHED_FIFO with its memory locked; per tick the
// driver's IO (a bus) and the plant's steps, then the rows to the writer thread. Timing in
// preallocated histograms; a signal ends it at the next tick with every row written.
Streamed stream_realtime(Simulation& sim, const Scenario& sc, std::string header, std::size_t columns,
                         io::TextFileWriter& csv, const BatchOptions& opt, std::ostream& log) {
  Streamed out;
  out.realtime = std::make_unique<RealtimeRun>();
  RealtimeRun& rt = *out.realtime;
  rt.requested = *opt.realtime;
  const double period_s = opt.realtime->period_s > 0.0 ? opt.realtime->period_s : sc.solver.step_s;
  rt.steps_per_tick = std::max<std::int64_t>(1, std::llround(period_s / sc.solver.step_s));
  rt.requested.period_s = period_s;
  // about two seconds of rows, within 4 MB: the writer wakes every 2 ms
  const double rows_per_s = 1.0 / (sc.solver.step_s * static_cast<double>(sc.output.decimation));
  // (clamped as a double before the cast: a tiny step makes rows_per_s too large for size_t)
  const double max_rows = std::max(64.0, static_cast<double>((4u << 20) / (8 * std::max<std::size_t>(columns, 1))));
  rt.queue_rows = static_cast<std::size_t>(std::clamp(2.0 * rows_per_s + 16.0, 64.0, max_rows));
  RowQueue queue(columns, rt.queue_rows);
  std::atomic<std::int64_t> step{0};
  RowWriter writer(queue, csv, std::move(header), out.hash, opt.progress, sc, step, log, opt.driver);
  const auto wall_start = std::chrono::steady_clock::now();
  if (!writer.start(out.csv_error)) return out;
  rt.setup = enter_realtime(rt.requested);

  MonotonicClock clock;
  TickPacer<MonotonicClock> pacer(clock, static_cast<std::int64_t>(std::llround(period_s * 1e9)), rt.timing);
  if (opt.driver != nullptr) opt.driver->start(sim, opt.stop_signal);
  const auto run_start = std::chrono::steady_clock::now();
  start_counting_allocations();
  pacer.start();
  for (;;) {
    // the tick's steps: the runner's loop, with the driver's port inside (its hooks' time is
    // the tick's IO, the rest compute)
    const std::int64_t t0 = clock.now_ns();
    sim.step(rt.steps_per_tick);
    std::int64_t io_ns = opt.driver != nullptr ? opt.driver->take_io_ns() : 0;
    const std::int64_t t = clock.now_ns();
    const std::int64_t compute_ns = t - t0 - io_ns;
    queue.push(sim.rows());
    sim.clear_rows();
    step.store(sim.step_index(), std::memory_order_relaxed);
    io_ns += clock.now_ns() - t;
    rt.timing.compute.record(compute_ns);
    rt.timing.io.record(io_ns);
    if (sim.finished()) break;
    if (opt.stop_signal != nullptr && opt.stop_signal->load() != 0) break;
    if (!pacer.wait_next_tick(opt.stop_signal)) break;
  }
  out.run_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
  leave_realtime(rt.setup);
  if (!sim.finished() && opt.stop_signal != nullptr && opt.stop_signal->load() != 0) {
    out.interrupted_by = opt.stop_signal->load();
    sim.run(opt.stop_signal);  // records the state the run reached, steps nothing
    queue.push(sim.rows());
    sim.clear_rows();
  }
  rt.rows_dropped = queue.dropped();
  out.csv_error = writer.finish();
  stop_counting_allocations(out);  // the writer's last rows included
  if (out.csv_error.empty() && opt.driver != nullptr) opt.driver->flush(out.csv_error);
  if (out.csv_error.empty()) csv.close(out.csv_error);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return out;
}

// Everything the summary says, computed once from the finished simulation.
struct Report {
  RunStats st;
  MetricTotals mt;
  RunFigures fig;
  plant::EnergyAudit audit;
  Streamed run;
  double sim_s = 0.0, distance_m = 0.0, relative = 0.0, fuel_g = 0.0, fuel_L_per_100km = 0.0;
  bool audit_closes = true;
  std::int64_t codec_saturations = 0;
  std::string status = "ok";
  TestRecord test{};
};

Report report_of(Simulation& sim, Streamed run) {
  Report r{sim.stats(), sim.metrics(), sim.figures(), sim.audit(), std::move(run)};
  r.test = sim.test_record();
  r.sim_s = sim.time_s();
  r.codec_saturations = sim.ecu_codec_saturations();
  r.distance_m = r.fig.distance_m.value_or(0.0);
  r.relative = std::abs(r.audit.residual_J) / std::max(r.audit.scale_J, 1.0);
  r.audit_closes = r.relative <= kAuditWarnRelative;
  if (r.fig.fuel_g) {
    r.fuel_g = *r.fig.fuel_g;
    const double litres = r.fuel_g / 1000.0 / r.fig.fuel_density_kg_m3 * 1000.0;
    r.fuel_L_per_100km = r.distance_m > 0.0 ? litres / (r.distance_m / 1e5) : NAN;
  }
  if (r.st.fault != 0) {
    r.status = "fault";
  } else if (r.run.interrupted_by != 0) {
    r.status = "interrupted";
  }
  return r;
}

// A summary figure an expectation checks (hil/config/test_reader.cpp lists them).
double figure_value(const std::string& name, const Report& r, const LinkFigures& link) {
  if (name == "ecu_timeouts") return link.ecu_timeouts;
  if (name == "safe_state_s") return link.safe_state_s;
  if (name == "soc_start") return r.fig.soc_start.value_or(NAN);
  if (name == "soc_end") return r.fig.soc_end.value_or(NAN);
  if (name == "soc_delta") return r.fig.soc_start ? *r.fig.soc_end - *r.fig.soc_start : NAN;
  if (name == "fuel_g") return r.fig.fuel_g ? r.fuel_g : NAN;
  if (name == "distance_m") return r.fig.distance_m ? r.distance_m : NAN;
  if (name == "energy_residual_rel") return r.relative;
  if (name == "plant_fault_steps") return static_cast<double>(r.st.fault_steps);
  if (name == "speed_error_max_kmh") return r.mt.has_speed ? r.mt.speed_error_max_kmh : NAN;
  return NAN;
}

// The verdict of a test: every expectation's outcome as lines, the faults' spans.
TestVerdict verdict_of(const Scenario& sc, const Report& r, const LinkFigures& link) {
  TestVerdict v;
  v.present = sc.test.is_test;
  if (!v.present) return v;
  v.expect_fail = sc.test.expect_fail;
  const double h = sc.solver.step_s;
  bool all = true;
  for (std::size_t i = 0; i < sc.expects.size(); ++i) {
    const ExpectSpec& e = sc.expects[i];
    ExpectOutcome o = i < r.test.outcomes.size() ? r.test.outcomes[i] : ExpectOutcome{};
    if (!e.figure.empty()) {
      o = judge_figure(e, figure_value(e.figure, r, link));
      // a figure of a run that stopped early is not the figure of the run asked for
      if (r.st.fault != 0 || r.run.interrupted_by != 0) {
        o.passed = false;
        o.why = ExpectOutcome::Why::kNotReached;
        o.step = r.st.steps_done;
      }
    }
    ExpectLine line{e, e.name, o.passed, expect_message(e, o, h)};
    const double end_s = static_cast<double>(sc.solver.steps) * h;
    if (e.window == ExpectWindow::kAlways || e.window == ExpectWindow::kEventually) {
      line.window_from_s = static_cast<double>(first_step_at(e.from_s, h)) * h;
      line.window_to_s = std::min(end_s, static_cast<double>(std::min(sc.solver.steps, last_step_at(e.to_s, h))) * h);
    } else if (e.window == ExpectWindow::kWithin && o.event_step >= 0) {
      line.window_from_s = static_cast<double>(o.event_step) * h;
      line.window_to_s = std::min(end_s, line.window_from_s + static_cast<double>(last_step_at(e.within_s, h)) * h);
    } else if (e.window == ExpectWindow::kAtEnd) {
      line.window_from_s = line.window_to_s = end_s;
    }
    if (o.step >= 0) line.time_s = static_cast<double>(o.step) * h;
    line.value = o.value;
    if (!o.passed && v.first_failure.empty()) v.first_failure = e.name + ": " + line.message;
    all = all && o.passed;
    v.expectations.push_back(std::move(line));
  }
  for (std::size_t i = 0; i < sc.faults.size(); ++i) {
    const FaultSpec& f = sc.faults[i];
    FaultLine line{f.name, fault_effect_name(f.effect), f.target};
    if (i < r.test.faults.size() && r.test.faults[i].first_step >= 0) {
      line.first_s = static_cast<double>(r.test.faults[i].first_step) * h;
      line.last_s = static_cast<double>(r.test.faults[i].last_step) * h;
      line.active_steps = r.test.faults[i].steps;
    }
    v.faults.push_back(std::move(line));
  }
  // a run that stopped on a plant fault or a signal did not do what the test asked
  v.all_held = all && r.st.fault == 0 && r.run.interrupted_by == 0;
  if (v.first_failure.empty() && !v.all_held) {
    v.first_failure = r.st.fault != 0 ? "the run stopped on a plant fault: " + fault_text(r.st.fault) : "the run was interrupted";
  }
  v.passed = v.expect_fail ? !v.all_held : v.all_held;
  if (v.expect_fail && v.all_held) v.first_failure = "written to fail (expect_fail = true), but every expectation held";
  return v;
}

io::JsonObject test_json(const TestVerdict& v) {
  io::JsonObject j;
  j.text("verdict", v.passed ? "passed" : "failed");
  j.boolean("expect_fail", v.expect_fail);
  j.boolean("all_expectations_held", v.all_held);
  if (!v.first_failure.empty()) j.text("first_failure", v.first_failure);
  std::vector<io::JsonObject> expects, faults;
  for (const ExpectLine& e : v.expectations) {
    io::JsonObject o;
    o.text("name", e.name);
    o.boolean("passed", e.passed);
    o.text("message", e.message);
    o.number("time_s", e.time_s);
    o.number("value", e.value);
    o.number("window_from_s", e.window_from_s);
    o.number("window_to_s", e.window_to_s);
    io::JsonObject spec;  // what was expected, for a figure or a report of one's own
    const ExpectSpec& x = e.spec;
    if (x.figure.empty()) {
      spec.text("signal", x.signal);
    } else {
      spec.text("figure", x.figure);
    }
    spec.text("window", expect_window_name(x.window));
    if (x.has_min) spec.number("min", x.min);
    if (x.has_max) spec.number("max", x.max);
    if (x.has_near && x.other.empty()) spec.number("value", x.value);
    if (!x.other.empty()) spec.text("other", x.other);
    if (x.has_near) spec.number("tol", x.tol);
    if (x.has_rate) spec.number("rate_max", x.rate_max);
    if (!x.after.empty()) {
      spec.text("after", x.after);
      spec.number("within_s", x.within_s);
    }
    o.object("spec", spec);
    expects.push_back(std::move(o));
  }
  for (const FaultLine& f : v.faults) {
    io::JsonObject o;
    o.text("name", f.name);
    o.text("kind", f.kind);
    o.text("target", f.target);
    o.number("first_s", f.first_s);
    o.number("last_s", f.last_s);
    o.integer("active_steps", f.active_steps);
    faults.push_back(std::move(o));
  }
  j.objects("expectations", expects);
  j.objects("faults", faults);
  return j;
}

std::string test_text(const TestVerdict& v) {
  std::string s;
  for (const FaultLine& f : v.faults) {
    s += "fault         " + f.name + " (" + f.kind + (f.target.empty() ? "" : " " + f.target) + "): " +
         (f.active_steps > 0 ? "acted " + io::number_text(f.first_s) + " .. " + io::number_text(f.last_s) + " s, " +
                                   std::to_string(f.active_steps) + " steps"
                             : std::string("never acted")) +
         "\n";
  }
  for (const ExpectLine& e : v.expectations) {
    s += std::string(e.passed ? "expect ok     " : "EXPECT FAILED ") + e.name + ": " + e.message + "\n";
  }
  s += std::string("verdict       ") + (v.passed ? "passed" : "FAILED") +
       (v.expect_fail ? (v.all_held ? " (written to fail, but every expectation held)" : " (expected failure)") : "") + "\n";
  return s;
}

// The warning of an energy audit that does not close, with its likely causes.
std::string audit_warning(const Scenario& sc, const Report& r) {
  std::string causes;
  if (r.st.newton_failures > 0) causes += std::to_string(r.st.newton_failures) + " implicit-Euler steps did not converge; ";
  if (r.st.chattering_steps > 0) causes += std::to_string(r.st.chattering_steps) + " steps hit the event cap (chattering); ";
  causes += "the step may be too coarse for the dynamics (solver.step_s = " + io::number_text(sc.solver.step_s) +
            " s; the shipped scenarios use 0.001 s)";
  char rel[32];
  std::snprintf(rel, sizeof rel, "%.3g", r.relative);
  return std::string("the energy audit does not close: relative residual ") + rel + " > " +
         io::number_text(kAuditWarnRelative) + ". Likely causes: " + causes + ". Treat the results with care.";
}

double us(std::int64_t ns) { return static_cast<double>(ns) / 1000.0; }

io::JsonObject quantiles_json(const LatencyHistogram& h, bool p999) {
  io::JsonObject q;
  q.number("p50", us(h.quantile_ns(0.5)));
  q.number("p99", us(h.quantile_ns(0.99)));
  if (p999) q.number("p99_9", us(h.quantile_ns(0.999)));
  q.number("max", us(h.max_ns()));
  q.number("mean", h.mean_ns() / 1000.0);
  return q;
}

io::JsonObject realtime_json(const RealtimeRun& rt) {
  io::JsonObject j;
  j.number("period_s", rt.requested.period_s);
  j.integer("steps_per_tick", rt.steps_per_tick);
  j.text("scheduler", rt.setup.fifo ? "SCHED_FIFO" : "SCHED_OTHER");
  j.integer("priority", rt.setup.fifo ? rt.requested.priority : 0);
  if (rt.requested.cpu >= 0) j.integer("cpu", rt.requested.cpu);
  j.boolean("pinned", rt.setup.pinned);
  j.boolean("memory_locked", rt.setup.memory_locked);
  j.boolean("cpu_dma_latency_zero", rt.setup.dma_latency_zero);
  j.integer("ticks", rt.timing.ticks);
  j.integer("overruns", rt.timing.overruns);
  j.integer("missed_ticks", rt.timing.missed_ticks);
  j.integer("queue_rows", static_cast<std::int64_t>(rt.queue_rows));
  j.integer("queue_rows_dropped", rt.rows_dropped);
  j.object("wakeup_latency_us", quantiles_json(rt.timing.wakeup, true));
  j.object("compute_us", quantiles_json(rt.timing.compute, false));
  j.object("io_us", quantiles_json(rt.timing.io, false));
  j.strings("setup_warnings", rt.setup.warnings);
  return j;
}

std::string realtime_text(const RealtimeRun& rt) {
  const TickTiming& t = rt.timing;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "real time     %s%s, period %.6g s (%lld step%s per tick)%s%s: %lld ticks, %lld overruns, "
                "%lld ticks missed\n"
                "  wake-up     p50 %.1f us, p99 %.1f us, p99.9 %.1f us, max %.1f us\n"
                "  compute     p50 %.2f us, p99 %.2f us, max %.1f us; io p50 %.2f us, p99 %.2f us, max %.1f us\n",
                rt.setup.fifo ? "SCHED_FIFO priority " : "SCHED_OTHER",
                rt.setup.fifo ? std::to_string(rt.requested.priority).c_str() : "", rt.requested.period_s,
                static_cast<long long>(rt.steps_per_tick), rt.steps_per_tick == 1 ? "" : "s",
                rt.setup.pinned ? (", CPU " + std::to_string(rt.requested.cpu)).c_str() : "",
                rt.setup.memory_locked ? ", memory locked" : "", static_cast<long long>(t.ticks),
                static_cast<long long>(t.overruns), static_cast<long long>(t.missed_ticks),
                us(t.wakeup.quantile_ns(0.5)), us(t.wakeup.quantile_ns(0.99)), us(t.wakeup.quantile_ns(0.999)),
                us(t.wakeup.max_ns()), us(t.compute.quantile_ns(0.5)), us(t.compute.quantile_ns(0.99)),
                us(t.compute.max_ns()), us(t.io.quantile_ns(0.5)), us(t.io.quantile_ns(0.99)), us(t.io.max_ns()));
  std::string s = buf;
  if (rt.rows_dropped > 0) s += "  WARNING     " + std::to_string(rt.rows_dropped) + " rows dropped: the writer fell behind\n";
  return s;
}

io::JsonObject summary_json(const Scenario& sc, const Report& r, const std::vector<std::string>& warnings,
                            const CommandSource& commands, const std::vector<std::string>& degraded,
                            const TestVerdict& test) {
  io::JsonObject j;
  const RunStats& st = r.st;
  const MetricTotals& mt = r.mt;
  // a status is a claim: a session that ran to its end without its ECU did not do its job
  j.text("status", r.status == "ok" && !degraded.empty() ? "degraded" : r.status);
  if (!degraded.empty()) j.strings("degraded", degraded);
  if (st.fault != 0) {
    j.text("fault", fault_text(st.fault) + " at t = " + io::number_text(st.fault_time_s) + " s (step " +
                        std::to_string(st.fault_step) + ")");
    j.integer("fault_steps", st.fault_steps);
  }
  j.text("scenario", sc.name);
  j.text("description", sc.description);
  if (r.run.interrupted_by != 0) j.text("interrupted_by", signal_name(r.run.interrupted_by));
  j.text("vehicle_file", sc.vehicle_path);
  j.text("cycle_file", sc.cycle_path);
  j.text("solver", solver_name(sc.solver.kind));
  j.number("step_s", sc.solver.step_s);
  j.number("duration_s", r.sim_s);
  j.integer("steps", st.steps_done);
  j.integer("events", st.events);
  j.integer("chattering_steps", st.chattering_steps);
  j.integer("newton_failures", st.newton_failures);
  j.integer("newton_iterations", st.newton_iterations);
  j.integer("output_decimation", sc.output.decimation);
  j.integer("rows_dropped", st.rows_dropped);
  if (sc.ecu_codec == EcuCodec::kCan) j.integer("ecu_codec_saturated_signals", r.codec_saturations);
  j.number("distance_m", r.distance_m);
  if (mt.has_speed) {
    j.number("speed_error_rms_kmh", mt.speed_error_rms_kmh());
    j.number("speed_error_max_kmh", mt.speed_error_max_kmh);
    j.number("locked_time_s", mt.locked_time_s);
  } else {
    j.null("speed_error_rms_kmh");
    j.null("speed_error_max_kmh");
  }
  const double km = r.distance_m / 1000.0;
  j.number("battery_energy_J", r.audit.battery_out_J);
  j.number("battery_Wh_per_km", r.distance_m > 0.0 ? r.audit.battery_out_J / 3600.0 / km : NAN);
  // what left the EMF (terminal energy + battery losses): tracks the SOC drop, and is what
  // the library tutorial reports as Wh/km (MODELS.md §10.3)
  j.number("battery_emf_Wh_per_km",
           r.distance_m > 0.0 ? (r.audit.battery_out_J + r.audit.battery_loss_J) / 3600.0 / km : NAN);
  if (r.fig.soc_start) {
    j.number("soc_start", *r.fig.soc_start);
    j.number("soc_end", *r.fig.soc_end);
  } else {
    j.null("soc_start");
    j.null("soc_end");
  }
  j.number("fuel_g", r.fuel_g);
  j.number("fuel_L_per_100km", r.fuel_L_per_100km);
  if (mt.has_engine) {
    j.number("ice_on_time_s", mt.engine_on_time_s);
    j.integer("ice_starts", mt.engine_starts);
  }
  j.number("energy_balance_residual_J", r.audit.residual_J);
  j.number("energy_balance_relative", r.relative);
  j.boolean("energy_balance_ok", r.audit_closes);
  io::JsonObject terms;
  for (const auto& [k, v] : r.audit.terms) terms.number(k, v);
  j.object("energy_audit", terms);
  j.number("wall_time_s", r.run.wall_s);
  j.number("run_wall_time_s", r.run.run_wall_s);
  j.number("realtime_factor", r.run.run_wall_s > 0.0 ? r.sim_s / r.run.run_wall_s : NAN);
  j.number("ns_per_step", st.steps_done > 0 ? 1e9 * r.run.run_wall_s / st.steps_done : NAN);
  j.text("trajectory_hash", r.run.hash.hex());
  if (r.run.heap_allocations) {
    j.integer("heap_allocations_after_startup", *r.run.heap_allocations);
    if (*r.run.heap_allocations > 0) j.text("first_heap_allocation", r.run.first_allocation);
  } else {
    j.null("heap_allocations_after_startup");  // a binary without the allocation guard
  }
  j.number("peak_rss_MB", static_cast<double>(peak_rss_bytes()) / (1024.0 * 1024.0));
  if (r.run.realtime) j.object("realtime", realtime_json(*r.run.realtime));
  j.strings("warnings", warnings);
  if (test.present) j.object("test", test_json(test));
  j.object("provenance", provenance_json(sc, commands));
  return j;
}

// The lines on the terminal.
std::string summary_text(const Scenario& sc, const Report& r) {
  char buf[256];
  std::string s;
  const RunStats& st = r.st;
  const MetricTotals& mt = r.mt;
  std::snprintf(buf, sizeof buf, "scenario      %s (%s, h = %g s, %lld steps, %lld events)\n", sc.name.c_str(),
                solver_name(sc.solver.kind), sc.solver.step_s, static_cast<long long>(st.steps_done),
                static_cast<long long>(st.events));
  s += buf;
  if (mt.has_speed) {
    std::snprintf(buf, sizeof buf, "distance      %.4f km\nspeed error   rms %.3f km/h, max %.3f km/h\n",
                  r.distance_m / 1000.0, mt.speed_error_rms_kmh(), mt.speed_error_max_kmh);
    s += buf;
  }
  if (r.fig.soc_start) {
    const double wh = r.audit.battery_out_J / 3600.0;
    if (r.distance_m > 0.0) {
      std::snprintf(buf, sizeof buf, "battery       %.1f Wh out, %.1f Wh/km, SOC %.4f -> %.4f\n", wh,
                    wh / (r.distance_m / 1000.0), *r.fig.soc_start, *r.fig.soc_end);
    } else {  // a rig: no distance
      std::snprintf(buf, sizeof buf, "battery       %.1f Wh out, SOC %.4f -> %.4f\n", wh, *r.fig.soc_start,
                    *r.fig.soc_end);
    }
    s += buf;
  }
  if (mt.has_engine) {
    std::snprintf(buf, sizeof buf, "fuel          %.1f g, %.2f L/100 km; engine on %.1f s, %lld start%s\n", r.fuel_g,
                  r.fuel_L_per_100km, mt.engine_on_time_s, static_cast<long long>(mt.engine_starts),
                  mt.engine_starts == 1 ? "" : "s");
    s += buf;
  }
  std::snprintf(buf, sizeof buf, "energy audit  residual %.3g J (relative %.2g)\n", r.audit.residual_J, r.relative);
  s += buf;
  const double rw = r.run.run_wall_s;
  std::snprintf(buf, sizeof buf, "speed         %.0f x real time (%.1f ns per step, %.3f s wall)\n",
                rw > 0 ? r.sim_s / rw : 0.0, st.steps_done > 0 ? 1e9 * rw / st.steps_done : 0.0, r.run.wall_s);
  s += buf;
  if (st.fault != 0) {
    s += "FAULT         " + fault_text(st.fault) + " at t = " + io::number_text(st.fault_time_s) + " s (step " +
         std::to_string(st.fault_step) + ")" +
         (st.fault_steps > 1 ? ", " + std::to_string(st.fault_steps) + " steps with a fault" : std::string()) + "\n";
  }
  if (r.run.realtime) s += realtime_text(*r.run.realtime);
  if (r.run.heap_allocations.value_or(0) > 0) {
    s += "ALLOCATIONS   " + std::to_string(*r.run.heap_allocations) + " heap allocations after start-up; the first: " +
         r.run.first_allocation + "\n";
  }
  if (r.run.interrupted_by != 0) {
    s += "INTERRUPTED   at t = " + io::number_text(r.sim_s) + " s; outputs so far kept\n";
  }
  return s;
}

// The exit code, the warnings and the summary of a finished run.
void conclude(const Scenario& sc, const Report& r, const ExternalDriver* driver, BatchResult& res) {
  if (r.st.fault != 0) {
    res.exit_code = 3;
  } else if (r.run.interrupted_by != 0) {
    res.exit_code = 128 + r.run.interrupted_by;  // the shell's convention: 130 SIGINT, 143 SIGTERM, 129 SIGHUP
  }
  if (!r.audit_closes) res.warnings.push_back(audit_warning(sc, r));
  if (r.run.realtime) {
    for (const std::string& w : r.run.realtime->setup.warnings) res.warnings.push_back(w);
  }
  std::vector<std::string> warnings = sc.warnings;
  warnings.insert(warnings.end(), res.warnings.begin(), res.warnings.end());
  if (driver != nullptr) res.degraded = driver->degraded_reasons();
  res.test = verdict_of(sc, r, driver != nullptr ? driver->link_figures() : LinkFigures{});
  res.summary = summary_json(sc, r, warnings, driver != nullptr ? driver->command_source() : CommandSource{}, res.degraded,
                             res.test);
  res.summary_text = summary_text(sc, r);
  if (res.test.present) res.summary_text += test_text(res.test);
}

}  // namespace

std::string test_verdict_json(const Scenario& sc, Simulation& sim) {
  if (!sc.test.is_test) return "";
  return test_json(verdict_of(sc, report_of(sim, Streamed{}), LinkFigures{})).str();
}

MemoryRun run_in_memory(const Scenario& sc, const std::atomic<int>* stop, ExternalDriver* driver) {
  MemoryRun res;
  if (const std::string why = bus_faults_refused(sc, driver); !why.empty()) {
    res.exit_code = 2;
    res.summary_text = "error: " + why + "\n";
    return res;
  }
  const std::vector<SignalInfo> signals = scenario_signals(sc);
  const std::vector<int> columns = chosen_columns(sc, signals);
  for (const int c : columns) res.columns.emplace_back(signals[static_cast<std::size_t>(c)].name);
  if (!sc.faults.empty()) res.columns.emplace_back("faults_active");
  SimulationOptions sim_opt{columns, kChunkSteps};
  if (driver != nullptr) {  // as run_batch
    sim_opt.external_ecu = true;
    sim_opt.fault_policy = FaultPolicy::kHold;
    driver->discard_files();
  }
  const std::unique_ptr<Simulation> sim = make_simulation(sc, sim_opt);
  if (sc.output.timeseries) {
    // the rows a whole run records (every decimation-th step and the last), so that the vector
    // does not grow in the loop; a longer record than 64 Mi values grows as it goes
    const double rows = static_cast<double>(sim->total_steps()) / static_cast<double>(sc.output.decimation) + 2.0;
    res.rows.reserve(static_cast<std::size_t>(std::min(rows * static_cast<double>(res.columns.size()), 64.0 * 1024 * 1024)));
  }
  MemorySink sink(sc.output.timeseries ? &res.rows : nullptr);
  BatchOptions opt;
  opt.stop_signal = stop;
  opt.driver = driver;
  std::ostringstream no_log;  // no progress line: nothing is written to it
  const Report r = report_of(*sim, stream(*sim, sc, sink, opt, no_log));
  std::string finish_error;
  if (driver != nullptr) driver->finish(finish_error);
  conclude(sc, r, driver, res);
  if (driver != nullptr) driver->report(res.summary, res.summary_text);
  if (!finish_error.empty() && res.exit_code == 0) res.exit_code = 1;
  if (res.exit_code == 0 && !res.degraded.empty()) res.exit_code = kExitDegraded;
  if (res.exit_code == 0 && res.test.present && !res.test.passed) res.exit_code = kExitExpectationFailed;
  return res;
}

// A batch run: columns, the output folder, the simulation streamed to CSV, the summary, the
// commit. Each step is one of the functions above.
std::string bus_faults_refused(const Scenario& sc, const ExternalDriver* driver) {
  const auto f = std::find_if(sc.faults.begin(), sc.faults.end(), [](const FaultSpec& x) { return x.side == FaultSide::kBus; });
  if (f == sc.faults.end() || (driver != nullptr && driver->takes_bus_faults())) return "";
  const std::string what = f->where + ": kind = \"" + fault_effect_name(f->effect) + "\" on " + f->target +
                           " acts on CAN frames, ";
  if (driver != nullptr) {
    return what + "and this session's bus carries none (LCM): run it over socketcand or SocketCAN (--bus socketcand:HOST:PORT)";
  }
  return what + "and this run calls the built-in ECU directly, with no frames between them: run it with `ehpt run "
                "FILE` or `ehpt test FILE` (they put the built-in ECU on an in-process CAN bus), or with an ECU over a "
                "bus (`ehpt plant FILE --bus ...`)";
}

BatchResult run_batch(const Scenario& sc, const BatchOptions& opt, std::ostream& log) {
  BatchResult res;
  // a signal while loading: nothing was run, and an earlier run in DIR stays as it is
  if (opt.stop_signal != nullptr && opt.stop_signal->load() != 0) {
    log << "interrupted by " << signal_name(opt.stop_signal->load()) << " before the run started; nothing was run\n";
    res.exit_code = 128 + opt.stop_signal->load();
    return res;
  }
  if (std::string why; opt.realtime != nullptr && opt.driver != nullptr && !opt.driver->realtime_capable(why)) {
    log << "error: --realtime: " << why << "; nothing was run\n";  // before the output folder
    res.exit_code = 2;
    return res;
  }
  if (const std::string why = bus_faults_refused(sc, opt.driver); !why.empty()) {
    log << "error: " << why << "\n";  // before the output folder: an earlier run in DIR stays
    res.exit_code = 2;
    return res;
  }
  const std::vector<SignalInfo> signals = scenario_signals(sc);
  const std::vector<int> columns = chosen_columns(sc, signals);
  io::OutputDir dir;
  io::TextFileWriter csv;
  std::string error;
  if (!sc.output.timeseries) csv.discard();
  if (!dir.open(opt.out_dir, error) || (sc.output.timeseries && !csv.open(dir.file("timeseries.csv"), error)) ||
      (opt.driver != nullptr && !opt.driver->open(dir, error))) {
    log << "error: " << error << "\n";
    res.exit_code = 1;
    return res;
  }
  std::string header;
  for (std::size_t c = 0; c < columns.size(); ++c) {
    header += (c ? "," : "") + std::string(signals[static_cast<std::size_t>(columns[c])].name);
  }
  // a test's faults: which act at each row, bit i fault i (docs/testing.md)
  const std::size_t width = columns.size() + (sc.faults.empty() ? 0 : 1);
  if (!sc.faults.empty()) header += ",faults_active";
  header += "\n";

  SimulationOptions sim_opt{columns, chunk_steps(sc, width)};
  if (opt.driver != nullptr) {
    sim_opt.external_ecu = true;
    sim_opt.fault_policy = FaultPolicy::kHold;
  }
  const std::unique_ptr<Simulation> sim = make_simulation(sc, sim_opt);
  CsvSink sink(csv, header, width);
  MemorySink hash_only(nullptr);  // output.timeseries off: the rows are hashed, never formatted
  const Report r = report_of(*sim, opt.realtime != nullptr ? stream_realtime(*sim, sc, header, width, csv, opt, log)
                                   : sc.output.timeseries  ? stream(*sim, sc, sink, opt, log)
                                                           : stream(*sim, sc, hash_only, opt, log));
  std::string finish_error;
  if (opt.driver != nullptr && r.run.csv_error.empty()) opt.driver->finish(finish_error);
  conclude(sc, r, opt.driver, res);
  if (opt.driver != nullptr) opt.driver->report(res.summary, res.summary_text);

  if (!finish_error.empty()) {
    log << "error: " << finish_error << " (the run's files are in " << dir.partial_dir() << ")\n";
    res.exit_code = 1;
    return res;
  }
  if (!r.run.csv_error.empty()) {
    log << "error: " << r.run.csv_error << " (the run's files are in " << dir.partial_dir() << ")\n";
    res.exit_code = 1;
    return res;
  }
  if (!io::write_file_atomically(dir.file("summary.json"), res.summary.str() + "\n", error)) {
    log << "error: " << error << " (the run's files are in " << dir.partial_dir() << ")\n";
    res.exit_code = 1;
    return res;
  }
  if (opt.before_commit && !opt.before_commit(dir.partial_dir())) res.after_failed = true;
  // an interrupted run never replaces a complete earlier one: it stays in its own folder
  if (!dir.commit(error, r.run.interrupted_by == 0)) {
    log << "error: " << error << "\n";
    res.exit_code = 1;
  }
  if (res.exit_code == 0 && !res.degraded.empty() && !opt.allow_degraded) res.exit_code = kExitDegraded;
  if (res.exit_code == 0 && res.test.present && !res.test.passed) res.exit_code = kExitExpectationFailed;
  res.results_dir = dir.results_dir();
  for (const std::string& w : dir.warnings()) res.warnings.push_back(w);
  return res;
}

}  // namespace ehpt::hil
