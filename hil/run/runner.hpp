// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The runner core (STYLE.md §8), ehpt's one step loop: per step the commands due and the ECU
// sample (the built-in ECU with its period and latency, or an ECU port from outside: a bus,
// a replayed session; hil/run/port.hpp), advance() on the fixed grid t0 + n h, the outputs,
// the pacer (none: as fast as possible; wall clock; lockstep is a port that waits for its
// command), and small policies composed around it: Recorder (rows), Metrics (declared by
// the vehicle), FaultPolicy (stop or hold). A plant with an observation (solvers/plant.hpp) gives, at the grid points
// that are not recorded, only what the metrics and the fault policy read, with dx/dt and the
// crossing functions for the next step; the full outputs are computed where they are recorded
// or can be read (see observe()). Start-up sizes every buffer; run() allocates nothing, does no I/O and takes
// no lock, so a target can call it in chunks and write the recorded rows between chunks
// (progress and bounded memory on long runs). Every pacer gives the same trajectory.

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <type_traits>
#include <vector>

#include "hil/run/expectations.hpp"
#include "hil/run/fault_injector.hpp"
#include "hil/run/metrics.hpp"
#include "hil/run/port.hpp"
#include "hil/run/recorder.hpp"
#include "msgs/stamp.hpp"
#include "plant/observation.hpp"
#include "plant/signals.hpp"
#include "solvers/event_stepper.hpp"

namespace ehpt::hil {

struct RunStats {
  std::int64_t steps_done = 0;
  std::int64_t events = 0;
  std::int64_t chattering_steps = 0;
  std::int64_t newton_failures = 0;
  std::int64_t newton_iterations = 0;
  // first fault (plant::Fault bits), with where it happened
  unsigned fault = 0;
  double fault_time_s = 0.0;
  std::int64_t fault_step = 0;
  // grid points with any fault bit set: 1 when the fault stops the run; under the hold
  // policy (HIL) every point the fault lasted, or came back
  std::int64_t fault_steps = 0;
  std::int64_t rows_dropped = 0;  // rows not recorded because the buffer was not drained
};

// What a fault does to the run: stop it (batch runs: exit 3, outputs kept) or hold on (an
// HIL plant keeps running and reports the fault on the bus; the first one is recorded).
enum class FaultPolicy { kStop, kHold };

// How many runs in this process have stopped on a fault: a test guard (tests/support) fails
// any test whose run raised a fault it did not expect. Touched once per faulted run.
inline std::atomic<std::int64_t> g_runs_with_fault{0};

// What a run is: its grid, its record, its ECU's timing and its fault policy (start-up only).
struct RunnerOptions {
  double step_s = 1e-3;               // the fixed grid t0 + n step_s
  std::int64_t total_steps = 0;       // the run ends at step total_steps
  std::int64_t decimation = 1;        // a row every decimation steps from step 0 (and the last)
  std::vector<int> columns;           // indices into plant.signals() to record
  std::int64_t chunk_steps = 50000;   // most steps one run() call may take; sizes the row buffer
  std::int64_t ecu_ratio = 1;         // an ECU sample every ecu_ratio steps from step 0
  std::int64_t ecu_latency_steps = 0; // a command acts this many steps after its sample
  FaultPolicy fault_policy = FaultPolicy::kStop;
  // true: no built-in ECU; run() stops at each ECU sample for the caller (sense, set_command)
  bool external_ecu = false;
};

// A runner without a controller: the plant's inputs stay as constructed.
struct NoController {};

// Controller: a discrete-time ECU, update(const Plant::Sensors&, Plant::Inputs& command), run
// every `controller_ratio` steps. At its sample step n the plant writes the sensor message
// (plant.sense at t_n, stamped {t_n, n, sequence}); the command computed from it (stamped
// with the same sample) applies from step n + latency_steps on and is held until the next
// one applies. The built-in ECU, a lockstep bus ECU and a recorded session are then the same
// discrete-time system. latency_steps = 0 (the default): the command acts from the sample
// it was computed from, as the library's continuous ECUs do and as a lockstep SIL (the plant
// waits for the command) can honour exactly.
template <class Plant, class Integrator, class Controller = NoController>
  requires solvers::RunnablePlant<Plant> && (std::is_same_v<Controller, NoController> || solvers::PlantWithSensors<Plant>)
class Runner {
 public:
  using State = typename Plant::State;
  using Modes = typename Plant::Modes;
  using Inputs = typename Plant::Inputs;
  using Outputs = typename Plant::Outputs;
  using Sensors = typename SensorsOf<Plant>::type;
  using Port = EcuPort<Sensors, Inputs>;

