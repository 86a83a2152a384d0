// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Faults at the seams where a real one acts (docs/testing.md): on the sensor message the plant
// sends its ECU (after plant.sense, at each sample), on the command it receives (between the
// ECU's command and the plant, at every step) and in the plant itself (its pack, its machines:
// plant/health.hpp, set on the run's own plant where a plant fault starts or ends). Bus faults
// act on frames at the bus plant's wire (hil/bus/bus_faults.hpp); here they have their span
// and their bit in mask(), which the wire reads at each exchange. Built at start-up from the scenario's
// FaultSpecs; the run phase allocates nothing, takes no lock and draws its noise from one
// seeded generator per fault, so a faulted run is the same bit for bit every time (and in a
// replay of its session).
//
// Timing, in whole plant steps h: a fault given by time acts at grid points n with
// ceil(at_s / h) <= n < ceil(until_s / h); one given by `when` from the step after the
// condition first holds on the outputs. A sensor fault changes the samples taken while it
// acts; a command fault the command each step integrates from.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <span>
#include <string_view>
#include <vector>

#include "hil/config/test_spec.hpp"
#include "msgs/fields.hpp"
#include "plant/health.hpp"
#include "plant/signals.hpp"
#include "solvers/plant.hpp"

namespace ehpt::hil {

// The first grid point at or after time t_s (within 1e-9 of a step: a time written as a whole
// number of steps is that step).
inline std::int64_t first_step_at(double t_s, double h_s) {
  const double steps = std::ceil(t_s / h_s - 1e-9);
  // infinity, or a time so far out that it has no step (1e300 s): never, not an overflow
  if (!(steps < 9e18)) return std::numeric_limits<std::int64_t>::max();
  return static_cast<std::int64_t>(steps);
}

// A condition on one output (a member of Outputs), compiled.
template <class Outputs>
struct CompiledCondition {
  double Outputs::*member = nullptr;
  SignalCondition::Op op = SignalCondition::Op::kLess;
  double value = 0.0;
  bool holds(const Outputs& y) const {
    const double x = y.*member;
    switch (op) {
      case SignalCondition::Op::kLess: return x < value;
      case SignalCondition::Op::kLessEqual: return x <= value;
      case SignalCondition::Op::kGreater: return x > value;
      case SignalCondition::Op::kGreaterEqual: return x >= value;
    }
    return false;
  }
};

template <class Outputs>
CompiledCondition<Outputs> compile_condition(const SignalCondition& c, std::span<const plant::Signal<Outputs>> signals) {
  CompiledCondition<Outputs> out;
  for (const auto& s : signals) {
    if (s.name == c.signal) out.member = s.member;
  }
  out.op = c.op;
  out.value = c.value;
  return out;
}

// splitmix64 and Box-Muller: the same normal numbers from the same seed on every machine with
// the same libm (no std:: distribution, whose algorithm is the library's choice).
struct NoiseSource {
  std::uint64_t state = 0;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double normal() {
    const double u1 = (static_cast<double>(next() >> 11) + 1.0) * 0x1.0p-53;  // (0, 1]
    const double u2 = static_cast<double>(next() >> 11) * 0x1.0p-53;          // [0, 1)
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
};

// The sensor message of a plant that has one (Plant::Sensors), else an empty struct.
template <class Plant>
struct SensorsOf {
  struct type {};
};
template <class Plant>
  requires requires { typename Plant::Sensors; }
struct SensorsOf<Plant> {
  using type = typename Plant::Sensors;
};

// When a fault acted: its first and last grid point (-1: never), and how many (the last two
// complete at the end: FaultInjector::final_spans).
struct FaultSpan {
  std::int64_t first_step = -1, last_step = -1, steps = 0;
  std::int64_t end_step = -1;  // the first grid point after it stopped acting for good (-1: it did not)
};

template <class Plant>
class FaultInjector {
 public:
  using Outputs = typename Plant::Outputs;
  using Inputs = typename Plant::Inputs;

  // A plant that takes plant faults (plant/health.hpp).
  static constexpr bool kTakesHealth = requires(Plant& p, const plant::PlantHealth& h, const typename Plant::State& x) {
    p.set_health(h, x);
  };

  // Start-up. ecu_ratio: plant steps per ECU sample (a sensor delay counts samples). plant: the
  // run's own, which plant faults change (between steps: apply_health); it outlives this.
  // After a copy (a saved simulation state restored): the plant of the copy's owner.
  void rebind(Plant& plant) { plant_ = &plant; }

