// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/bus_plant.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <span>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "ecu/shev_ems.hpp"
#include "hil/bus/bus_family.hpp"
#include "hil/bus/bus_wire_can.hpp"
#ifndef EHPT_BUS_NO_LCM  // an FMU's library (CMakeLists.txt: ehpt_fmu_core) speaks CAN only, without liblcm
#include "hil/bus/bus_wire_lcm.hpp"
#endif
#include "hil/run/latency_histogram.hpp"
#include "hil/run/pacer.hpp"
#include "hil/run/port.hpp"
#include "hil/bus/session_log.hpp"
#include "hil/run/simulation.hpp"
#include "io/handoff_buffer.hpp"
#include "io/number_format.hpp"

namespace ehpt::hil {

namespace {

// The plant's side of a bus, over a Wire (hil/bus/bus_wire_can.hpp, hil/bus/bus_wire_lcm.hpp): an
// ECU port of the runner's step loop (hil/run/port.hpp) and, on the wall clock, its pacer;
// the samples, the staleness timeout and safe state, the figures. The wire moves samples out
// and commands in. Lockstep is the port's sample waiting (bounded) for that sample's command.
template <class Sensors, class Wire>
class BusPlant final : public ExternalDriver,
                       public EcuPort<Sensors, typename BusFamily<Sensors>::Command>,
                       public StepPacer {
  using F = BusFamily<Sensors>;
  using Command = typename F::Command;

 public:
  // the wire is built in place from wire_args (it owns files and buffers: not movable)
  template <class... WireArgs>
  BusPlant(const Scenario& sc, const BusPlantOptions& opt, WireArgs&&... wire_args)
      : wire_(std::forward<WireArgs>(wire_args)...),
        opt_(opt),
        h_s_(sc.solver.step_s),
        ratio_(sc.solver.ecu_ratio),
        period_s_(sc.ecu_timing.period_s),
        timeout_s_(opt.command_timeout_s > 0.0 ? opt.command_timeout_s
                                               : std::max(3.0 * sc.ecu_timing.period_s, wire_.command_timeout_s())),
        timeout_steps_(static_cast<std::int64_t>(std::floor(timeout_s_ / sc.solver.step_s + 1e-9))),
        pacer_(clock_, std::max<std::int64_t>(1, static_cast<std::int64_t>(sc.solver.step_s * 1e9))) {
    wire_.set_background_writer(opt.realtime);
  }

  bool open(const io::OutputDir& dir, std::string& error) override {
    if (!wire_.open(dir, error) || !inputs_.open(dir.file(kInputsLogName), error)) return false;
    inputs_buf_.append(inputs_log_header(opt_.scenario_path, opt_.overrides, opt_.faults, F::kFamily, pacing()));
    return true;
  }

  void discard_files() override {
    inputs_.discard();
    no_inputs_log_ = true;
    if constexpr (requires { wire_.discard_files(); }) wire_.discard_files();
  }

  bool realtime_capable(std::string& why) const override {
    if (opt_.lockstep) {
      why = "--lockstep waits for the ECU's command at every sample: it cannot keep a real-time period (use one or the other)";
      return false;
    }
    return true;
  }

  // Before t = 0: the ECU connects and answers sample 0; then the plant is the simulation's
  // port, and on the wall clock its pacer (the real-time loop paces it itself).
  void start(Simulation& sim, const std::atomic<int>* stop) override {
    if (started_) return;
    started_ = true;
    stop_ = stop;
    sim_ = &sim;
    if (opt_.event_mode) {  // sample 0 goes out now; its command comes in the Event Mode after initialization
      Sensors s;
      sim.read_sensors(s);
      send_sample(s, 0);
      sent_ahead_ = 0;
      if (!sim.attach(this, nullptr)) attach_error_ = "the bus plant's messages are not this vehicle's";
      sim.defer_exchange();
      return;
    }
    wait_for_peer();
    first_command(sim);
    if (!sim.attach(this, opt_.lockstep || opt_.realtime ? nullptr : this)) {
      attach_error_ = "the bus plant's messages are not this vehicle's";
    }
  }

  // (event_mode) The sample the simulation stopped at goes out now, ahead of its exchange.
  bool send_ahead() override {
    if (!opt_.event_mode || sim_ == nullptr) return false;
    const std::int64_t n = sim_->step_index();
    if (n % ratio_ != 0 || n == last_sample_ || sim_->finished()) return false;
    const IoTime io(*this);
    read_fault_mask(n);
    Sensors s;
    sim_->read_sensors(s);
    send_sample(s, n);
    sent_ahead_ = n;
    return true;
  }

  // (a) Wall clock and real time: what came in; each complete, fresh command acts from n.
  bool commands_due(std::int64_t n, Command& command) override {
    if (opt_.lockstep) return false;  // a command answers its sample: taken in sample()
    const IoTime io(*this);
    read_fault_mask(n);
    return drain(n, command);
  }
  // (b) The sensors at t_n (sample 0 went out at start-up); lockstep waits for its command.
  bool sample(std::int64_t n, const Sensors& s, Command& command) override {
    const bool ahead = sent_ahead_ == n;  // event_mode: it went out at the end of the last step
    if (n == last_sample_ && !ahead) return false;
    sent_ahead_ = -1;
    const IoTime io(*this);
    if (!ahead) {
      read_fault_mask(n);
      send_sample(s, n);
    }
    if (!opt_.lockstep) return false;
    if (!wire_.sample_intact()) {
      // a bus fault changed what the ECU got of this sample: it may answer or not, at a time
      // the plant cannot know, so the plant goes on without its answer (a late one is stale)
      ++samples_not_awaited_;
      return false;
    }
    if (gave_up_waiting_) return drain(n, command);  // no wait: the ECU is gone (see kMaxConsecutiveWaits)
    return wait_for_command(n, command);
  }
  // (c) The staleness check (lockstep: at its samples and where the held command times out).
  bool before_step(std::int64_t n, Command& command) override {
    if (opt_.lockstep && n % ratio_ != 0 && (safe_ || n < timeout_step())) return false;
    return check_staleness(n, command);
  }
  // The wall clock: step n starts at its deadline; how late each one woke is counted.
  void wait_for_step(std::int64_t n) override {
    pacer_.wait_for_step(n);
    if (n > 0) period_error_.record(clock_.now_ns() - pacer_.last_deadline_ns());
  }

  std::int64_t take_io_ns() override {
    const std::int64_t t = io_ns_;
    io_ns_ = 0;
    return t;
  }

  bool finish(std::string& error) override {
    wire_.finish();
    return flush(error);
  }

  bool flush(std::string& error) override {
    const bool log_ok = wire_.flush(error);
    inputs_buf_.take_all([&](std::string_view t) { write_inputs(t); });
    if (inputs_error_.empty() && inputs_buf_.dropped_bytes() > 0) {
      inputs_error_ = "inputs.log: " + std::to_string(inputs_buf_.dropped_bytes()) +
                      " bytes dropped (the writer fell behind): the session cannot be replayed";
    }
    if (log_ok && !inputs_error_.empty()) error = inputs_error_;
    if (!attach_error_.empty()) error = attach_error_;
    return log_ok && inputs_error_.empty() && attach_error_.empty();
  }

  // The real-time loop's writer thread: what the loop handed over, written off the loop.
  void background_flush() override {
    wire_.background_flush();
    inputs_buf_.take_handed([&](std::string_view t) { write_inputs(t); });
  }

  bool takes_bus_faults() const override { return Wire::kTakesBusFaults; }
  LinkFigures link_figures() const override {
    return {static_cast<double>(timeouts_), static_cast<double>(safe_steps()) * h_s_};
  }
  Wire& wire() { return wire_; }  // start-up: its bus faults

  CommandSource command_source() const override {
    return {"external", "external ECU over " + wire_.describe() + ", " + pacing(), {}};
  }

  std::vector<std::string> degraded_reasons() const override {
    std::vector<std::string> why;
    const auto count = [](std::int64_t n, const char* one, const char* many) {
      return std::to_string(n) + " " + (n == 1 ? one : many);
    };
    if (commands_applied_ == 0) {
      why.push_back("no ECU: not one command in the whole session (none connected, or it never answered)");
    }
    if (timeouts_ > fault_timeouts_) {
      why.push_back("the ECU's commands timed out " + count(timeouts_ - fault_timeouts_, "time", "times") +
                    (fault_timeouts_ > 0 ? " (and " + std::to_string(fault_timeouts_) + " under bus faults)" : "") + ": " +
                    io::number_text(static_cast<double>(safe_steps()) * h_s_) + " s in the safe state");
    }
    if (waits_timed_out_ > 0) {
      why.push_back(count(waits_timed_out_, "lockstep wait", "lockstep waits") + " for the ECU timed out" +
                    (gave_up_at_step_ >= 0 ? "; the plant stopped waiting at t = " +
                                                 io::number_text(static_cast<double>(gave_up_at_step_) * h_s_) + " s after " +
                                                 std::to_string(kMaxConsecutiveWaits) + " in a row"
                                           : ""));
    }
    wire_.degraded_reasons(why);
    return why;
  }

  void report(io::JsonObject& summary, std::string& text) const override {
    io::JsonObject b;
    b.text("transport", wire_.describe());
    b.text("pacing", pacing());
    b.number("ecu_period_s", period_s_);
    b.number("command_timeout_s", timeout_s_);
    std::int64_t rejected = 0;
    wire_.report(b, rejected);
    b.integer("commands_applied", commands_applied_);
    b.integer("stale_samples", stale_samples_);
    b.integer("timeouts", timeouts_);
    if (wire_.has_faults()) {  // hil/bus/bus_faults.hpp; the faults' own figures are the wire's
      b.integer("timeouts_under_bus_faults", fault_timeouts_);
      if (opt_.lockstep) {
        b.integer("samples_not_awaited", samples_not_awaited_);
        b.integer("commands_lost_to_faults", commands_lost_to_faults_);
      }
    }
    b.number("safe_state_time_s", static_cast<double>(safe_steps()) * h_s_);
    b.number("longest_command_gap_s", static_cast<double>(longest_gap_steps_) * h_s_);
    b.integer("saturated_signals", saturated_);
    io::JsonObject timing;
    const LatencyHistogram& hist = opt_.lockstep ? round_trip_ : period_error_;
    timing.number("p50", us(hist.quantile_ns(0.5)));
    timing.number("p99", us(hist.quantile_ns(0.99)));
    timing.number("max", us(hist.max_ns()));
    timing.integer("count", hist.count());
    if (opt_.lockstep) {
      b.integer("lockstep_waits_timed_out", waits_timed_out_);
      b.object("round_trip_us", timing);
      // the exchange's own rate: samples answered from the first command to the last (the
      // wait for the ECU to start is not in it)
      b.number("exchange_s", exchange_s());
      b.number("samples_per_s", samples_per_s());
    } else if (!opt_.realtime && !opt_.event_mode) {  // real time: the loop's own figures ("realtime")
      b.integer("missed_ticks", pacer_.missed_ticks());
      b.object("period_error_us", timing);
    }
    summary.object("bus", b);

    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "bus           %s, %s: %lld %s in, %lld out, %lld rejected; %lld commands, %lld stale samples, "
                  "%lld timeouts (%.3f s in the safe state), longest command gap %.3f s\n",
                  wire_.describe().c_str(), pacing_text(),
                  static_cast<long long>(wire_.messages_in()), Wire::kUnit,
                  static_cast<long long>(wire_.messages_out()), static_cast<long long>(rejected),
                  static_cast<long long>(commands_applied_), static_cast<long long>(stale_samples_),
                  static_cast<long long>(timeouts_), static_cast<double>(safe_steps()) * h_s_,
                  static_cast<double>(longest_gap_steps_) * h_s_);
    text += buf;
    if (opt_.realtime || opt_.event_mode) return;  // no wall time to speak of
    std::snprintf(buf, sizeof buf, "bus timing    %s p50 %.0f us, p99 %.0f us, max %.0f us",
                  opt_.lockstep ? "round trip" : "period error", us(hist.quantile_ns(0.5)),
                  us(hist.quantile_ns(0.99)), us(hist.max_ns()));
    text += buf;
    if (opt_.lockstep && std::isfinite(samples_per_s())) {
      std::snprintf(buf, sizeof buf, "; %.0f samples/s", samples_per_s());
      text += buf;
    }
    text += "\n";
  }

