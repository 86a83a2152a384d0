// SPDX-License-Identifier: BSD-3-Clause
// The CVODE reference (hil/reference/cvode_reference.hpp): one driver template over (Plant, ECU) that
// reproduces the runner's discrete-time semantics between CVODE restarts.
#include "hil/reference/cvode_reference.hpp"

#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <memory>
#include <type_traits>
#include <variant>

#include "ecu/ev_follower.hpp"
#include "ecu/psd_ecu.hpp"
#include "hil/run/codec_ecu.hpp"
#include "plant/bev_plant.hpp"
#include "plant/ev_machine_plant.hpp"
#include "plant/psd_plant.hpp"
#include "solvers/event_stepper.hpp"

namespace ehpt::hil {

namespace {

// The scale of each state for the absolute tolerance (atol_i = rtol * scale_i): the weighted
// norm is then relative to max(|x_i|, scale_i). A state that starts at zero (distance, fuel,
// the energy integrals) would otherwise be held to an absolute error far below anything that
// matters until it has grown, and force needlessly small steps; a larger scale would lose
// accuracy where the state is small. The scales are the magnitudes below which a state's
// error does not matter for the figures compared: 1 m/s (1e-8 m/s), 10 rad/s of a shaft
// (about 1 m/s of the vehicle through the final gear), 1 m, 1 V (the pack EMF is hundreds of
// V, so its own size governs; v_rc is a few V), 1 g of fuel (the run burns hundreds: 1e-11 kg),
// 1 kJ for the audit's energy integrals (they reach MJ, no derivative reads them).
template <class Layout, class State>
void ev_body_battery_scales(State& s) {
  s[Layout::kDistance] = 1.0;
  s[Layout::kAltitude] = 1.0;
  s[Layout::kRoadJ] = 1e3;
  s[Layout::kBrakeJ] = 1e3;
  s[Layout::kEmf] = 1.0;
  s[Layout::kVrc] = 1.0;
}

template <class Plant>
typename Plant::State state_scales() {
  typename Plant::State s;
  s.setConstant(1e3);  // the energy integrals
  ev_body_battery_scales<Plant>(s);
  if constexpr (std::is_same_v<Plant, plant::PsdPlant>) {
    s[Plant::kIceSpeed] = 10.0;
    s[Plant::kRingSpeed] = 10.0;
    s[Plant::kFuelKg] = 1e-3;
  } else {
    s[Plant::kSpeed] = 1.0;
  }
  return s;
}

// The SUNDIALS objects of one run, freed in reverse order whatever happens.
struct CvodeObjects {
  SUNContext ctx = nullptr;
  N_Vector y = nullptr, atol = nullptr;
  SUNMatrix a = nullptr;
  SUNLinearSolver ls = nullptr;
  void* mem = nullptr;
  CvodeObjects() = default;
  CvodeObjects(const CvodeObjects&) = delete;
  CvodeObjects& operator=(const CvodeObjects&) = delete;
  ~CvodeObjects() {
    if (mem != nullptr) CVodeFree(&mem);
    if (ls != nullptr) SUNLinSolFree(ls);
    if (a != nullptr) SUNMatDestroy(a);
    if (atol != nullptr) N_VDestroy(atol);
    if (y != nullptr) N_VDestroy(y);
    if (ctx != nullptr) SUNContext_Free(&ctx);
  }
};

template <class Plant, class Controller>
class CvodeDriver {
 public:
  using State = typename Plant::State;
  using Modes = typename Plant::Modes;
  using Inputs = typename Plant::Inputs;
  using Outputs = typename Plant::Outputs;
  static constexpr int kN = Plant::kNumStates;
  static constexpr int kZ = Plant::kNumCrossings;
  static constexpr int kMaxEventsPerStep = solvers::EventStepper<Plant, solvers::Rk4<Plant>>::kMaxEventsPerStep;