  FaultInjector(std::span<const FaultSpec> specs, Plant& plant, double step_s, std::int64_t ecu_ratio)
      : h_s_(step_s), plant_(&plant) {
    faults_.resize(specs.size());
    spans_.resize(specs.size());
    for (std::size_t i = 0; i < specs.size(); ++i) {
      const FaultSpec& s = specs[i];
      Fault& f = faults_[i];
      f.spec = s;
      f.bit = 1u << i;
      f.start = s.has_when ? kNever : first_step_at(s.at_s, h_s_);
      f.until = first_step_at(s.until_s, h_s_);
      if (s.has_when) {
        f.when = compile_condition<Outputs>(s.when, plant.signals());
        triggers_ = true;
      }
      f.noise.state = s.seed;
      if (s.effect == FaultEffect::kIntermittent) {
        f.period_steps = std::max<std::int64_t>(1, std::llround(s.period_s / h_s_));
        f.on_steps = std::clamp<std::int64_t>(std::llround(s.duty * static_cast<double>(f.period_steps)), 1,
                                              f.period_steps);
      }
      if (s.side == FaultSide::kPlant) {
        plant_bits_ |= f.bit;  // (the reader refused plant faults on plants that take none)
        continue;
      }
      // a bus fault acts on frames, at the bus plant's wire (hil/bus/bus_faults.hpp): here only
      // its span (the mask the wire reads), so a replay of its session has the same column
      if (s.side == FaultSide::kBus) continue;
      if constexpr (solvers::PlantWithSensors<Plant>) {
        using Sensors = typename Plant::Sensors;
        if (s.side == FaultSide::kSensor) {
          for (const auto& field : msgs::FieldTable<Sensors>::kFields) {
            if (field.name == s.target) {
              f.sensor_get = field.get;
              f.sensor_set = field.set;
            }
          }
        } else {
          commands_ = true;
          for (const auto& field : msgs::FieldTable<Inputs>::kFields) {
            if (field.name == s.target) {
              f.command_get = field.get;
              f.command_set = field.set;
            }
          }
          if (s.effect == FaultEffect::kNoStart) {
            for (const auto& field : msgs::FieldTable<Inputs>::kFields) {
              const bool request = field.name == "icePowRef_W" || field.name == "iceTauRef_Nm" || field.name == "gensetPowRef_W";
              if (request && f.zero_count < static_cast<int>(std::size(f.zero_sets))) {
                f.zero_sets[f.zero_count++] = field.set;
              }
            }
          }
        }
        if (s.effect == FaultEffect::kDelay) {
          const double per = s.side == FaultSide::kSensor ? h_s_ * static_cast<double>(ecu_ratio) : h_s_;
          f.delay = std::max<std::int64_t>(1, std::llround(s.delay_s / per));
          f.history.assign(static_cast<std::size_t>(f.delay + 1), 0.0);
        }
      }
    }
  }

  bool empty() const { return faults_.empty(); }
  bool acts_on_commands() const { return commands_; }
  // Whether observe() must see every output at every step (a `when` condition).
  bool needs_outputs() const { return triggers_; }

  // Run phase: which faults act at grid point n (called once per n, in order, before the
  // samples and commands of n). Returns the bits of those acting.
  unsigned begin_step(std::int64_t n) {
    last_begun_ = n;
    if (n < next_change_) return mask_;  // nothing starts or stops before next_change_
    unsigned mask = 0;
    std::int64_t next = kNever;
    for (std::size_t i = 0; i < faults_.size(); ++i) {
      Fault& f = faults_[i];
      bool on = n >= f.start && n < f.until;
      if (on && f.period_steps > 0) on = (n - f.start) % f.period_steps < f.on_steps;
      FaultSpan& sp = spans_[i];
      if (on && !f.active) {  // a span begins
        if (sp.first_step < 0) sp.first_step = n;
        f.span_start = n;
      } else if (!on && f.active) {  // it ends
        sp.steps += n - f.span_start;
        sp.last_step = n - 1;
      }
      // its end: the first grid point past its window, once it has acted
      if (n >= f.until && sp.first_step >= 0 && sp.end_step < 0) sp.end_step = n;
      if (!on) f.holding = false;
      f.active = on;
      if (on) mask |= f.bit;
      // where this fault changes next
      if (n < f.start) {
        next = std::min(next, f.start);  // (kNever for a trigger not yet fired: observe() says)
      } else if (n < f.until) {
        std::int64_t change = f.until;
        if (f.period_steps > 0) {
          const std::int64_t phase = (n - f.start) % f.period_steps;
          change = std::min(change, n - phase + (phase < f.on_steps ? f.on_steps : f.period_steps));
        }
        next = std::min(next, change);
      }
    }
    next_change_ = next;
    if ((mask & plant_bits_) != (mask_ & plant_bits_)) health_due_ = true;
    mask_ = mask;
    return mask;
  }