 private:
  // Lockstep: after this many waits in a row ran out the plant stops waiting (it runs on in
  // the safe state, taking any command that comes, and waits again once one does): an ECU
  // that never came, or died, must not make NEDC take 33 h at one sample per wait.
  static constexpr int kMaxConsecutiveWaits = 10;

  static double us(std::int64_t ns) { return static_cast<double>(ns) / 1000.0; }
  double exchange_s() const { return static_cast<double>(last_command_ns_ - first_command_ns_) * 1e-9; }
  double samples_per_s() const {
    return commands_applied_ > 1 && exchange_s() > 0.0 ? static_cast<double>(commands_applied_ - 1) / exchange_s() : NAN;
  }
  const char* pacing() const {
    return opt_.event_mode ? "fmi_event_mode" : opt_.lockstep ? "lockstep" : opt_.realtime ? "realtime" : "wall_clock";
  }
  const char* pacing_text() const {
    return opt_.event_mode ? "FMI Event Mode" : opt_.lockstep ? "lockstep" : opt_.realtime ? "real time" : "wall clock";
  }

  // The bus faults acting at step n, for the wire; remembered for the timeouts they cause.
  void read_fault_mask(std::int64_t n) {
    if (sim_ != nullptr && wire_.set_fault_mask(sim_->fault_mask())) last_bus_fault_step_ = n;
  }

