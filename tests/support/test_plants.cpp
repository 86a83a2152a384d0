#include "test_plants.hpp"

#include <unistd.h>

#include <stdexcept>

#include "hil/config.hpp"

namespace ehpt::test {

std::filesystem::path scratch_root() {
  struct Root {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("ehpt_test_" + std::to_string(::getpid()));
    Root() { std::filesystem::create_directories(path); }
    ~Root() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);  // ours: made by this process
    }
  };
  static const Root root;
  return root.path;
}

hil::Scenario load(const std::string& path, const std::vector<std::string>& overrides) {
  hil::Scenario sc;
  std::vector<std::string> errors;
  if (!hil::load_scenario(path, overrides, sc, errors)) {
    throw std::runtime_error(path + ": " + (errors.empty() ? "load failed" : errors.front()));
  }
  return sc;
}

plant::BevParams mbev(const std::string& cycle_file) {
  hil::Scenario sc;
  std::vector<std::string> errors;
  if (!hil::load_scenario(source_path("scenarios/ev_sort1.toml"), {"cycle=\"" + source_path(cycle_file) + "\""}, sc,
                          errors)) {
    throw std::runtime_error(errors.empty() ? "load failed" : errors.front());
  }
  return std::get<plant::BevParams>(sc.plant);
}

}  // namespace ehpt::test