  CvodeDriver(const Plant& plant, Controller& ecu, const Scenario& sc, const ReferenceOptions& opt)
      : plant_(plant),
        ecu_(ecu),
        opt_(opt),
        h_s_(sc.solver.step_s),
        total_steps_(sc.solver.steps),
        ratio_(std::max<std::int64_t>(1, sc.solver.ecu_ratio)),
        latency_steps_(sc.solver.ecu_latency_steps) {}

  bool run(ReferenceResult& out, std::string& why) {
    out = ReferenceResult{};
    out_ = &out;
    if (!setup(why)) return false;
    x_ = plant_.initial_state();
    m_ = plant_.initial_modes(x_);
    tick(0);
    Outputs y0;
    plant_.outputs(0.0, x_, m_, u_, y0);
    Outputs y1 = y0;
    std::int64_t n = 0;
    for (;;) {
      if (y1.fault != 0.0) {  // the runner's default policy: the first fault stops the run
        out.fault = static_cast<unsigned>(y1.fault);
        out.fault_time_s = time_s(n);
        break;
      }
      if (n >= total_steps_) break;
      std::int64_t next = std::min(total_steps_, (n / ratio_ + 1) * ratio_);
      if (!pending_.empty() && pending_.front().apply_step > n) next = std::min(next, pending_.front().apply_step);
      if (!integrate(time_s(n), time_s(next), why)) return false;
      n = next;
      tick(n);
      plant_.outputs(time_s(n), x_, m_, u_, y1);
      out.end_time_s = time_s(n);
    }
    harvest();
    const auto& src = Plant::kMetrics;
    if (src.distance_m != nullptr) out.figures.distance_m = y1.*src.distance_m;
    if (src.soc != nullptr) {
      out.figures.soc_start = y0.*src.soc;
      out.figures.soc_end = y1.*src.soc;
    }
    if (src.fuel_g != nullptr) out.figures.fuel_g = y1.*src.fuel_g - y0.*src.fuel_g;
    return true;
  }

 private:
  double time_s(std::int64_t n) const { return static_cast<double>(n) * h_s_; }  // as EventStepper::time_s, t0 = 0

  bool setup(std::string& why) {
    CvodeObjects& c = cv_;
    if (SUNContext_Create(nullptr, &c.ctx) != 0) return fail("SUNContext_Create failed", why);
    c.y = N_VNew_Serial(kN, c.ctx);
    c.atol = N_VNew_Serial(kN, c.ctx);
    if (c.y == nullptr || c.atol == nullptr) return fail("N_VNew_Serial failed", why);
    const State scale = state_scales<Plant>();
    for (int i = 0; i < kN; ++i) NV_Ith_S(c.atol, i) = opt_.rtol * opt_.atol_scale * scale[i];
    c.mem = CVodeCreate(CV_BDF, c.ctx);
    if (c.mem == nullptr) return fail("CVodeCreate failed", why);
    CVodeSetErrHandlerFn(c.mem, &CvodeDriver::on_error, this);
    for (int i = 0; i < kN; ++i) NV_Ith_S(c.y, i) = 0.0;
    if (CVodeInit(c.mem, &CvodeDriver::rhs, 0.0, c.y) != CV_SUCCESS) return fail("CVodeInit", why);
    if (CVodeSVtolerances(c.mem, opt_.rtol, c.atol) != CV_SUCCESS) return fail("CVodeSVtolerances", why);
    if (CVodeSetUserData(c.mem, this) != CV_SUCCESS) return fail("CVodeSetUserData", why);
    c.a = SUNDenseMatrix(kN, kN, c.ctx);
    if (c.a == nullptr) return fail("SUNDenseMatrix failed", why);
    c.ls = SUNLinSol_Dense(c.y, c.a, c.ctx);
    if (c.ls == nullptr) return fail("SUNLinSol_Dense failed", why);
    if (CVodeSetLinearSolver(c.mem, c.ls, c.a) != CV_SUCCESS) return fail("CVodeSetLinearSolver", why);
    if (CVodeSetMaxNumSteps(c.mem, opt_.max_steps_per_segment) != CV_SUCCESS) return fail("CVodeSetMaxNumSteps", why);
    if (CVodeSetMaxOrd(c.mem, opt_.max_order) != CV_SUCCESS) return fail("CVodeSetMaxOrd", why);
    if constexpr (kZ > 0) {
      if (CVodeRootInit(c.mem, kZ, &CvodeDriver::roots) != CV_SUCCESS) return fail("CVodeRootInit", why);
      std::array<int, kZ> direction;
      direction.fill(-1);  // z falls through zero: the mode is no longer valid
      if (CVodeSetRootDirection(c.mem, direction.data()) != CV_SUCCESS) return fail("CVodeSetRootDirection", why);
    }
    return true;
  }