  // steps spent in the safe state (up to the last one seen, if still in it)
  std::int64_t safe_steps() const { return safe_steps_ + (safe_ ? last_step_ - safe_since_step_ : 0); }

  // The real-time loop's IO figure: the port's own time in its hooks (a clock read only there).
  struct IoTime {
    BusPlant& p;
    std::int64_t t0;
    explicit IoTime(BusPlant& plant) : p(plant), t0(plant.opt_.realtime ? plant.rt_clock_.now_ns() : 0) {}
    ~IoTime() {
      if (p.opt_.realtime) p.io_ns_ += p.rt_clock_.now_ns() - t0;
    }
  };

  void wait_for_peer() {
    const std::int64_t deadline = clock_.now_ns() + static_cast<std::int64_t>(opt_.peer_wait_s * 1e9);
    while (!wire_.has_peer() && clock_.now_ns() < deadline) {
      if (stopped()) return;
      wire_.wait(10'000'000);
      wire_.idle();
    }
  }
  bool stopped() const { return stop_ != nullptr && stop_->load(std::memory_order_relaxed) != 0; }

  // t = 0 waits for the ECU's first command (both pacers): sample 0 is sent again every
  // lockstep_wait_s until it answers, up to peer_wait_s (an ECU on SocketCAN or LCM may start
  // after the plant: there is no connection to wait for). A silence after that is a timeout.
  void first_command(Simulation& sim) {
    const std::int64_t deadline = clock_.now_ns() + static_cast<std::int64_t>(opt_.peer_wait_s * 1e9);
    Command command{};
    for (;;) {
      Sensors s;
      sim.read_sensors(s);
      send_sample(s, 0);
      if (wait_for_command(0, command, false)) {
        sim.write_command(command);
        return;
      }
      if (clock_.now_ns() > deadline || stopped()) return;
    }
  }

