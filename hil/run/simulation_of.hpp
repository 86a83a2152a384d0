// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The one implementation of Simulation, over a plant type, its integrator and its built-in
// ECU (hil/kinds/registry.cpp instantiates it once per vehicle kind and solver). Start-up only
// here; the stepping is Runner's.

#include <memory>
#include <vector>

#include "hil/run/simulation.hpp"

namespace ehpt::hil {

template <class Plant, class Integrator, class Controller = NoController>
class SimulationOf final : public Simulation {
 public:
  // plant and controller are owned here; the runner refers to them (and the fault injector,
  // the one writer of the plant: its health, between steps).
  SimulationOf(const Scenario& sc, const SimulationOptions& opt, std::unique_ptr<Plant> plant,
               std::unique_ptr<Controller> controller, double fuel_density_kg_m3 = 0.0)
      : plant_(std::move(plant)),
        controller_(std::move(controller)),
        fuel_density_kg_m3_(fuel_density_kg_m3) {
    for (const auto& s : plant_->signals()) signals_.push_back({s.name, s.meaning});
    std::vector<int> columns = opt.columns;
    if (columns.empty()) {
      for (std::size_t i = 0; i < signals_.size(); ++i) columns.push_back(static_cast<int>(i));
    }
    const RunnerOptions run{.step_s = sc.solver.step_s,
                            .total_steps = sc.solver.steps,
                            .decimation = sc.output.decimation,
                            .columns = columns,
                            .chunk_steps = opt.chunk_steps,
                            .ecu_ratio = sc.solver.ecu_ratio,
                            .ecu_latency_steps = sc.solver.ecu_latency_steps,
                            .fault_policy = opt.fault_policy,
                            .external_ecu = opt.external_ecu};
    faults_ = std::make_unique<FaultInjector<Plant>>(sc.faults, *plant_, sc.solver.step_s, sc.solver.ecu_ratio);
    expects_ = sc.expects;  // the checker refers to them
    checks_ = std::make_unique<ExpectationChecker<Plant>>(expects_, *plant_, sc.solver.step_s, sc.solver.steps);
    runner_ = std::make_unique<R>(*plant_, run, opt.external_ecu ? nullptr : controller_.get(), nullptr, faults_.get(),
                                  checks_.get());
    values_.resize(signals_.size());
  }

  std::span<const SignalInfo> signals() const override { return signals_; }
  std::int64_t run(const std::atomic<int>* stop) override { return runner_->run(stop); }
  bool finished() const override { return runner_->finished(); }
  std::int64_t step_index() const override { return runner_->step_index(); }
  std::int64_t total_steps() const override { return runner_->total_steps(); }
  double time_s() const override { return runner_->time_s(); }
  std::span<const double> rows() const override { return runner_->rows(); }
  void clear_rows() override { runner_->clear_rows(); }
  std::int64_t step(std::int64_t n) override { return runner_->run(nullptr, n); }
  std::span<const double> outputs() override {
    const auto& y = runner_->last_outputs();
    for (std::size_t i = 0; i < values_.size(); ++i) values_[i] = y.*(plant_->signals()[i].member);
    return values_;
  }
  bool read_sensors(msgs::EvSensors& s) override { return sense_as(s); }
  bool read_sensors(msgs::PsdSensors& s) override { return sense_as(s); }
  bool read_sensors(msgs::ShevSensors& s) override { return sense_as(s); }
  bool write_command(const msgs::EvCommand& c) override { return command_as(c); }
  bool write_command(const msgs::PsdCommand& c) override { return command_as(c); }
  bool write_command(const msgs::ShevCommand& c) override { return command_as(c); }
  bool attach(EcuPort<msgs::EvSensors, msgs::EvCommand>* port, StepPacer* pacer) override {
    return attach_as(port, pacer);
  }
  bool attach(EcuPort<msgs::PsdSensors, msgs::PsdCommand>* port, StepPacer* pacer) override {
    return attach_as(port, pacer);
  }
  bool attach(EcuPort<msgs::ShevSensors, msgs::ShevCommand>* port, StepPacer* pacer) override {
    return attach_as(port, pacer);
  }

  void defer_exchange() override { runner_->defer_exchange(); }
  bool exchange_now() override { return runner_->exchange_now(); }