  // pacer: when each step may start (none: at once). faults, checks: a test's faults at the
  // message seams and its expectations on the outputs (none: a plain run; both outlive the runner)
  Runner(const Plant& plant, const RunnerOptions& opt, Controller* controller = nullptr, StepPacer* pacer = nullptr,
         FaultInjector<Plant>* faults = nullptr, ExpectationChecker<Plant>* checks = nullptr)
      : plant_(&plant),
        faults_(faults != nullptr && !faults->empty() ? faults : nullptr),
        checks_(checks != nullptr && !checks->empty() ? checks : nullptr),
        external_ecu_(opt.external_ecu),
        controller_(controller),
        pacer_(pacer),
        fault_policy_(opt.fault_policy),
        controller_ratio_(opt.ecu_ratio),
        latency_steps_(opt.ecu_latency_steps),
        integrator_(plant),
        stepper_(plant, integrator_, 0.0, opt.step_s),
        total_steps_(opt.total_steps),
        chunk_steps_(opt.chunk_steps),
        recorder_(plant.signals(), opt.columns, opt.decimation, opt.chunk_steps,
                  faults_ != nullptr ? &fault_mask_ : nullptr),
        metrics_(Plant::kMetrics, opt.step_s),
        decimation_(opt.decimation) {
    // commands in flight: one per ECU period of latency, and one more
    pending_.resize(static_cast<std::size_t>(latency_steps_ / std::max<std::int64_t>(1, controller_ratio_) + 2));
    x0_ = plant.initial_state();
    x_ = x0_;
    m_ = plant.initial_modes(x_);
    // every output at every step where an expectation or a fault's condition reads them
    full_outputs_ = checks_ != nullptr || (faults_ != nullptr && faults_->needs_outputs());
    if (pacer_ != nullptr) pacer_->wait_for_step(0);
    begin_faults(0);
    tick_controller(0);
    if (!external_ecu_) actuate(0);  // an outside ECU's first command is yet to come
    if (external_ecu_) {
      awaiting_command_ = true;  // the caller reads the sensors at t_0 and writes a command first
    } else {
      observe(0);
    }
  }

  // Run phase: advances up to chunk_steps, or max_steps if fewer (no allocation, no I/O but a
  // port's own). Returns steps taken. stop: a flag (e.g. the number of a signal) that ends
  // the run when non-zero.
  std::int64_t run(const std::atomic<int>* stop = nullptr,
                   std::int64_t max_steps = std::numeric_limits<std::int64_t>::max()) {
    const std::int64_t start = n_;
    // one loop, compiled twice: without a port and a pacer (batch runs) nothing of them is
    // tested per step
    if (port_ != nullptr || pacer_ != nullptr) {
      loop<true>(stop, max_steps);
    } else {
      loop<false>(stop, max_steps);
    }
    stats_.steps_done = n_;
    stats_.rows_dropped = recorder_.dropped();
    return n_ - start;
  }

  // Start-up (external_ecu): the ECU port from now on (the caller no longer steps to each
  // sample), and the pacer, told that step n may start. The port's first exchange is at the
  // current step, in the next run().
  void attach(Port* port, StepPacer* pacer) {
    port_ = port;
    pacer_ = pacer;
    if (pacer_ != nullptr) pacer_->wait_for_step(n_);
  }
  // Start-up, with a port whose command of a sample comes after run() returned (an LS-BUS
  // FMU: the sample goes out at the end of the doStep that reached it, its command comes in
  // the Event Mode that follows): the exchange at a run's last grid point is left for
  // exchange_now() or the next run(), also at the end of the run.
  void defer_exchange() { defer_exchange_ = true; }
  // Between run()s: the port's exchange at the current grid point, if it has not been (once
  // per grid point, as in the loop): its command applies and, at a sample step, the outputs
  // at t_n follow. False without a port.
  bool exchange_now() {
    if (port_ == nullptr || stopped_by_fault()) return false;
    exchange(n_);
    return true;
  }