  // The sensors at t_n, with the plant's status.
  void send_sample(const Sensors& s, std::int64_t n) {
    if (last_sample_ >= 0 && last_sample_ != n && wire_.sample_stale(n, command_since_sample_, ratio_)) ++stale_samples_;
    command_since_sample_ = false;
    last_sample_ = n;
    saturated_ += wire_.send_sample(s, n, safe_);
    sent_ns_ = clock_.now_ns();
  }

  // Until the command of the sample is complete (true), or the wait runs out.
  bool wait_for_command(std::int64_t n, Command& command, bool count = true) {
    const std::int64_t deadline = sent_ns_ + static_cast<std::int64_t>(opt_.lockstep_wait_s * 1e9);
    for (;;) {
      if (drain(n, command)) {
        round_trip_.record(clock_.now_ns() - sent_ns_);
        consecutive_waits_ = 0;
        return true;
      }
      if (wire_.has_faults() && wire_.sample_resolved()) {
        ++commands_lost_to_faults_;  // all of its frames came; a bus fault kept it from being whole
        return false;
      }
      const std::int64_t left = deadline - clock_.now_ns();
      if (left <= 0 || stopped()) {
        if (count && left <= 0) {
          ++waits_timed_out_;
          if (++consecutive_waits_ >= kMaxConsecutiveWaits && !gave_up_waiting_) {
            gave_up_waiting_ = true;
            gave_up_at_step_ = n;
          }
        }
        return false;
      }
      wire_.wait(std::min<std::int64_t>(left, 50'000'000));
    }
  }

