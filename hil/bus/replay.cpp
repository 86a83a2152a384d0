// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/replay.hpp"

#include <algorithm>
#include <vector>

#include "hil/run/port.hpp"
#include "hil/run/simulation.hpp"

namespace ehpt::hil {

namespace {

// A recorded session as the runner's ECU port: each record acts from the step it acted from
// in the session, in the same place of the same loop (hil/run/port.hpp) as the bus plant
// applied it; as fast as possible (no pacer). No sample goes anywhere.
template <class Sensors, class Command>
class ReplayDriver final : public ExternalDriver, public EcuPort<Sensors, Command> {
 public:
  ReplayDriver(const std::vector<RecordedCommand<Command>>& records, const InputsLog& log, std::string log_path)
      : records_(records), log_(log), log_path_(std::move(log_path)) {}

  bool open(const io::OutputDir&, std::string&) override { return true; }

  void start(Simulation& sim, const std::atomic<int>*) override {
    if (!sim.attach(this, nullptr)) attach_error_ = log_path_ + ": its family (" + log_.family + ") is not this vehicle's";
  }

  bool commands_due(std::int64_t n, Command& command) override {
    bool applied = false;
    while (next_ < records_.size() && records_[next_].step <= n) {
      command = records_[next_].command;
      ++next_;
      applied = true;
    }
    return applied;
  }
  bool sample(std::int64_t, const Sensors&, Command&) override { return false; }

  bool flush(std::string& error) override {
    if (!attach_error_.empty()) error = attach_error_;
    return attach_error_.empty();
  }

  CommandSource command_source() const override {
    InputFile f = log_.file;
    f.path = log_path_;
    return {"replay", "replay of " + log_path_, {f}};
  }

  void report(io::JsonObject& summary, std::string& text) const override {
    io::JsonObject r;
    r.text("inputs_log", log_path_);
    r.text("recorded_pacing", log_.pacing);
    r.integer("commands_recorded", static_cast<std::int64_t>(records_.size()));
    r.integer("commands_applied", static_cast<std::int64_t>(next_));
    summary.object("replay", r);
    text += "replay        " + std::to_string(next_) + " of " + std::to_string(records_.size()) +
            " recorded commands applied (" + log_.pacing + " session, " + log_path_ + ")\n";
  }

 private:
  const std::vector<RecordedCommand<Command>>& records_;
  const InputsLog& log_;
  std::string log_path_;
  std::size_t next_ = 0;
  std::string attach_error_;
};

}  // namespace

std::unique_ptr<ExternalDriver> make_replay_driver(const InputsLog& log, const std::string& log_path) {
  if (log.family == "psd") {
    return std::make_unique<ReplayDriver<msgs::PsdSensors, msgs::PsdCommand>>(log.psd, log, log_path);
  }
  return std::make_unique<ReplayDriver<msgs::EvSensors, msgs::EvCommand>>(log.ev, log, log_path);
}

}  // namespace ehpt::hil