  // Start-up only (a saved state restored: an FMU's fmi3SetFMUState): this runner takes saved's
  // state, a copy of this runner (or of one built alike) made earlier, and keeps its own links:
  // plant, controller, pacer, port, faults, checks, and what refers into it (the stepper to
  // its integrator, the recorder to its fault bits). May allocate (the copy's buffers).
  void restore_state(const Runner& saved) {
    const Plant* plant = plant_;
    Controller* controller = controller_;
    StepPacer* pacer = pacer_;
    Port* port = port_;
    FaultInjector<Plant>* faults = faults_;
    ExpectationChecker<Plant>* checks = checks_;
    *this = saved;
    plant_ = plant;
    controller_ = controller;
    pacer_ = pacer;
    port_ = port;
    faults_ = faults;
    checks_ = checks;
    integrator_.rebind(*plant_);
    stepper_.rebind(*plant_, integrator_);
    recorder_.rebind_bits(faults_ != nullptr ? &fault_mask_ : nullptr);
  }

  // For an ECU outside the runner (external_ecu: a bus, a Python callback, a test): run()
  // stops at each ECU sample step; the caller reads the sensor message there (stamped like the
  // built-in ECU's) and writes the command, which acts from that step on; the next run()
  // takes the outputs at that step and goes on. The same discrete-time system, bit for bit.
  template <class S>
    requires std::is_same_v<S, typename SensorsOf<Plant>::type>
  void sense(S& sensors) {
    sensors.stamp = msgs::Stamp{stepper_.time_s(n_), n_, sensor_sequence_++};
    plant_->sense(sensors.stamp.time_s, x_, m_, u(), sensors);
    if (faults_ != nullptr) faults_->sensors(n_, sensors.stamp.time_s, sensors);
    sensors_ = sensors;  // a sample step is sampled once: a port's exchange there gets this one
    sensed_step_ = n_;
  }
  void set_command(const Inputs& command) {
    inputs_ = command;
    actuate(n_);
    dx_observed_step_ = -1;  // taken with the old command
  }
  // The ECU's command (what a command fault acts on) and what the plant integrates from.
  const Inputs& command() const { return inputs_; }
  const Inputs& applied_command() const { return u(); }
  // The faults acting at the current step (bit i: the scenario's fault i).
  unsigned fault_mask() const { return fault_mask_; }

  bool finished() const { return (n_ >= total_steps_ && !awaiting_command_) || stopped_by_fault(); }
  std::int64_t step_index() const { return n_; }
  std::int64_t total_steps() const { return total_steps_; }
  double time_s() const { return stepper_.time_s(n_); }
  const RunStats& stats() const { return stats_; }
  const MetricTotals& metrics() const { return metrics_.totals(); }
  const State& state() const { return x_; }
  const State& initial_state() const { return x0_; }
  const Modes& modes() const { return m_; }
  const Outputs& last_outputs() const { return y_; }
  const Outputs& initial_outputs() const { return y0_; }  // at t_0 (once observed)

  // Recorded rows since the last take (row-major, columns as given); clears the buffer.
  std::span<const double> rows() const { return recorder_.rows(); }
  void clear_rows() { recorder_.clear(); }