  // Everything received; each complete, fresh command goes to the plant. True if one did.
  // Lockstep: the command of this sample only; wall clock, and lockstep after it stopped
  // waiting: one no older than the timeout (so that an ECU that comes back is heard: its
  // answer arrives after the plant, not waiting, has sent the next sample).
  bool drain(std::int64_t n, Command& command) {
    bool applied = false;
    wire_.receive(n, std::max<std::int64_t>(last_sample_, 0), opt_.lockstep && !gave_up_waiting_ ? 0 : timeout_steps_,
                  [&](const Command& c) {
                    apply_command(n, c, command);
                    applied = true;
                  });
    return applied;
  }

  // Every command the plant applies goes through here: to the plant and into inputs.log.
  void write_command(std::int64_t n, const Command& c, Command& command) {
    command = c;
    if (no_inputs_log_) return;
    char line[320];
    const int k = format_command(line, sizeof line - 1, n, c);
    if (k > 0 && static_cast<std::size_t>(k) < sizeof line - 1) {
      line[k] = '\n';
      inputs_buf_.append(std::string_view(line, static_cast<std::size_t>(k) + 1));
    }
    if (!opt_.realtime && inputs_buf_.wants_writer()) {
      inputs_buf_.take_handed([&](std::string_view t) { write_inputs(t); });
    }
  }
  // The loop or the writer thread (never both at once); after a failure nothing more.
  void write_inputs(std::string_view text) {
    if (inputs_error_.empty() && !text.empty()) inputs_.write(text, inputs_error_);
  }

  void apply_command(std::int64_t n, const Command& c, Command& command) {
    if (opt_.lockstep) {  // the exchange rate (the wall-clock pacers keep their own time)
      last_command_ns_ = clock_.now_ns();
      if (commands_applied_ == 0) first_command_ns_ = last_command_ns_;
    }
    applied_ = c;
    write_command(n, applied_, command);
    ++commands_applied_;
    command_since_sample_ = true;
    longest_gap_steps_ = std::max(longest_gap_steps_, n - last_command_step_);
    last_command_step_ = n;
    if (safe_) safe_steps_ += n - safe_since_step_;  // fresh commands end the safe state
    safe_ = false;
    consecutive_waits_ = 0;
    gave_up_waiting_ = false;  // it is back: lockstep waits for it again
  }