  // Whether a plant fault started or ended at the grid point begun last: apply_health is due
  // before its samples and its step.
  bool health_due() const { return health_due_; }
  // Run phase, where health_due(): the plant's health from the plant faults acting now, set on
  // the run's plant at its state x (what the pack's capacitors lose is booked in its audit).
  void apply_health(const typename Plant::State& x) {
    health_due_ = false;
    if constexpr (kTakesHealth) {
      static_assert(Plant::kMachines.size() <= plant::kMaxMachines);
      plant::PlantHealth h;
      for (const Fault& f : faults_) {
        if (!f.active || (f.bit & plant_bits_) == 0) continue;
        const FaultSpec& s = f.spec;
        switch (s.effect) {
          case FaultEffect::kR0Gain: h.battery.r0_gain *= s.gain; break;
          case FaultEffect::kCapacityFade: h.battery.capacity_gain *= 1.0 - s.fraction; break;
          case FaultEffect::kInternalShort: h.battery.short_A += s.current_A; break;
          case FaultEffect::kStringLoss: h.battery.strings_lost += s.strings; break;
          case FaultEffect::kDerate: h.torque_gain[static_cast<std::size_t>(s.machine)] *= s.gain; break;
          default: break;
        }
      }
      plant_->set_health(h, x);
    }
  }
  // The spans at the end: those still acting close at the last grid point begun.
  std::vector<FaultSpan> final_spans() const {
    std::vector<FaultSpan> out = spans_;
    for (std::size_t i = 0; i < faults_.size(); ++i) {
      if (faults_[i].active) {
        out[i].steps += last_begun_ - faults_[i].span_start + 1;
        out[i].last_step = last_begun_;
      }
    }
    return out;
  }
  unsigned mask() const { return mask_; }

  // Run phase: the outputs at grid point n, for the `when` conditions (a fault acts from n + 1).
  void observe(std::int64_t n, const Outputs& y) {
    if (!triggers_) return;
    for (Fault& f : faults_) {
      if (f.spec.has_when && f.start == kNever && f.when.holds(y)) {
        f.start = n + 1;
        next_change_ = std::min(next_change_, f.start);
      }
    }
  }

  // Run phase: the sensor message sampled at t_s (the sample of grid point n), faulted.
  template <class Sensors>
  void sensors(std::int64_t n, double t_s, Sensors& s) {
    for (Fault& f : faults_) {
      if (f.sensor_get == nullptr) continue;
      const double healthy = f.sensor_get(s);
      double v = healthy;
      if (apply(f, n, t_s, healthy, v)) f.sensor_set(s, v);
    }
  }

  // Run phase: the command the plant integrates from at grid point n (t_s), from the one the
  // ECU gave. Returns true if a fault acts on it. Called again at the same n (a command that
  // came later in the step's exchange), it gives what the first call would have given for
  // that command: a delay's history and a noise draw advance once per grid point.
  bool commands(std::int64_t n, double t_s, const Inputs& command, Inputs& applied) {
    applied = command;
    bool any = false;
    for (Fault& f : faults_) {
      if (f.command_get == nullptr) continue;
      const double healthy = f.command_get(applied);
      double v = healthy;
      if (!apply(f, n, t_s, healthy, v)) continue;
      any = true;
      f.command_set(applied, v);
      for (int z = 0; z < f.zero_count; ++z) f.zero_sets[z](applied, 0.0);
    }
    return any;
  }

  std::span<const FaultSpan> spans() const { return spans_; }

 private:
  static constexpr std::int64_t kNever = std::numeric_limits<std::int64_t>::max();

  template <class M>
  using Get = double (*)(const M&);
  template <class M>
  using Set = void (*)(M&, double);