  bool fail(const std::string& what, std::string& why) {
    why = what + (last_error_.empty() ? std::string() : ": " + last_error_);
    return false;
  }

  // At grid step n: the commands that are due apply; at an ECU sample the ECU reads the sensors
  // and computes its command (hil::Runner::tick_controller).
  void tick(std::int64_t n) {
    while (!pending_.empty() && pending_.front().apply_step <= n) {
      u_ = pending_.front().command;
      pending_.pop_front();
    }
    if (n % ratio_ != 0) return;
    const msgs::Stamp stamp{time_s(n), n, sensor_sequence_++};
    sensors_.stamp = stamp;
    plant_.sense(stamp.time_s, x_, m_, u_, sensors_);
    Inputs command = u_;
    ecu_.update(sensors_, command);
    command.stamp = msgs::Stamp{stamp.time_s, stamp.step, command_sequence_++};
    if (latency_steps_ == 0) {
      u_ = command;
    } else {
      pending_.push_back({n + latency_steps_, command});
    }
  }

  // From ta to tb with the inputs held: restarts at every event.
  bool integrate(double ta, double tb, std::string& why) {
    double t = ta;
    while (t < tb) {
      if (t >= suspended_until_s_) {
        suspended_until_s_ = -1.0;
        fire_at_start(t);
      }
      const double stop = suspended_until_s_ > t ? std::min(tb, suspended_until_s_) : tb;
      // a remainder below CVODE's resolution of t (a root a hair before the stop time)
      if (stop - t < 1e-9 * h_s_) {
        t = stop;
        continue;
      }
      if (!restart(t, stop, why)) return false;
      double t_ret = t;
      const int flag = CVode(cv_.mem, stop, cv_.y, &t_ret, CV_NORMAL);
      called_ = true;
      if (flag < 0) return fail("CVode at t = " + std::to_string(t) + " s failed (" + std::to_string(flag) + ")", why);
      for (int i = 0; i < kN; ++i) x_[i] = NV_Ith_S(cv_.y, i);
      t = flag == CV_ROOT_RETURN ? t_ret : stop;
      std::array<int, (kZ > 0 ? kZ : 1)> found{};
      if constexpr (kZ > 0) {
        if (flag == CV_ROOT_RETURN) CVodeGetRootInfo(cv_.mem, found.data());
        // a crossing below zero that CVODE did not report (e.g. one that was exactly zero at
        // the restart, which CVODE leaves inactive): it fires at the next segment start, late
        if (suspended_until_s_ < 0.0) {
          std::array<double, kZ> z;
          plant_.crossings(t, x_, m_, u_, z.data());
          for (int i = 0; i < kZ; ++i) out_->late_events += (found[i] == 0 && z[i] < 0.0) ? 1 : 0;
        }
      }
      if (flag == CV_ROOT_RETURN) {
        for (int i = 0; i < kZ; ++i) {
          if (found[i] != 0) {  // several at the same time: the lowest index, the others then fire at once
            if (event(i, t)) ++out_->roots;
            break;
          }
        }
      }
    }
    return true;
  }