  // The first step at which the held command is older than the timeout.
  std::int64_t timeout_step() const { return last_command_step_ + timeout_steps_ + 1; }

  // True if the held command timed out here (the safe one written).
  bool check_staleness(std::int64_t n, Command& command) {
    last_step_ = n;
    if (safe_) {
      longest_gap_steps_ = std::max(longest_gap_steps_, n - last_command_step_);
      return false;
    }
    // the command as a whole, or (a cyclic ECU) one of its messages, is older than its timeout
    if (n < timeout_step() && !wire_.message_timed_out(n)) return false;
    safe_ = true;
    safe_since_step_ = n;
    ++timeouts_;
    // a timeout while (or just after) a bus fault acted is what the fault was for
    if (last_bus_fault_step_ >= 0 && n - last_bus_fault_step_ <= timeout_steps_ + ratio_) ++fault_timeouts_;
    Command safe = applied_;
    F::make_safe(safe);
    write_command(n, safe, command);
    wire_.resync();  // a restarted ECU starts its counters anew
    return true;
  }

  io::TextFileWriter inputs_;
  bool no_inputs_log_ = false;  // a run into memory: no inputs.log, nothing formatted for it
  io::HandoffBuffer inputs_buf_{1 << 20};
  std::string inputs_error_;
  Wire wire_;
  BusPlantOptions opt_;
  double h_s_;
  std::int64_t ratio_;
  double period_s_, timeout_s_;
  std::int64_t timeout_steps_;
  Command applied_{};
  bool started_ = false, safe_ = false, command_since_sample_ = false;
  std::int64_t last_sample_ = -1, last_command_step_ = 0, sent_ns_ = 0;
  std::int64_t sent_ahead_ = -1;  // event_mode: the sample send_ahead (or start-up) sent, not yet exchanged
  std::int64_t commands_applied_ = 0, stale_samples_ = 0, timeouts_ = 0, safe_steps_ = 0, longest_gap_steps_ = 0;
  std::int64_t saturated_ = 0, waits_timed_out_ = 0, safe_since_step_ = 0, last_step_ = 0;
  std::int64_t first_command_ns_ = 0, last_command_ns_ = 0;  // lockstep: the exchange's span
  int consecutive_waits_ = 0;        // lockstep waits that ran out since the last command
  bool gave_up_waiting_ = false;     // kMaxConsecutiveWaits reached: no more waits until a command
  std::int64_t gave_up_at_step_ = -1;
  const std::atomic<int>* stop_ = nullptr;  // ends a wait (start-up, lockstep) when non-zero
  Simulation* sim_ = nullptr;               // its fault mask (bus faults)
  std::int64_t last_bus_fault_step_ = -1;   // the last step a bus fault acted at
  std::int64_t fault_timeouts_ = 0;         // timeouts while or just after a bus fault acted
  std::int64_t samples_not_awaited_ = 0;    // lockstep: samples a bus fault changed (no wait)
  std::int64_t commands_lost_to_faults_ = 0;  // lockstep: samples whose command a bus fault broke
  std::string attach_error_;
  std::int64_t io_ns_ = 0;  // real time: the hooks' time since take_io_ns
  MonotonicClock rt_clock_;
  SteadyClock clock_;
  WallClock<SteadyClock> pacer_;
  LatencyHistogram round_trip_, period_error_;  // ns, 1.6 % resolution
};

}  // namespace

bool can_run_on_bus(const Scenario& sc, std::string& why) {
  // the ECU's messages decide the bus family: every EV kind uses the follower's, the hybrid its own
  if (!sc.ecu.holds<ecu::PsdEcuParams>() && !sc.ecu.holds<ecu::EvFollowerParams>() &&
      !sc.ecu.holds<ecu::ShevEmsParams>()) {
    why = sc.name + ": its vehicle (" + sc.vehicle_path +
          ") has no bus messages (the EV, the power-split and the series hybrid talk to an ECU; the rigs have "
          "no ECU)";
    return false;
  }
  if (sc.solver.ecu_latency_steps != 0) {
    why = sc.name + ": vehicle.ecu.latency_s = " + io::number_text(sc.ecu_timing.latency_s) +
          " belongs to the built-in ECU; on a bus the latency is the bus's own (set it to 0)";
    return false;
  }
  return true;
}

