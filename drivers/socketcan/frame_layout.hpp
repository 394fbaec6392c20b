#pragma once
// Table-driven CAN frame decoder (and its inverse, used by the emulator and tests):
// which signal sits where in which frame, as in a DBC file, configured in JSON
// (docs/unit-can.md).
#include <array>
#include <cstddef>
#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "drivers/status.hpp"

namespace standcal::drivers::can {

// Force signals in "g" count standard gravity; the driver reports m/s^2.
inline constexpr double kStandardGravity_mps2 = 9.80665;

enum class ByteOrder { intel, motorola };  // little-endian / big-endian (DBC @1 / @0)

// What a signal means to the unit driver.
enum class SignalRole { force_x, force_y, force_z, temperature, counter };

// "force_x", "force_y", "force_z", "temperature" or "counter" to the role; false for any
// other text.
bool parse_role(const std::string& text, SignalRole& role);

struct SignalSpec {
  std::string name;
  SignalRole role = SignalRole::force_x;
  std::uint32_t can_id = 0;  // 11-bit, or 29-bit when extended
  bool extended = false;
  int start_bit = 0;  // Intel: LSB position; Motorola: MSB position (DBC numbering)
  int length = 1;     // bits, 1..64
  ByteOrder byte_order = ByteOrder::intel;
  bool is_signed = false;
  double scale = 1;  // physical = raw * scale + offset, in `unit`
  double offset = 0;
  std::string unit;  // "g", "mg", "m/s2" for forces; "degC" for temperature
};

// What one data frame contributed: any of the three forces (m/s^2), the temperature
// (degC) and the frame's sample counter (raw).
struct FrameValues {
  std::array<double, 3> force_mps2{};
  double temperature_c = 0;
  std::uint64_t counter = 0;
  std::uint8_t force_mask = 0;  // bit i set: force_mps2[i] present
  bool has_temperature = false;
  bool has_counter = false;
};

// Raw bits of a signal from a frame payload; the payload must hold the signal.
std::uint64_t extract_raw(const std::uint8_t* data, int start_bit, int length, ByteOrder order);
// Writes raw bits of a signal into a payload (other bits untouched).
void insert_raw(std::uint8_t* data, int start_bit, int length, ByteOrder order, std::uint64_t raw);
// Number of payload bytes a signal needs.
int bytes_needed(int start_bit, int length, ByteOrder order);

// A frame to send: id (with CAN_EFF_FLAG when extended) and payload.
struct EncodedFrame {
  std::uint32_t can_id = 0;
  std::uint8_t len = 0;
  std::array<std::uint8_t, 64> data{};
};

class FrameLayout {
 public:
  // The default three-axis layout of docs/unit-can.md.
  static FrameLayout default_layout();
  // Parses and validates the JSON schema of docs/unit-can.md.
  static Result<FrameLayout> from_json(const nlohmann::json& j);
  // Reads a layout file: a DBC file (name ending .dbc, roles by signal name), or JSON
  // holding "signals", or JSON naming a DBC file with a role per signal
  // ({"dbc": "vendor.dbc", "roles": {"AccX": "force_x", ...}}, the path relative to the
  // JSON file). docs/unit-can.md.
  static Result<FrameLayout> from_file(const std::string& path);
  // Builds from signal specs after validation.
  static Result<FrameLayout> from_signals(std::vector<SignalSpec> signals);

  // Decodes one data frame; false when the id is not in the layout or it is too short.
  bool decode(std::uint32_t can_id, const std::uint8_t* data, std::size_t len,
              FrameValues& out) const;
  // Encodes one sample into the layout's frames (inverse of decode; values are clamped).
  std::vector<EncodedFrame> encode(const std::array<double, 3>& force_mps2, double temperature_c,
                                   std::uint64_t counter) const;

  // The CAN ids (with CAN_EFF_FLAG when extended) for CAN_RAW_FILTER.
  std::vector<std::uint32_t> can_ids() const;
  // Sample counter modulus, 2^(counter length).
  std::uint64_t counter_modulus() const { return counter_modulus_; }
  const std::vector<SignalSpec>& signals() const { return signals_; }

 private:
  struct CompiledSignal {
    SignalRole role;
    int start_bit, length;
    ByteOrder order;
    bool is_signed;
    double scale_si, offset_si;  // to m/s^2 or degC
  };
  struct CompiledFrame {
    std::uint32_t key;  // id | CAN_EFF_FLAG when extended
    std::size_t min_len;
    std::vector<CompiledSignal> signals;
  };
  std::vector<SignalSpec> signals_;
  std::vector<CompiledFrame> frames_;
  std::uint64_t counter_modulus_ = 0;
};

}  // namespace standcal::drivers::can
