// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// A bus binding: which signal of a DBC carries which plant input or output (docs/binding.md).
// An ECU that comes with its own CAN matrix is connected the way dSPACE's Bus Manager, CANoe
// and VeriStand connect one: the user names, for each plant field, the `Message.Signal` of
// their DBC that carries it, with its unit; the plant then sends and receives exactly those
// frames. ehpt's own contract (io/can/ehpt.dbc) is one binding among others: the default one,
// io/can/ehpt-psd.binding.toml and io/can/ehpt-ev.binding.toml, read through the same code.
//
// Start-up only: load_binding reads the TOML file and its DBC and checks everything the run
// phase relies on (every name resolves, units convert, directions match the DBC's senders, no
// plant input bound twice, every input either bound or given a value, E2E layouts fit). Every
// problem is "file:line: ..." with a close-match suggestion where a name is unknown.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "io/can/dbc.hpp"
#include "io/can/e2e.hpp"

namespace ehpt::hil {

// What a bound signal carries.
enum class BoundRole : std::uint8_t {
  kField,       // a field of the family's sensors (sent) or command (received), msgs/fields.hpp
  kPlantStep,   // sent: the plant's step index of the sample (PlantStatus.step)
  kEcuTimeout,  // sent: 1 while the plant is in its safe state (PlantStatus.ecuTimeout)
  kCounter,     // a rolling counter: +1 per frame sent; received, checked by the codec's rule
  kEcho,        // received: the step of the sample the command answers (ehpt's sampleStep)
};

struct BoundSignal {
  const io::can::DbcSignal* signal = nullptr;  // into Binding::dbc (its messages never move after load)
  BoundRole role = BoundRole::kField;
  int field = -1;       // kField: index into the family's field table (msgs/fields.hpp)
  double to_si = 1.0;   // the field's value = the signal's physical value * to_si
  io::can::RawRange raw;  // integer signals: what the codec's rule allows (io::can::codec_raw_range)
  std::uint64_t mask_bit = 0;  // received kField: its bit in the completion mask
};

struct BoundMessage {
  const io::can::DbcMessage* message = nullptr;
  bool send = false;        // the plant sends it (else: the ECU sends, the plant receives)
  int line = 0;             // of its [[send]] / [[receive]] table in the binding
  int cycle_ms = 0;         // sent: its cycle (0: every ECU sample)
  double timeout_s = 0.0;   // received: older than this puts the plant in its safe state
  std::vector<BoundSignal> signals;  // bound fields and roles (the DBC's other signals: start values)
  std::optional<io::can::E2eConfig> e2e;
  std::vector<const io::can::DbcSignal*> e2e_signals;  // its CRC and counter: no field may be bound to them
};

struct Binding {
  Binding() = default;
  Binding(Binding&&) = default;  // moved, never copied: the bound signals point into dbc
  Binding& operator=(Binding&&) = default;
  Binding(const Binding&) = delete;
  Binding& operator=(const Binding&) = delete;

  std::string file;       // the binding file as given ("<built-in ehpt-psd>" for the default)
  std::string family;     // "psd", "ev" or "shev": the scenario's (the field names are its messages')
  io::can::Dbc dbc;
  std::string plant_node;  // the DBC node the plant plays
  std::vector<BoundMessage> send, receive;  // in the binding's order: the order frames go out
  // command fields no signal carries, and the value they hold (field index, value)
  std::vector<std::pair<int, double>> unbound;
  std::uint64_t complete_mask = 0;  // every received field's bit: a whole command
  bool echo = false;                // a received message carries kEcho (ehpt's contract)
  std::vector<std::string> warnings;
  // the ids the plant receives (kExtendedIdFlag on extended ones): SocketCAN's kernel filter
  std::vector<std::uint32_t> receive_ids() const;
};

// Start-up: reads the binding file and the DBC it names (relative to the binding's folder) for
// a plant of family "psd", "ev" or "shev" whose ECU runs every ecu_period_s. nullopt and every problem
// in errors if it cannot be used.
std::optional<Binding> load_binding(const std::string& path, const std::string& family, double ecu_period_s,
                                    std::vector<std::string>& errors);
// The same from texts (tests, and the built-in default): binding_file and dbc_file name them in
// messages; the binding's `dbc` key is then ignored.
std::optional<Binding> parse_binding(std::string_view binding_text, const std::string& binding_file,
                                     std::string_view dbc_text, const std::string& dbc_file, const std::string& family,
                                     double ecu_period_s, std::vector<std::string>& errors);
// ehpt's own contract as a binding: io/can/ehpt.dbc with io/can/ehpt-<family>.binding.toml,
// both compiled in (a test holds them to loading clean; nullopt only for an unknown family).
std::optional<Binding> default_binding(const std::string& family, double ecu_period_s, std::vector<std::string>& errors);

// The texts compiled in (generated from the files at build time).
std::string_view builtin_ehpt_dbc();
std::string_view builtin_binding_text(const std::string& family);  // "" for an unknown family

// Unit conversion by name (case-insensitive): the factor from a value in `unit` to the SI unit
// si_unit ("rad/s", "m/s", "W", "Nm", "V", "A"; "" for a fraction: "", "-", "1", "%"). nullopt
// if the unit is not one of si_unit's.
std::optional<double> unit_to_si(std::string_view unit, std::string_view si_unit);

}  // namespace ehpt::hil