  const RunStats& stats() const override { return runner_->stats(); }
  const MetricTotals& metrics() const override { return runner_->metrics(); }
  plant::EnergyAudit audit() const override { return plant_->audit(runner_->initial_state(), runner_->state()); }

  std::uint64_t fault_mask() const override { return runner_->fault_mask(); }
  TestRecord test_record() override {
    TestRecord t;
    t.faults = faults_->final_spans();
    const auto o = checks_->finish();
    t.outcomes.assign(o.begin(), o.end());
    return t;
  }

  std::unique_ptr<SimulationState> save_state() const override {
    return std::make_unique<Saved>(*plant_, controller_.get(), *faults_, *checks_, *runner_);
  }
  bool restore_state(const SimulationState& state) override {
    const auto* s = dynamic_cast<const Saved*>(&state);
    if (s == nullptr) return false;
    if constexpr (!std::is_const_v<Plant>) *plant_ = s->plant;  // a const plant never changes (its state is the runner's)
    if (controller_ && s->controller) *controller_ = *s->controller;
    *faults_ = s->faults;
    faults_->rebind(*plant_);
    *checks_ = s->checks;
    runner_->restore_state(s->runner);
    return true;
  }

  std::int64_t ecu_codec_saturations() const override {
    if constexpr (requires(const Controller& c) { c.saturated_signals(); }) {
      return controller_->saturated_signals();
    }
    return 0;
  }

  RunFigures figures() const override {
    // from the outputs the vehicle declares (Plant::kMetrics), at t = 0 and now
    const auto& src = Plant::kMetrics;
    const auto& y1 = runner_->last_outputs();
    RunFigures f;
    if (src.distance_m != nullptr) f.distance_m = y1.*src.distance_m;
    if (src.soc != nullptr) {
      f.soc_start = runner_->initial_outputs().*src.soc;
      f.soc_end = y1.*src.soc;
    }
    if (src.fuel_g != nullptr) f.fuel_g = y1.*src.fuel_g - runner_->initial_outputs().*src.fuel_g;
    f.fuel_density_kg_m3 = fuel_density_kg_m3_;
    return f;
  }

 private:
  using R = Runner<Plant, Integrator, Controller>;
  // save_state's copy: every object whose state moves in a run (their links to each other are
  // the live ones again on restore)
  struct Saved final : SimulationState {
    Saved(const Plant& p, const Controller* c, const FaultInjector<Plant>& f, const ExpectationChecker<Plant>& e,
          const R& r)
        : plant(p), controller(c != nullptr ? std::make_unique<Controller>(*c) : nullptr), faults(f), checks(e), runner(r) {}
    Plant plant;
    std::unique_ptr<Controller> controller;
    FaultInjector<Plant> faults;
    ExpectationChecker<Plant> checks;
    R runner;
  };
  template <class S>
  bool sense_as(S& s) {
    if constexpr (std::is_same_v<S, typename SensorsOf<Plant>::type>) {
      runner_->sense(s);
      return true;
    }
    return false;
  }
  template <class C>
  bool command_as(const C& c) {
    if constexpr (std::is_same_v<C, typename Plant::Inputs>) {
      runner_->set_command(c);
      return true;
    }
    return false;
  }

  template <class S, class C>
  bool attach_as(EcuPort<S, C>* port, StepPacer* pacer) {
    if constexpr (std::is_same_v<S, typename SensorsOf<Plant>::type> && std::is_same_v<C, typename Plant::Inputs>) {
      runner_->attach(port, pacer);
      return true;
    }
    return false;
  }

  std::unique_ptr<Plant> plant_;  // this run's own: its plant faults (FaultInjector) change it between steps
  std::unique_ptr<Controller> controller_;
  double fuel_density_kg_m3_;
  std::vector<SignalInfo> signals_;
  std::vector<double> values_;  // outputs(), sized at start-up
  std::vector<ExpectSpec> expects_;
  std::unique_ptr<FaultInjector<Plant>> faults_;
  std::unique_ptr<ExpectationChecker<Plant>> checks_;
  std::unique_ptr<R> runner_;  // last: it refers to the faults and checks
};

}  // namespace ehpt::hil
