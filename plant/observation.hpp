// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The runner's observation (solvers/plant.hpp, PlantWithObservation) from one source per plant.
//
// A plant with observe() writes its outputs once, in one function template
//   template <OutputSet kSet> void outputs_from(const Eval&, t, x, modes, inputs, Outputs& y)
// that fills every field for kSet == kAll (outputs()) and, for kObserved (observe()), only the
// fields the runner reads at every step: those Plant::kMetrics names, and fault. The other
// fields sit under `if constexpr (kSet == OutputSet::kAll)`, so an observed field has one
// expression for both and the two cannot drift apart; tests/plant/observation_test.cpp checks,
// for every plant of ObservedPlants over a whole cycle, that observe() fills exactly those
// fields, bit for bit as outputs(), and dx/dt and z as derivatives() and crossings().
// observe<OutputSet::kAll>() is the same with every field: what the runner takes at each step
// of a test (expectations read any output), still one evaluation for y, dx/dt and z.
//
// Every plant with observe() is listed in ObservedPlants below: its observe() asserts it
// (static_assert(kObservationTested<...>)), and the test runs one case per entry of the list
// (a plant without a case does not compile), so a new plant cannot be left out of the test.

#include <type_traits>

namespace ehpt::plant {

enum class OutputSet {
  kAll,       // outputs(): every field
  kObserved,  // observe(): the fields kMetrics names, and fault; the others left as they were
};

template <class... Plants>
struct PlantList {};

template <class Drive>
class EvPlant;
class MapMachine;
class PmMachine;
class AmMachine;
class PsdPlant;

// Every plant with observe(), in the order of the test's cases.
using ObservedPlants = PlantList<EvPlant<MapMachine>, EvPlant<PmMachine>, EvPlant<AmMachine>, PsdPlant>;

// Whether Plant is in a PlantList (a class template, not a function: a call would look up
// names in the listed plants and so need them complete).
template <class Plant, class List>
struct ListedIn;
template <class Plant, class... Plants>
struct ListedIn<Plant, PlantList<Plants...>> : std::bool_constant<(std::is_same_v<Plant, Plants> || ...)> {};
template <class Plant>
inline constexpr bool kObservationTested = ListedIn<Plant, ObservedPlants>::value;

}  // namespace ehpt::plant