  struct Fault {
    FaultSpec spec;
    unsigned bit = 0;
    std::int64_t start = 0, until = 0;
    CompiledCondition<Outputs> when;
    bool active = false, holding = false;
    std::int64_t span_start = 0;  // where its current span began (while active)
    double held = 0.0;
    std::int64_t hold_n = -1;
    NoiseSource noise;
    std::int64_t period_steps = 0, on_steps = 0;  // intermittent
    std::int64_t delay = 0;                        // delay, in samples (sensor) or steps (command)
    std::vector<double> history;                   // the last delay + 1 healthy values, a ring
    std::size_t head = 0;
    std::int64_t pushed = 0;
    std::int64_t last_n = -1;  // the grid point of the last apply
    double draw = 0.0;         // noise: that grid point's draw
    double (*sensor_get)(const typename SensorsOf<Plant>::type&) = nullptr;
    void (*sensor_set)(typename SensorsOf<Plant>::type&, double) = nullptr;
    Get<Inputs> command_get = nullptr;
    Set<Inputs> command_set = nullptr;
    Set<Inputs> zero_sets[2] = {nullptr, nullptr};  // no_start: the engine's requests (PSD 2, SHEV 1)
    int zero_count = 0;
  };

  // v: the faulted value of a healthy one, at a sample or step at t_s; false if the fault does
  // not act now (a delay keeps its history either way).
  bool apply(Fault& f, std::int64_t n, double t_s, double healthy, double& v) {
    const bool again = n == f.last_n;
    f.last_n = n;
    if (f.delay > 0) {
      const std::size_t size = f.history.size();
      if (!again) {
        f.head = (f.head + 1) % size;
        ++f.pushed;
      }
      f.history[f.head] = healthy;
      // the value delay samples (steps) back; before there is one, the first
      const std::int64_t back = std::min<std::int64_t>(f.delay, f.pushed - 1);
      if (!f.active) return false;
      v = f.history[(f.head + size - static_cast<std::size_t>(back)) % size];
      return true;
    }
    if (!f.active) return false;
    const FaultSpec& s = f.spec;
    switch (s.effect) {
      case FaultEffect::kStuck:
        // the value of its first grid point (the last command given there, if given twice)
        if (!f.holding || f.hold_n == n) {
          f.holding = true;
          f.hold_n = n;
          f.held = healthy;
        }
        v = f.held;
        break;
      case FaultEffect::kFixed: v = s.value; break;
      case FaultEffect::kOffset: v = healthy + s.offset; break;
      case FaultEffect::kGain: v = healthy * s.gain; break;
      case FaultEffect::kNoise:
        if (!again) f.draw = f.noise.normal();
        v = healthy + s.sigma * f.draw;
        break;
      case FaultEffect::kDrift: v = healthy + s.rate * (t_s - static_cast<double>(f.start) * h_s_); break;
      case FaultEffect::kDelay: break;
      case FaultEffect::kQuantise: v = std::round(healthy / s.step) * s.step; break;
      case FaultEffect::kIntermittent: v = s.value; break;
      case FaultEffect::kSaturate: v = std::clamp(healthy, -s.limit, s.limit); break;
      case FaultEffect::kLoss: v = 0.0; break;
      case FaultEffect::kNoStart: v = 0.0; break;
      case FaultEffect::kR0Gain:  // plant faults: apply_health, not a value
      case FaultEffect::kCapacityFade:
      case FaultEffect::kInternalShort:
      case FaultEffect::kStringLoss:
      case FaultEffect::kDerate: return false;
      case FaultEffect::kDrop:  // bus faults: on frames, at the bus plant's wire (hil/bus/bus_faults.hpp)
      case FaultEffect::kDuplicate:
      case FaultEffect::kReorder:
      case FaultEffect::kCorrupt:
      case FaultEffect::kCounterFreeze:
      case FaultEffect::kCounterJump:
      case FaultEffect::kBadCrc:
      case FaultEffect::kStop:
      case FaultEffect::kPeriod:
      case FaultEffect::kBusOff:
      case FaultEffect::kErrorFrames: return false;
    }
    return true;
  }

  double h_s_;
  Plant* plant_;
  unsigned plant_bits_ = 0;  // the plant faults' bits
  bool health_due_ = false;
  std::vector<Fault> faults_;
  std::vector<FaultSpan> spans_;
  unsigned mask_ = 0;
  std::int64_t next_change_ = 0;   // the next grid point where a fault may start or stop
  std::int64_t last_begun_ = -1;   // the last grid point begin_step saw
  bool commands_ = false, triggers_ = false;
};

}  // namespace ehpt::hil
