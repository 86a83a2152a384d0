// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Battery with one RC block: Batt1 / Batt1Conn, MODELS.md §6. Paper: P15 §4 (E = E0 + E1*SOC).
//
// Pack of np parallel strings of ns cells. From the + terminal inwards:
//   p -- R0 -- X --+-- [R1 || C1] -- C_batt (the EMF E) -- n
//                  +-- parasitic current source i_p = k |i| (from X to n)
// Discharge current i > 0. i_m = i + i_p flows through the main branch.
//   C_batt dE/dt    = -i_m
//   C1     dv_rc/dt = i_m - v_rc / R1
//   v_term = E - v_rc - R0 i,   SOC = (E - E_min) / (E_max - E_min)
//   P_loss = R0 i^2 + v_rc^2 / R1 + (E - v_rc) i_p
// A plant fault (plant/health.hpp, set_health) scales R0, C_batt, the strings, or adds an
// internal short i_s to i_m (loss (E - v_rc) i_s, like the parasitic source's), between steps.
// The load is an ideal constant-power load P (the drives' DC power, §1.6, §6.5):
//   v_term = (v_int + sqrt(v_int^2 - 4 R0 P)) / 2,  v_int = E - v_rc,  i = P / v_term
//   (no real root: the load asks for more than the pack can give -> fault flag).
// The parasitic coefficient k makes a full charge/discharge swing at constant cell current
// I_eff have the stated round-trip efficiency eta (§6.3, cell values as recommended there):
//   k = [(1-eta)(Ec_max+Ec_min) - 2(1+eta) Rc I_eff] / [(1+eta)(Ec_max+Ec_min) - 2(1-eta) Rc I_eff]
//   with Rc = R0_cell + R1_cell; eta must not exceed eta_max (the value that gives k = 0).
// States: E (V) and v_rc (V). The library's asserts (§6.4) become load-time problems or
// run-time fault flags here.

#include <cmath>
#include <optional>
#include <string>

#include "plant/health.hpp"
#include "plant/problems.hpp"
#include "plant/signals.hpp"

namespace ehpt::plant {

struct BatteryRcParams {
  double cell_capacity_Ah = 10.0;     // QCellNom: charge between E_min and E_max
  double cell_emf_min_V = 3.3;        // cell EMF at SOC = 0
  double cell_emf_max_V = 4.15;       // cell EMF at SOC = 1
  double soc_min = 0.0;
  double soc_max = 1.0;
  double soc_initial = 0.5;
  std::optional<double> cell_current_max_A;          // default 10 C
  std::optional<double> r0_cell_Ohm;                 // default 0.05 * Ec_max / I_max
  std::optional<double> r1_cell_Ohm;                 // default r0_cell_Ohm
  std::optional<double> c1_cell_F;                   // default 60 s / r1_cell_Ohm
  double efficiency = 0.85;                          // round-trip energy efficiency
  std::optional<double> cell_current_efficiency_A;   // I_eff, default 0.5 * I_max
  int cells_series = 1;                              // ns
  int strings_parallel = 1;                          // np
};

// Pack constants, computed once at start-up from the cell data.
struct BatteryRcConstants {
  double c_batt_F = 0.0;        // EMF capacitor
  double emf_min_V = 0.0, emf_max_V = 0.0;
  double r0_Ohm = 0.0, r1_Ohm = 0.0, c1_F = 0.0;
  double current_max_A = 0.0;   // pack
  double k_parasitic = 0.0;
  double efficiency_max = 0.0;  // eta at k = 0
  double soc_min = 0.0, soc_max = 1.0;
  double emf_initial_V = 0.0;
  int strings_parallel = 1;     // np (a lost string scales the pack by (np - k) / np)
};

BatteryRcConstants derive(const BatteryRcParams& p);
void validate(const BatteryRcParams& p, const std::string& at, Problems& problems);

struct BatteryTerminal {
  double voltage_V = 0.0;       // v_term
  double current_A = 0.0;       // i, > 0 discharging
  double parasitic_A = 0.0;     // i_p
  double main_A = 0.0;          // i_m
  double loss_W = 0.0;          // R0 i^2 + v_rc^2/R1 + (E - v_rc) i_p
  bool feasible = true;         // false: constant-power load beyond the pack's maximum power
};

class BatteryRc {
 public:
  static constexpr int kNumStates = 2;
  static constexpr int kEmf = 0, kVrc = 1;  // emf_V, v_rc_V

  BatteryRc() = default;
  explicit BatteryRc(const BatteryRcParams& params)
      : c_(derive(params)),
        inv_c_batt_F_(1.0 / c_.c_batt_F),
        inv_c1_F_(1.0 / c_.c1_F),
        inv_r1_Ohm_(1.0 / c_.r1_Ohm),
        four_r0_Ohm_(4.0 * c_.r0_Ohm),
        healthy_(c_) {}
  // the pack as it is now (after plant faults) and as it was built
  const BatteryRcConstants& constants() const { return c_; }
  const BatteryRcConstants& healthy_constants() const { return healthy_; }