 private:
  template <bool kPaced>
  void loop(const std::atomic<int>* stop, std::int64_t max_steps) {
    const std::int64_t end = std::min(total_steps_, n_ + std::min(chunk_steps_, max_steps));
    run_end_ = end;
    if (awaiting_command_ && !has_port<kPaced>()) {  // the caller's command for this sample is in: the outputs at t_n
      awaiting_command_ = false;
      actuate(n_);
      observe(n_);
    }
    while (n_ < end && !stopped_by_fault()) {
      if (stop != nullptr && stop->load(std::memory_order_relaxed) != 0) {
        if (awaiting_command_) {  // a port's sample step, not exchanged: the plant as it got there
          awaiting_command_ = false;
          observe(n_);
        }
        complete_outputs(n_);
        recorder_.record(n_, y_);  // an interrupted run still ends with the state it reached
        break;
      }
      if (has_port<kPaced>()) exchange(n_);
      // dx/dt (and the crossing functions) at t_n came with the outputs at t_n when nothing has
      // moved since (same x, modes, inputs): the integrator's first stage and the crossings at
      // the step's start, evaluations saved, the same result
      const bool observed = dx_observed_step_ == n_;
      const solvers::StepReport r = stepper_.advance(n_, x_, m_, u(), observed ? &dx_observed_ : nullptr,
                                                     observed && z_observed_ ? z_observed_values_.data() : nullptr);
      dx_observed_step_ = -1;
      stats_.events += r.events;
      stats_.chattering_steps += r.chattering ? 1 : 0;
      stats_.newton_failures += r.converged ? 0 : 1;
      stats_.newton_iterations += r.iterations;
      ++n_;
      if constexpr (kPaced) {
        if (pacer_ != nullptr) pacer_->wait_for_step(n_);
      }
      begin_faults(n_);
      tick_controller(n_);
      // the sensors of a sample are read with the command in force until then (the built-in
      // ECU's were, in tick_controller); an outside ECU's command acts once it has come
      if (faults_ != nullptr && (!external_ecu_ || n_ % controller_ratio_ != 0)) actuate(n_);
      if (external_ecu_ && n_ % controller_ratio_ == 0) {
        // an ECU sample: the outputs at t_n follow with its command (as the built-in ECU's
        // do): from the port's exchange, or back to the caller, who reads the sensors at t_n
        // and writes the command
        awaiting_command_ = true;
        if (has_port<kPaced>()) continue;
        break;
      }
      observe(n_);
    }
    // the last grid point, a sample step: its sample goes out and its command is in (and logged)
    if (has_port<kPaced>() && n_ == total_steps_ && awaiting_command_ && !stopped_by_fault() && !defer_exchange_) {
      exchange(n_);
    }
  }

  template <bool kPaced>
  bool has_port() const {
    if constexpr (kPaced) return port_ != nullptr;
    return false;
  }

  // Run phase: the port's exchange at grid point n (hil/run/port.hpp), once per grid point;
  // at a sample step the outputs at t_n after it.
  void exchange(std::int64_t n) {
    if (exchanged_step_ == n) return;
    exchanged_step_ = n;
    bool changed = port_->commands_due(n, inputs_);
    if constexpr (solvers::PlantWithSensors<Plant>) {
      if (n % controller_ratio_ == 0) {
        if (sensed_step_ != n) sense(sensors_);  // (the caller read it at start-up: the one it sent)
        changed = port_->sample(n, sensors_, inputs_) || changed;
      }
    }
    changed = port_->before_step(n, inputs_) || changed;
    // a command fault acts on the command that came (at a sample step: the one of this sample)
    if (changed || n % controller_ratio_ == 0) actuate(n);
    if (changed) dx_observed_step_ = -1;  // taken with the old command
    if (awaiting_command_) {
      awaiting_command_ = false;
      observe(n);
    }
  }

  bool stopped_by_fault() const { return fault_policy_ == FaultPolicy::kStop && stats_.fault != 0; }

  // Run phase: commands that are due apply; at a sample step the ECU reads the sensors at
  // t_n and computes its next command (applied now, or latency_steps later).
  [[gnu::always_inline]] void tick_controller(std::int64_t n) {
    if constexpr (!std::is_same_v<Controller, NoController>) {
      if (controller_ == nullptr) return;
      while (pending_count_ > 0 && pending_[pending_head_].apply_step <= n) {
        inputs_ = pending_[pending_head_].command;
        pending_head_ = (pending_head_ + 1) % pending_.size();
        --pending_count_;
      }
      // a sample every controller_ratio steps from step 0 (n % ratio == 0: n comes 0, 1, 2, ...)
      if (n != next_sample_step_) return;
      next_sample_step_ = n + controller_ratio_;
      const msgs::Stamp stamp{stepper_.time_s(n), n, sensor_sequence_++};
      sensors_.stamp = stamp;
      plant_->sense(stamp.time_s, x_, m_, u(), sensors_);
      if (faults_ != nullptr) faults_->sensors(n, stamp.time_s, sensors_);
      Inputs command = inputs_;  // what the ECU does not set stays as it was
      controller_->update(sensors_, command);
      command.stamp = msgs::Stamp{stamp.time_s, stamp.step, command_sequence_++};
      if (latency_steps_ == 0) {
        inputs_ = command;
      } else if (pending_count_ < pending_.size()) {  // sized so that it cannot be full
        pending_[(pending_head_ + pending_count_) % pending_.size()] = {n + latency_steps_, command};
        ++pending_count_;
      }
    }
  }