  // A segment starts at t (after an input jump or a mode switch): crossings that are already
  // invalid there fire at once, as in the event stepper (z < 0, or z = 0 and falling: the sign
  // of z one small Euler step ahead).
  void fire_at_start(double t) {
    if constexpr (kZ > 0) {
      std::array<double, kZ> z, z_ahead;
      for (;;) {
        if (suspended_until_s_ > t) return;
        plant_.crossings(t, x_, m_, u_, z.data());
        bool ahead_done = false;
        int fired = -1;
        for (int i = 0; i < kZ && fired < 0; ++i) {
          if (z[i] < 0.0) fired = i;
          if (z[i] == 0.0) {
            if (!ahead_done) {
              const double dt = 1e-6 * h_s_;
              State dx;
              plant_.derivatives(t, x_, m_, u_, dx);
              const State x_ahead = x_ + dt * dx;
              plant_.crossings(t + dt, x_ahead, m_, u_, z_ahead.data());
              ahead_done = true;
            }
            if (z_ahead[i] < 0.0) fired = i;
          }
        }
        if (fired < 0) return;
        if (event(fired, t)) ++out_->immediate_events;
      }
    }
  }

  // One event at t: on_crossing, unless the grid step [n h, (n+1) h) holding t has had its
  // kMaxEventsPerStep already: then the rest of that grid step runs in the last mode (false).
  bool event(int i, double t) {
    const auto cell = static_cast<std::int64_t>(std::floor(t / h_s_ + 1e-9));
    if (cell != cell_) {
      cell_ = cell;
      events_in_cell_ = 0;
    }
    if (events_in_cell_ >= kMaxEventsPerStep) {
      ++out_->chattering_steps;
      suspended_until_s_ = time_s(cell + 1);
      return false;
    }
    plant_.on_crossing(i, t, x_, m_, u_);
    ++events_in_cell_;
    ++out_->events;
    return true;
  }

  // CVODE from (t, x) with the current modes and inputs, to the stop time.
  bool restart(double t, double stop, std::string& why) {
    harvest();
    for (int i = 0; i < kN; ++i) NV_Ith_S(cv_.y, i) = x_[i];
    if (CVodeReInit(cv_.mem, t, cv_.y) != CV_SUCCESS) return fail("CVodeReInit", why);
    if (CVodeSetStopTime(cv_.mem, stop) != CV_SUCCESS) return fail("CVodeSetStopTime", why);
    ++out_->restarts;
    return true;
  }

  // CVODE's counters restart with each CVodeReInit: add them up before.
  void harvest() {
    if (!called_) return;
    called_ = false;
    long v = 0;
    if (CVodeGetNumSteps(cv_.mem, &v) == CV_SUCCESS) out_->cvode_steps += v;
    if (CVodeGetNumErrTestFails(cv_.mem, &v) == CV_SUCCESS) out_->error_test_failures += v;
    if (CVodeGetNumNonlinSolvConvFails(cv_.mem, &v) == CV_SUCCESS) out_->nonlinear_failures += v;
    if (CVodeGetNumJacEvals(cv_.mem, &v) == CV_SUCCESS) out_->jacobian_evaluations += v;
  }

  static int rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user) {
    auto& self = *static_cast<CvodeDriver*>(user);
    State x, dx;
    for (int i = 0; i < kN; ++i) x[i] = NV_Ith_S(y, i);
    self.plant_.derivatives(t, x, self.m_, self.u_, dx);
    for (int i = 0; i < kN; ++i) NV_Ith_S(ydot, i) = dx[i];
    ++self.out_->rhs_evaluations;
    return dx.allFinite() ? 0 : 1;  // > 0: recoverable, CVODE tries a smaller step
  }

  static int roots(sunrealtype t, N_Vector y, sunrealtype* z, void* user) {
    auto& self = *static_cast<CvodeDriver*>(user);
    if (self.suspended_until_s_ >= 0.0) {  // chattering: no events until the grid step ends
      for (int i = 0; i < kZ; ++i) z[i] = 1.0;
      return 0;
    }
    State x;
    for (int i = 0; i < kN; ++i) x[i] = NV_Ith_S(y, i);
    self.plant_.crossings(t, x, self.m_, self.u_, z);
    return 0;
  }

