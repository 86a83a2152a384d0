// SPDX-License-Identifier: BSD-3-Clause
// genset_rig: TestGenset2 / TestGensetOO (MODELS.md §11.5): the series hybrid's genset on an
// ideal DC source, its power request a trapezoid.
#include "hil/kinds/kind.hpp"

#include "plant/genset_rig.hpp"

namespace ehpt::hil::kinds {

namespace {

plant::GensetRigParams read_genset_rig(Reader& root, Context& ctx) {
  plant::GensetRigParams p;
  p.dc_voltage_V = root.number("dc_voltage_V", p.dc_voltage_V);
  p.off_at_s = root.number("off_at_s", p.off_at_s);
  p.genset = read_genset(root.sub("genset"), ctx);
  p.request_W = read_trapezoid(root.sub("request"), "W");
  return p;
}

KindRead read_genset_rig_kind(Reader& vr, const KindInput& in, Scenario& out, Problems& problems, Problems& warnings,
                              Context& ctx) {
  no_cycle(in, "a genset rig", ctx);
  plant::GensetRigParams p = read_genset_rig(vr, ctx);
  vr.finish();
  plant::validate(p, problems);
  if (problems.empty()) plant::warn(p.genset.generator, "genset.generator", warnings);
  check_signals(plant::GensetRig::kSignals, out.output.signals, ctx);
  check_test_targets_of(plant::GensetRig::kSignals, out, ctx);
  out.plant = std::move(p);
  return {};
}

}  // namespace

// genset_rig: TestGenset2 / TestGensetOO
extern const VehicleKind kind_genset_rig{
    "genset_rig", &typeid(plant::GensetRigParams), read_genset_rig_kind,
    [](const Scenario& sc, const SimulationOptions& opt) {
      const auto& p = sc.plant.get<plant::GensetRigParams>();
      return simulate(sc, opt, std::make_unique<plant::GensetRig>(p), std::unique_ptr<NoController>(),
                      p.genset.ice.fuel_density_kg_m3);
    },
    [](const Scenario& sc) { return signals_of(plant::GensetRig(sc.plant.get<plant::GensetRigParams>())); }};

}  // namespace ehpt::hil::kinds