const char* bus_family(const Scenario& sc) {
  if (sc.ecu.holds<ecu::PsdEcuParams>()) return BusFamily<msgs::PsdSensors>::kFamily;
  if (sc.ecu.holds<ecu::ShevEmsParams>()) return BusFamily<msgs::ShevSensors>::kFamily;
  return BusFamily<msgs::EvSensors>::kFamily;
}

std::unique_ptr<ExternalDriver> make_bus_plant(const Scenario& sc, io::can::Transport& bus, const BusPlantOptions& opt,
                                               Binding binding, std::string& error) {
  if (!can_run_on_bus(sc, error)) return nullptr;
  if (binding.family != bus_family(sc)) {
    error = binding.file + ": a binding of the " + binding.family + " plant's fields, but " + sc.name + " is a " +
            bus_family(sc) + " plant";
    return nullptr;
  }
  const double command_timeout_s = opt.command_timeout_s > 0.0 ? opt.command_timeout_s : 3.0 * sc.ecu_timing.period_s;
  // the scenario's bus faults on the frames of this binding (none: nothing changes)
  const auto with_faults = [&](auto plant) -> std::unique_ptr<ExternalDriver> {
    std::vector<std::string> errors;
    BusFaults faults;
    if (!BusFaults::resolve(sc.faults, plant->wire().binding(), sc.solver.step_s, sc.solver.ecu_ratio,
                            bus.sends_error_frames(), faults, errors)) {
      for (const std::string& e : errors) error += (error.empty() ? "" : "\n") + e;
      return nullptr;
    }
    if (!faults.empty() && opt.lockstep && !plant->wire().binding().echo) {
      error = sc.name + ": bus faults in lockstep need a binding whose commands echo the sample they answer (" +
              plant->wire().binding().file + " has no `echo`): without it the plant cannot tell a late frame "
              "from an answer, and the verdict would depend on timing";
      return nullptr;
    }
    plant->wire().set_faults(std::move(faults));
    return plant;
  };
  const auto make = [&](auto tag) {
    using S = decltype(tag);
    return with_faults(std::make_unique<BusPlant<S, CanWire<S>>>(sc, opt, bus, std::move(binding), sc.solver.step_s,
                                                                 opt.lockstep, command_timeout_s, opt.log_interface,
                                                                 opt.asc_log));
  };
  if (sc.ecu.holds<ecu::PsdEcuParams>()) return make(msgs::PsdSensors{});
  if (sc.ecu.holds<ecu::ShevEmsParams>()) return make(msgs::ShevSensors{});
  return make(msgs::EvSensors{});
}

#ifndef EHPT_BUS_NO_LCM
std::unique_ptr<ExternalDriver> make_bus_plant(const Scenario& sc, io::lcm::LcmBus& bus, const BusPlantOptions& opt,
                                               std::string& error) {
  if (!can_run_on_bus(sc, error)) return nullptr;
  if (sc.ecu.holds<ecu::PsdEcuParams>()) {
    using S = msgs::PsdSensors;
    return std::make_unique<BusPlant<S, LcmWire<S>>>(sc, opt, bus, opt.lcm_prefix);
  }
  if (sc.ecu.holds<ecu::ShevEmsParams>()) {
    using S = msgs::ShevSensors;
    return std::make_unique<BusPlant<S, LcmWire<S>>>(sc, opt, bus, opt.lcm_prefix);
  }
  using S = msgs::EvSensors;
  return std::make_unique<BusPlant<S, LcmWire<S>>>(sc, opt, bus, opt.lcm_prefix);
}
#endif

}  // namespace ehpt::hil
