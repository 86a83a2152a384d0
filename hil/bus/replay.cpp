// SPDX-License-Identifier: BSD-3-Clause
#include "hil/bus/replay.hpp"

#include <algorithm>
#include <vector>

#include "hil/run/simulation.hpp"

namespace ehpt::hil {

namespace {

template <class Command>
class ReplayDriver final : public ExternalDriver {
 public:
  ReplayDriver(const std::vector<RecordedCommand<Command>>& records, const InputsLog& log, std::string log_path)
      : records_(records), log_(log), log_path_(std::move(log_path)) {}

  bool open(const io::OutputDir&, std::string&) override { return true; }

  // The bus plant's order at every step: the commands of this step, then the step (one at a
  // time, as the wall-clock and real-time pacers take them; the runner makes k single steps
  // and one k-step call the same).
  void advance(Simulation& sim, std::int64_t max_steps, const std::atomic<int>* stop) override {
    const std::int64_t end = std::min(sim.total_steps(), sim.step_index() + max_steps);
    while (!sim.finished() && sim.step_index() <= end) {
      if (stop != nullptr && stop->load(std::memory_order_relaxed) != 0) return;
      const std::int64_t n = sim.step_index();
      while (next_ < records_.size() && records_[next_].step <= n) {
        sim.write_command(records_[next_].command);
        ++next_;
      }
      if (n >= end && n < sim.total_steps()) return;
      sim.step(n < sim.total_steps() ? 1 : 0);
    }
  }

  bool flush(std::string&) override { return true; }

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
};

}  // namespace

std::unique_ptr<ExternalDriver> make_replay_driver(const InputsLog& log, const std::string& log_path) {
  if (log.family == "psd") return std::make_unique<ReplayDriver<msgs::PsdCommand>>(log.psd, log, log_path);
  return std::make_unique<ReplayDriver<msgs::EvCommand>>(log.ev, log, log_path);
}

}  // namespace ehpt::hil
