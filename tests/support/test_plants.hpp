#pragma once
// Parameter sets shared by several tests (the shipped MBEV, a coast-down vehicle, cycles).

#include <string>

#include "hil/config.hpp"
#include "plant/bev_plant.hpp"

namespace ehpt::test {

inline std::string source_path(const std::string& rel) { return std::string(EHPT_SOURCE_DIR) + "/" + rel; }

// A scenario through the real loader (aborts the test on problems).
hil::Scenario load(const std::string& path, const std::vector<std::string>& overrides = {});

// MBEV as in vehicles/mbev.toml, loaded through the real loader with the given cycle.
plant::BevParams mbev(const std::string& cycle_file = "data/cycles/cycle_sort1.csv");

}  // namespace ehpt::test