  // Run phase: outputs at grid point n, metrics, the fault policy and the record. The full
  // outputs where they are recorded or can be read (row 0 and every decimation-th, the last
  // step, a first fault, the last step of this run() call and the step before an external
  // ECU's sample, after which run() returns); elsewhere the plant's observation (what the
  // metrics and the fault policy read), when it has one. Either way y_ holds the full outputs
  // at the last grid point observed whenever run() returns.
  [[gnu::always_inline]] void observe(std::int64_t n) {
    const double t_s = stepper_.time_s(n);
    // a row every decimation steps from step 0 (recorder_.due(n): n comes 0, 1, 2, ..., once each)
    const bool row_due = n == next_row_step_;
    if (row_due) next_row_step_ = n + decimation_;
    if constexpr (solvers::PlantWithObservation<Plant>) {
      const bool full = full_outputs_ || row_due || n == total_steps_ || n == run_end_ ||
                        (external_ecu_ && (n + 1) % controller_ratio_ == 0);
      if (!full) {
        plant_->observe(t_s, x_, m_, u(), y_, dx_observed_, z_observed_values_.data());
        dx_observed_step_ = n;
        z_observed_ = true;
        y_full_ = false;
      } else {
        rare_observe_all(n);
      }
    } else {
      outputs_at(n);
    }
    if (n == 0) y0_ = y_;
    metrics_.template observe<Plant::kMetrics>(n, y_);
    if (faults_ != nullptr || checks_ != nullptr) [[unlikely]] {
      test_observe(n);
    }
    const auto fault = static_cast<unsigned>(y_.fault);
    if (fault != 0) ++stats_.fault_steps;
    if (fault != 0 && stats_.fault == 0) {
      stats_.fault = fault;
      stats_.fault_time_s = t_s;
      stats_.fault_step = n;
      g_runs_with_fault.fetch_add(1, std::memory_order_relaxed);
      complete_outputs(n);  // its row, and the outputs a stopped run ends with
    }
    if (row_due || n == total_steps_ || (fault != 0 && stats_.fault_step == n)) recorder_.record(n, y_);
  }

  // The command the plant integrates from: the ECU's, or what a command fault made of it.
  [[gnu::always_inline]] const Inputs& u() const { return actuating_ ? applied_ : inputs_; }

  // Run phase: which faults act at grid point n, before its sample and command (once per n).
  [[gnu::always_inline]] void begin_faults(std::int64_t n) {
    if (faults_ != nullptr) [[unlikely]] {
      fault_mask_ = faults_->begin_step(n);
      if (faults_->health_due()) {  // a plant fault starts or ends: the plant changes here
        faults_->apply_health(x_);
        dx_observed_step_ = -1;
      }
    }
  }
  // Run phase: the command faults on the command in force at grid point n.
  [[gnu::always_inline]] void actuate(std::int64_t n) {
    if (faults_ != nullptr && faults_->acts_on_commands()) [[unlikely]] {
      const bool was = actuating_;
      actuating_ = faults_->commands(n, stepper_.time_s(n), inputs_, applied_);
      if (actuating_ || was) dx_observed_step_ = -1;  // dx/dt taken with another command
    }
  }
  // Run phase: the outputs at grid point n for the faults' conditions and the expectations
  // (once per n).
  [[gnu::noinline]] void test_observe(std::int64_t n) {
    if (n == tested_step_) return;
    tested_step_ = n;
    complete_outputs(n);
    if (faults_ != nullptr) faults_->observe(n, y_);
    if (checks_ != nullptr) {
      checks_->observe(n, y_, faults_ != nullptr ? faults_->spans() : std::span<const FaultSpan>{});
    }
  }

