// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The written contract between a plant and everything that steps it (STYLE.md §4-§6). The
// integrators, the event stepper and the runner take only types that satisfy these concepts,
// so a new vehicle that misses a piece fails to compile with the concept's name, not deep in
// a template.
//
// OdeSystem (integrators), Plant (event stepper), RunnablePlant (runner): a fixed-size state,
// modes that change only at events, inputs held over a step.
//   static constexpr int kNumStates, kNumCrossings;
//   using State = Eigen::Matrix<double, kNumStates, 1>;  struct Modes;  Inputs (a struct or a
//   command message);
//   derivatives(t, x, modes, inputs, dx): dx/dt, a pure function
//   crossings(t, x, modes, inputs, z): the kNumCrossings functions that are > 0 while the
//     mode holds; on_crossing(i, t, x, modes, inputs): the mode switch and its reset
// PlantWithSensors: a Plant that an ECU can close the loop on: sense(t, x, modes, inputs,
//   sensors) fills Plant::Sensors (a sensor message, msgs/).

#include <concepts>

namespace ehpt::solvers {

// What an integrator needs: the derivatives of a fixed-size state.
template <class P>
concept OdeSystem = requires(const P& plant, double t_s, const typename P::State& x, typename P::State& dx,
                             const typename P::Modes& m, const typename P::Inputs& u) {
  { P::kNumStates } -> std::convertible_to<int>;
  plant.derivatives(t_s, x, m, u, dx);
};

// What the event stepper needs: the derivatives and the mode logic.
template <class P>
concept Plant = OdeSystem<P> && requires(const P& plant, double t_s, const typename P::State& x,
                                         typename P::State& x_mut, const typename P::Modes& m,
                                         typename P::Modes& m_mut, const typename P::Inputs& u, double* z) {
  { P::kNumCrossings } -> std::convertible_to<int>;
  plant.crossings(t_s, x, m, u, z);
  plant.on_crossing(0, t_s, x_mut, m_mut, u);
};

// What a runner needs besides: where a run starts, its outputs and what it measures.
template <class P>
concept RunnablePlant = Plant<P> && requires(const P& plant, double t_s, const typename P::State& x,
                                             const typename P::Modes& m, const typename P::Inputs& u,
                                             typename P::Outputs& y) {
  { plant.initial_state() } -> std::convertible_to<typename P::State>;
  { plant.initial_modes(x) } -> std::convertible_to<typename P::Modes>;
  plant.outputs(t_s, x, m, u, y);
  plant.signals();
  P::kMetrics;
};

// Optional: outputs(t, x, modes, inputs, y, dx) fills the outputs and dx/dt from one
// evaluation; the runner then gives dx/dt to the next step as its first stage (the same t, x,
// modes and inputs), saving one evaluation per step with bit-identical results.
template <class P>
concept PlantWithOutputDerivatives =
    RunnablePlant<P> && requires(const P& plant, double t_s, const typename P::State& x, const typename P::Modes& m,
                                 const typename P::Inputs& u, typename P::Outputs& y, typename P::State& dx) {
      plant.outputs(t_s, x, m, u, y, dx);
    };

// Optional: observe(t, x, modes, inputs, y, dx, z) gives, from one evaluation, what the runner
// needs at a grid point it does not record: the fields of y that Plant::kMetrics names and
// fault (the other fields are left as they were), dx/dt and the kNumCrossings crossing
// functions z, each bit-identical to what outputs(), derivatives() and crossings() give at the
// same point. The runner then computes the full outputs only for the rows it records and where
// a caller can read them, and hands dx and z to the next step (its first stage, and the
// crossings at its start).
template <class P>
concept PlantWithObservation =
    PlantWithOutputDerivatives<P> && requires(const P& plant, double t_s, const typename P::State& x,
                                              const typename P::Modes& m, const typename P::Inputs& u,
                                              typename P::Outputs& y, typename P::State& dx, double* z) {
      plant.observe(t_s, x, m, u, y, dx, z);
    };

template <class P>
concept PlantWithSensors = RunnablePlant<P> && requires(const P& plant, double t_s, const typename P::State& x,
                                                const typename P::Modes& m, const typename P::Inputs& u,
                                                typename P::Sensors& s) {
  plant.sense(t_s, x, m, u, s);
};

}  // namespace ehpt::solvers