  // Between steps (a plant fault starts or ends), at the pack's state (E, v_rc): its constants
  // from its healthy ones. The states stay (the EMF and SOC do not jump); what the two
  // capacitors held beyond their new size is gone, booked in removed_by_faults_J() for the
  // plant's energy audit. h valid: strings_lost < strings_parallel, gains > 0, short_A >= 0
  // (hil/config/test_reader.cpp).
  void set_health(const BatteryHealth& h, double emf_V, double v_rc_V) {
    const double before_J = stored_energy_J(emf_V, v_rc_V);
    const double keep = static_cast<double>(healthy_.strings_parallel - h.strings_lost) /
                        static_cast<double>(healthy_.strings_parallel);
    c_ = healthy_;
    c_.c_batt_F = healthy_.c_batt_F * keep * h.capacity_gain;
    c_.c1_F = healthy_.c1_F * keep;
    c_.r0_Ohm = healthy_.r0_Ohm / keep * h.r0_gain;
    c_.r1_Ohm = healthy_.r1_Ohm / keep;
    c_.current_max_A = healthy_.current_max_A * keep;
    inv_c_batt_F_ = 1.0 / c_.c_batt_F;
    inv_c1_F_ = 1.0 / c_.c1_F;
    inv_r1_Ohm_ = 1.0 / c_.r1_Ohm;
    four_r0_Ohm_ = 4.0 * c_.r0_Ohm;
    short_A_ = h.short_A;
    removed_by_faults_J_ += before_J - stored_energy_J(emf_V, v_rc_V);
  }
  // The energy set_health took from the capacitors as they shrank (0 for a healthy pack).
  double removed_by_faults_J() const { return removed_by_faults_J_; }

  // Run phase: pure functions.
  BatteryTerminal terminal(double emf_V, double v_rc_V, double load_power_W) const;
  // The same at an imposed terminal current (tests, current-controlled loads).
  BatteryTerminal at_current(double emf_V, double v_rc_V, double current_A) const;
  double demf_dt(const BatteryTerminal& b) const { return -b.main_A * inv_c_batt_F_; }
  double dvrc_dt(const BatteryTerminal& b, double v_rc_V) const {
    return (b.main_A - v_rc_V * inv_r1_Ohm_) * inv_c1_F_;
  }
  double soc(double emf_V) const { return (emf_V - c_.emf_min_V) / (c_.emf_max_V - c_.emf_min_V); }
  // Energy held by the two capacitors; its decrease is what the battery gave out, losses included.
  double stored_energy_J(double emf_V, double v_rc_V) const {
    return 0.5 * c_.c_batt_F * emf_V * emf_V + 0.5 * c_.c1_F * v_rc_V * v_rc_V;
  }
  double healthy_stored_energy_J(double emf_V, double v_rc_V) const {
    return 0.5 * healthy_.c_batt_F * emf_V * emf_V + 0.5 * healthy_.c1_F * v_rc_V * v_rc_V;
  }
  // What the pack gave out (losses included) from (emf0, v_rc0), the pack as built, to (emf,
  // v_rc), the pack as it is now: what plant faults took from the capacitors when they shrank
  // (a lost string, capacity fade) is no energy the pack gave out. Every vehicle's audit.
  double stored_out_J(double emf0_V, double v_rc0_V, double emf_V, double v_rc_V) const {
    return healthy_stored_energy_J(emf0_V, v_rc0_V) - stored_energy_J(emf_V, v_rc_V) - removed_by_faults_J_;
  }
  // §6.4 run-time asserts: SOC window and cell current.
  bool soc_in_window(double emf_V) const {
    const double s = soc(emf_V);
    return s >= c_.soc_min && s <= c_.soc_max;
  }
  bool current_in_limit(double current_A) const { return std::abs(current_A) < c_.current_max_A; }
  // plant::Fault bits for this operating point (SOC window, cell current, infeasible load).
  unsigned faults(double emf_V, const BatteryTerminal& b) const {
    return (soc_in_window(emf_V) ? 0u : kFaultSocWindow) | (current_in_limit(b.current_A) ? 0u : kFaultCellCurrent) |
           (b.feasible ? 0u : kFaultPowerInfeasible);
  }

 private:
  BatteryRcConstants c_;
  double inv_c_batt_F_ = 0.0, inv_c1_F_ = 0.0, inv_r1_Ohm_ = 0.0;
  double four_r0_Ohm_ = 0.0;  // 4 R0, the product terminal() used to form at every call
  double short_A_ = 0.0;      // an internal short's current (0: healthy; + 0.0 changes no bit)
  double removed_by_faults_J_ = 0.0;
  BatteryRcConstants healthy_;
};

// Run phase, inline: the plant's derivative function calls it at every stage.
[[gnu::always_inline]] inline BatteryTerminal BatteryRc::terminal(double emf_V, double v_rc_V, double load_power_W) const {
  const double v_int = emf_V - v_rc_V;
  const double disc = v_int * v_int - four_r0_Ohm_ * load_power_W;  // (4 R0) P, as before
  // beyond the maximum power point (disc < 0): hold at it and flag (the runner stops the run)
  const bool feasible = disc >= 0.0;
  const double voltage_V = 0.5 * (v_int + std::sqrt(feasible ? disc : 0.0));
  const double current_A = load_power_W / voltage_V;
  const double parasitic_A = c_.k_parasitic * std::abs(current_A);
  return {.voltage_V = voltage_V,
          .current_A = current_A,
          .parasitic_A = parasitic_A,
          .main_A = current_A + parasitic_A + short_A_,
          .loss_W = c_.r0_Ohm * current_A * current_A + v_rc_V * v_rc_V * inv_r1_Ohm_ + v_int * (parasitic_A + short_A_),
          .feasible = feasible};
}

}  // namespace ehpt::plant