  // Run phase: the full outputs at grid point n (and dx/dt there, if the plant gives it).
  void outputs_at(std::int64_t n) {
    const double t_s = stepper_.time_s(n);
    if constexpr (solvers::PlantWithOutputDerivatives<Plant>) {
      plant_->outputs(t_s, x_, m_, u(), y_, dx_observed_);
      dx_observed_step_ = n;
    } else {
      plant_->outputs(t_s, x_, m_, u(), y_);
    }
    z_observed_ = false;
    y_full_ = true;
  }
  // The same out of line, where a plant with an observation needs them (a recorded row, the end
  // of a run() call): the step's loop stays small.
  [[gnu::noinline]] void rare_outputs_at(std::int64_t n) { outputs_at(n); }
  // The full outputs at grid point n with dx/dt and the crossing functions from the same
  // evaluation (a plant's observe<kAll>), for the next step's start as observe() gives them: a
  // test reads every output at every step, and the crossings there would cost another call.
  [[gnu::noinline]] void rare_observe_all(std::int64_t n) {
    if constexpr (requires(const Plant& p, const State& x, const Modes& m, const Inputs& u, Outputs& y, State& dx,
                           double* z) { p.template observe<plant::OutputSet::kAll>(0.0, x, m, u, y, dx, z); }) {
      plant_->template observe<plant::OutputSet::kAll>(stepper_.time_s(n), x_, m_, u(), y_, dx_observed_,
                                                      z_observed_values_.data());
      dx_observed_step_ = n;
      z_observed_ = true;
      y_full_ = true;
    } else {
      outputs_at(n);
    }
  }
  // Run phase: the full outputs at grid point n if only the observation was taken there (the
  // same x, modes and inputs: nothing has moved since observe(n) in this run() call).
  void complete_outputs(std::int64_t n) {
    if (!y_full_) rare_outputs_at(n);
  }

  const Plant* plant_;
  FaultInjector<Plant>* faults_ = nullptr;       // a test's faults, or none
  ExpectationChecker<Plant>* checks_ = nullptr;  // a test's expectations, or none
  unsigned fault_mask_ = 0;                      // the faults acting at the current step
  bool actuating_ = false;                       // a command fault acts: the plant gets applied_
  bool full_outputs_ = false;                    // every output at every step (faults' conditions, expectations)
  std::int64_t tested_step_ = -1;                // the last grid point test_observe saw
  bool external_ecu_ = false;      // the caller is the ECU: it is asked at every sample step
  bool awaiting_command_ = false;  // stopped at a sample step, the outputs there not yet taken
  Controller* controller_;
  StepPacer* pacer_;
  Port* port_ = nullptr;            // the ECU outside (attach), or none
  std::int64_t exchanged_step_ = -1;  // the last grid point the port exchanged at
  bool defer_exchange_ = false;       // the port's command comes between run()s (defer_exchange)
  std::int64_t sensed_step_ = -1;     // the last grid point sense() read
  FaultPolicy fault_policy_;
  std::int64_t controller_ratio_, latency_steps_;
  struct Pending {
    std::int64_t apply_step = 0;
    Inputs command{};
  };
  std::vector<Pending> pending_;  // ring of commands not applied yet
  std::size_t pending_head_ = 0, pending_count_ = 0;
  std::uint32_t sensor_sequence_ = 0, command_sequence_ = 0;
  Integrator integrator_;
  solvers::EventStepper<Plant, Integrator> stepper_;
  std::int64_t total_steps_, chunk_steps_;
  Recorder<Outputs> recorder_;
  Metrics<Outputs> metrics_;
  std::int64_t n_ = 0;
  State x0_, x_;
  Modes m_{};
  Inputs inputs_{};   // the ECU's command
  Inputs applied_{};  // what the plant integrates from while a command fault acts
  typename SensorsOf<Plant>::type sensors_{};
  Outputs y_{}, y0_{};
  State dx_observed_;                   // dx/dt with the outputs at step dx_observed_step_
  std::int64_t dx_observed_step_ = -1;  // -1: none that the next step may use
  // the crossing functions there, when the plant's observation gave them (z_observed_)
  std::array<double, (Plant::kNumCrossings > 0 ? Plant::kNumCrossings : 1)> z_observed_values_{};
  bool z_observed_ = false;
  bool y_full_ = true;             // y_ holds every output (not only the observation)
  std::int64_t run_end_ = 0;       // the step the current run() call ends at
  std::int64_t decimation_;        // the recorder's: a row every decimation steps
  std::int64_t next_row_step_ = 0, next_sample_step_ = 0;  // the next row, the next ECU sample
  RunStats stats_;
};

}  // namespace ehpt::hil
