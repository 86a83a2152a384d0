// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What an ehpt FMU is made of, as a pure function of a loaded scenario: its variables (value
// references, names, units, causality) and its modelDescription.xml. `ehpt fmu` writes the
// description from it and the FMU's library (targets/fmu/fmu_instance.hpp) answers by the same
// table, so the two cannot disagree. FMI 3.0 co-simulation (fmi-standard.org).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "hil/config/config.hpp"

namespace ehpt::fmu {

enum class Causality { kIndependent, kOutput };

struct Variable {
  std::uint32_t vr = 0;      // valueReference: 0 is time; outputs from 1 in signal order
  std::string name;          // as in `ehpt signals` (time_s is FMI's "time")
  std::string unit;          // "" without unit
  std::string description;
  Causality causality = Causality::kOutput;
  int signal = -1;           // its index in the simulation's signals() (outputs)
};

struct Description {
  std::string model_name;     // the scenario's name
  std::string description;    // the scenario's
  double step_s = 0.0;        // the plant step: fixedInternalStepSize
  double stop_s = 0.0;        // the scenario's duration: DefaultExperiment stopTime
  std::vector<Variable> variables;
};

Description describe(const hil::Scenario& sc);

// The SI unit of a signal name's suffix (speed_m_s -> "m/s"); "" for a quantity without one
// (soc, iceON, driverRequest).
std::string unit_of(std::string_view signal_name);

// modelDescription.xml (FMI 3.0, co-simulation); token: the instantiationToken the library
// checks; generation_tool: "ehpt VERSION".
std::string model_description_3(const Description& d, const std::string& model_identifier, const std::string& token,
                                const std::string& generation_tool);

}  // namespace ehpt::fmu