  static void on_error(int code, const char* module, const char* function, char* msg, void* user) {
    auto& self = *static_cast<CvodeDriver*>(user);
    if (code < 0) self.last_error_ = std::string(module) + "::" + function + ": " + msg;
  }

  const Plant& plant_;
  Controller& ecu_;
  ReferenceOptions opt_;
  double h_s_;
  std::int64_t total_steps_, ratio_, latency_steps_;
  CvodeObjects cv_;
  ReferenceResult* out_ = nullptr;
  bool called_ = false;  // CVode ran since the last restart: its counters are to be added
  State x_;
  Modes m_{};
  Inputs u_{};
  typename Plant::Sensors sensors_{};
  struct Pending {
    std::int64_t apply_step;
    Inputs command;
  };
  std::deque<Pending> pending_;  // commands computed, not applied yet (latency)
  std::uint32_t sensor_sequence_ = 0, command_sequence_ = 0;
  std::int64_t cell_ = -1;                // grid step of the last event
  int events_in_cell_ = 0;
  double suspended_until_s_ = -1.0;       // chattering: events off until this time
  std::string last_error_;
};

template <class Plant, class Ecu>
bool run_with(const Scenario& sc, const ReferenceOptions& opt, const Plant& plant, std::unique_ptr<Ecu> ecu,
              ReferenceResult& out, std::string& why, double fuel_density_kg_m3 = 0.0) {
  // the built-in ECU through the same codec seam as the product (a pass-through unless
  // ecu.codec = "can"), so that a run with the codec has its reference too
  CodecEcu<Ecu> controller(std::move(ecu), sc.ecu_codec == EcuCodec::kCan);
  const auto t0 = std::chrono::steady_clock::now();
  bool ok = false;
  {
    CvodeDriver<Plant, CodecEcu<Ecu>> driver(plant, controller, sc, opt);
    ok = driver.run(out, why);
  }  // CVODE's memory freed inside the timing
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.figures.fuel_density_kg_m3 = fuel_density_kg_m3;
  return ok;
}

}  // namespace

bool run_cvode_reference(const Scenario& sc, const ReferenceOptions& opt, ReferenceResult& out, std::string& why) {
  if (!(opt.rtol > 0.0) || !(opt.atol_scale > 0.0)) {
    why = "rtol and atol_scale must be > 0";
    return false;
  }
  if (sc.solver.ecu_latency_steps < 0 || sc.solver.steps < 0 || !(sc.solver.step_s > 0.0)) {
    why = "the scenario's solver settings are not valid (load it with load_scenario)";
    return false;
  }
  if (const auto* p = sc.plant.get_if<plant::BevParams>()) {
    const plant::BevPlant plant(*p);
    return run_with(sc, opt, plant, std::make_unique<ecu::EvFollower>(), out, why);
  }
  if (const auto* p = sc.plant.get_if<plant::PsdParams>()) {
    const auto* e = sc.ecu.get_if<ecu::PsdEcuParams>();
    if (e == nullptr) {
      why = "psd without its ECU parameters";
      return false;
    }
    const plant::PsdPlant plant(*p);
    return run_with(sc, opt, plant, std::make_unique<ecu::PsdEcu>(*e, e->period_s), out, why,
                    p->ice.fuel_density_kg_m3);
  }
  if (const auto* p = sc.plant.get_if<plant::EvPmParams>()) {
    const plant::EvPmPlant plant(*p);
    return run_with(sc, opt, plant, std::make_unique<ecu::EvFollower>(), out, why);
  }
  if (const auto* p = sc.plant.get_if<plant::EvAmParams>()) {
    const plant::EvAmPlant plant(*p);
    return run_with(sc, opt, plant, std::make_unique<ecu::EvFollower>(), out, why);
  }
  why = "kind " + sc.kind + ": no CVODE reference (it covers bev, psd, ev_pm and ev_am)";
  return false;
}

}  // namespace ehpt::hil
