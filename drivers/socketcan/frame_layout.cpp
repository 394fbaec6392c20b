#include "drivers/socketcan/frame_layout.hpp"

#include "drivers/socketcan/dbc.hpp"

#include <linux/can.h>

#include <algorithm>
#include <bitset>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string_view>

namespace standcal::drivers::can {
namespace {

// A layout number must be a whole number inside its field's range: converting a larger
// or fractional JSON number would wrap or be undefined (fuzz/regressions/can_layout_json).
long long whole_number(const nlohmann::json& v, const char* key, long long lo, long long hi) {
  if (v.is_number_integer() &&
      !(v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(hi))) {
    const long long n = v.get<long long>();
    if (n >= lo && n <= hi) return n;
  }
  throw std::out_of_range(std::string(key) + " must be a whole number " + std::to_string(lo) +
                          ".." + std::to_string(hi) + ", got " + v.dump());
}

// A can_id given as text: "0x181" (hex) or "385" (decimal), wholly a number (std::stoul
// took "0x181zz" as 0x181 and said only "stoul" for "x").
std::uint32_t can_id_text(const std::string& text) {
  const bool hex = text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X');
  const std::string_view digits = std::string_view(text).substr(hex ? 2 : 0);
  std::uint32_t id = 0;
  const auto [end, ec] =
      std::from_chars(digits.data(), digits.data() + digits.size(), id, hex ? 16 : 10);
  if (digits.empty() || ec != std::errc{} || end != digits.data() + digits.size())
    throw std::invalid_argument("can_id \"" + text +
                                "\" must be a number such as \"0x181\" or 385");
  return id;
}

constexpr int kMaxPayloadBits = 64 * 8;

std::uint64_t low_mask(int bits) { return bits >= 64 ? ~0ULL : ((1ULL << bits) - 1); }

// Motorola signals are numbered by the DBC "sawtooth": the start bit names the MSB as
// byte*8 + bit-in-byte; in a big-endian bit stream that is position byte*8 + 7 - bit.
int motorola_stream_pos(int start_bit) { return (start_bit / 8) * 8 + 7 - start_bit % 8; }

// DBC bit number of every bit a signal occupies (for overlap checks).
std::vector<int> occupied_bits(int start_bit, int length, ByteOrder order) {
  std::vector<int> bits;
  for (int i = 0; i < length; ++i) {
    if (order == ByteOrder::intel) {
      bits.push_back(start_bit + i);
    } else {
      const int p = motorola_stream_pos(start_bit) + i;
      bits.push_back((p / 8) * 8 + 7 - p % 8);
    }
  }
  return bits;
}

const char* role_name(SignalRole r) {
  switch (r) {
    case SignalRole::force_x:
      return "force_x";
    case SignalRole::force_y:
      return "force_y";
    case SignalRole::force_z:
      return "force_z";
    case SignalRole::temperature:
      return "temperature";
    case SignalRole::counter:
      return "counter";
  }
  return "?";
}

bool is_force(SignalRole r) {
  return r == SignalRole::force_x || r == SignalRole::force_y || r == SignalRole::force_z;
}

// Factor from the signal's unit to SI (m/s^2) or degC; 0 when the unit does not fit.
double unit_factor(const SignalSpec& s) {
  if (is_force(s.role)) {
    if (s.unit == "g") return kStandardGravity_mps2;
    if (s.unit == "mg") return kStandardGravity_mps2 * 1e-3;
    if (s.unit == "ug") return kStandardGravity_mps2 * 1e-6;
    if (s.unit == "m/s2" || s.unit == "m/s^2") return 1.0;
    return 0;
  }
  if (s.role == SignalRole::temperature) return (s.unit == "degC" || s.unit == "C") ? 1.0 : 0;
  return 1.0;  // counter: unit is ignored
}

// CAN FD payload lengths: a frame longer than 8 bytes must use one of these.
std::uint8_t fd_length(std::size_t needed) {
  static constexpr std::array<std::uint8_t, 8> kLens{8, 12, 16, 20, 24, 32, 48, 64};
  if (needed <= 8) return static_cast<std::uint8_t>(needed);
  for (auto l : kLens)
    if (l >= needed) return l;
  return 64;
}

Status invalid(const std::string& what) {
  return Status::error(ErrorKind::invalid_argument, "CAN layout: " + what);
}

std::string hex_id(std::uint32_t id) {
  std::ostringstream os;
  os << "0x" << std::hex << id;
  return os.str();
}

Status read_layout_text(const std::string& path, std::string& text) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    return Status::error(ErrorKind::invalid_argument,
                         "CAN layout file " + path + " is a directory, not a layout file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::error(ErrorKind::invalid_argument, "cannot open CAN layout file " + path);
  text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return Status::ok();
}

bool has_dbc_extension(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  return ext.size() == 4 && std::tolower(static_cast<unsigned char>(ext[1])) == 'd' &&
         std::tolower(static_cast<unsigned char>(ext[2])) == 'b' &&
         std::tolower(static_cast<unsigned char>(ext[3])) == 'c';
}

// {"dbc": "vendor.dbc", "roles": {"AccX": "force_x", ...}}: the DBC path is relative to
// the JSON file, so a layout directory can be copied whole.
Result<FrameLayout> from_dbc_reference(const nlohmann::json& j, const std::string& json_path) {
  for (const auto& [k, v] : j.items())
    if (k != "dbc" && k != "roles")
      return invalid("unknown key '" + k + "' beside \"dbc\" (expected \"dbc\" and \"roles\")");
  if (!j["dbc"].is_string()) return invalid("\"dbc\" must be the DBC file's path");
  std::filesystem::path dbc_path = j["dbc"].get<std::string>();
  if (dbc_path.is_relative()) dbc_path = std::filesystem::path(json_path).parent_path() / dbc_path;
  DbcRoles roles;
  if (j.contains("roles")) {
    if (!j["roles"].is_object()) return invalid("\"roles\" must map DBC signal names to roles");
    for (const auto& [signal, role] : j["roles"].items()) {
      SignalRole r{};
      if (!role.is_string() || !parse_role(role.get<std::string>(), r))
        return invalid("roles." + signal +
                       ": must be force_x, force_y, force_z, temperature or counter");
      roles[signal] = r;
    }
  }
  std::string text;
  if (Status read = read_layout_text(dbc_path.string(), text); !read) return read;
  return layout_from_dbc(text, dbc_path.string(), roles);
}

}  // namespace

bool parse_role(const std::string& text, SignalRole& role) {
  static const std::map<std::string, SignalRole> kRoles{{"force_x", SignalRole::force_x},
                                                        {"force_y", SignalRole::force_y},
                                                        {"force_z", SignalRole::force_z},
                                                        {"temperature", SignalRole::temperature},
                                                        {"counter", SignalRole::counter}};
  const auto it = kRoles.find(text);
  if (it == kRoles.end()) return false;
  role = it->second;
  return true;
}

int bytes_needed(int start_bit, int length, ByteOrder order) {
  if (order == ByteOrder::intel) return (start_bit + length - 1) / 8 + 1;
  return (motorola_stream_pos(start_bit) + length - 1) / 8 + 1;
}

std::uint64_t extract_raw(const std::uint8_t* data, int start_bit, int length, ByteOrder order) {
  std::uint64_t v = 0;
  if (order == ByteOrder::intel) {
    int bit = start_bit, got = 0;
    while (got < length) {
      const int off = bit % 8;
      const int take = std::min(8 - off, length - got);
      v |= ((static_cast<std::uint64_t>(data[bit / 8]) >> off) & low_mask(take)) << got;
      got += take;
      bit += take;
    }
    return v;
  }
  int p = motorola_stream_pos(start_bit), remaining = length;
  while (remaining > 0) {
    const int avail = 8 - p % 8;
    const int take = std::min(avail, remaining);
    const std::uint64_t chunk =
        (static_cast<std::uint64_t>(data[p / 8]) >> (avail - take)) & low_mask(take);
    v = (take >= 64 ? 0 : (v << take)) | chunk;
    remaining -= take;
    p += take;
  }
  return v;
}

void insert_raw(std::uint8_t* data, int start_bit, int length, ByteOrder order, std::uint64_t raw) {
  raw &= low_mask(length);
  if (order == ByteOrder::intel) {
    int bit = start_bit, put = 0;
    while (put < length) {
      const int off = bit % 8;
      const int take = std::min(8 - off, length - put);
      const auto m = static_cast<std::uint8_t>(low_mask(take) << off);
      const auto bits = static_cast<std::uint8_t>(((raw >> put) & low_mask(take)) << off);
      data[bit / 8] = static_cast<std::uint8_t>((data[bit / 8] & ~m) | bits);
      put += take;
      bit += take;
    }
    return;
  }
  int p = motorola_stream_pos(start_bit), remaining = length;
  while (remaining > 0) {
    const int avail = 8 - p % 8;
    const int take = std::min(avail, remaining);
    const int shift = avail - take;
    const auto m = static_cast<std::uint8_t>(low_mask(take) << shift);
    const auto bits =
        static_cast<std::uint8_t>(((raw >> (remaining - take)) & low_mask(take)) << shift);
    data[p / 8] = static_cast<std::uint8_t>((data[p / 8] & ~m) | bits);
    remaining -= take;
    p += take;
  }
}

Result<FrameLayout> FrameLayout::from_signals(std::vector<SignalSpec> signals) {
  FrameLayout layout;
  std::map<std::uint32_t, CompiledFrame> frames;
  std::map<std::uint32_t, std::bitset<kMaxPayloadBits>> used;
  std::map<SignalRole, int> role_count;
  std::map<std::uint32_t, int> counters_per_frame;
  std::set<std::uint32_t> force_frames;
  int counter_length = 0;
  for (const auto& s : signals) {
    const std::string where = "signal '" + s.name + "' (" + hex_id(s.can_id) + ")";
    if (s.can_id > (s.extended ? CAN_EFF_MASK : CAN_SFF_MASK))
      return invalid(where + ": id too large for a " + (s.extended ? "29" : "11") +
                     "-bit identifier");
    if (s.length < 1 || s.length > 64) return invalid(where + ": length must be 1..64 bits");
    if (s.start_bit < 0 || s.start_bit >= kMaxPayloadBits ||
        bytes_needed(s.start_bit, s.length, s.byte_order) > 64)
      return invalid(where + ": does not fit in a 64-byte payload");
    if (s.scale == 0 || !std::isfinite(s.scale) || !std::isfinite(s.offset))
      return invalid(where + ": scale must be finite and non-zero");
    const double factor = unit_factor(s);
    if (factor == 0)
      return invalid(where + ": unit '" + s.unit + "' does not fit role " + role_name(s.role));
    const std::uint32_t key = s.can_id | (s.extended ? CAN_EFF_FLAG : 0U);
    auto& bits = used[key];
    for (int b : occupied_bits(s.start_bit, s.length, s.byte_order)) {
      if (b < 0 || b >= kMaxPayloadBits)
        return invalid(where + ": does not fit in a 64-byte payload");
      if (bits.test(static_cast<std::size_t>(b)))
        return invalid(where + ": overlaps another signal");
      bits.set(static_cast<std::size_t>(b));
    }
    ++role_count[s.role];
    if (s.role == SignalRole::counter) {
      if (s.is_signed || s.length > 32)
        return invalid(where + ": a counter is unsigned, at most 32 bits");
      if (counter_length != 0 && counter_length != s.length)
        return invalid(where + ": all sample counters must have the same length");
      counter_length = s.length;
      ++counters_per_frame[key];
    }
    if (is_force(s.role)) force_frames.insert(key);
    auto& f = frames[key];
    f.key = key;
    f.min_len = std::max<std::size_t>(
        f.min_len, static_cast<std::size_t>(bytes_needed(s.start_bit, s.length, s.byte_order)));
    f.signals.push_back({s.role, s.start_bit, s.length, s.byte_order, s.is_signed, s.scale * factor,
                         s.offset * factor});
  }
  for (auto r : {SignalRole::force_x, SignalRole::force_y, SignalRole::force_z})
    if (role_count[r] != 1)
      return invalid(std::string("exactly one signal must have role ") + role_name(r));
  if (role_count[SignalRole::temperature] > 1)
    return invalid("at most one signal may have role temperature");
  for (auto key : force_frames)
    if (counters_per_frame[key] != 1)
      return invalid("frame " + hex_id(key & CAN_EFF_MASK) +
                     " carries a force and needs exactly one counter signal");
  for (auto& [key, f] : frames) layout.frames_.push_back(std::move(f));
  layout.signals_ = std::move(signals);
  layout.counter_modulus_ = 1ULL << counter_length;
  return layout;
}

FrameLayout FrameLayout::default_layout() {
  std::vector<SignalSpec> s;
  const std::array<SignalRole, 3> axes{SignalRole::force_x, SignalRole::force_y,
                                       SignalRole::force_z};
  const std::array<const char*, 3> names{"x", "y", "z"};
  for (std::uint32_t i = 0; i < 3; ++i) {
    s.push_back({std::string("force_") + names[i], axes[i], 0x101 + i, false, 0, 32,
                 ByteOrder::intel, true, 1e-7, 0, "g"});
    s.push_back({std::string("counter_") + names[i], SignalRole::counter, 0x101 + i, false, 32, 16,
                 ByteOrder::intel, false, 1, 0, ""});
  }
  s.push_back({"temperature", SignalRole::temperature, 0x104, false, 0, 16, ByteOrder::intel, true,
               0.01, 0, "degC"});
  s.push_back(
      {"counter_t", SignalRole::counter, 0x104, false, 16, 16, ByteOrder::intel, false, 1, 0, ""});
  auto r = from_signals(std::move(s));
  return r.value();  // the built-in table is valid by construction (tested)
}

Result<FrameLayout> FrameLayout::from_json(const nlohmann::json& j) {
  static const std::set<std::string> kKeys{"name",      "role",   "can_id",     "extended",
                                           "start_bit", "length", "byte_order", "signed",
                                           "scale",     "offset", "unit"};
  if (!j.is_object() || !j.contains("signals") || !j["signals"].is_array())
    return invalid("expected an object with a \"signals\" array");
  std::vector<SignalSpec> specs;
  std::size_t index = 0;
  for (const auto& js : j["signals"]) {
    const std::string where = "signals[" + std::to_string(index++) + "]";
    try {
      if (!js.is_object()) return invalid(where + ": expected an object");
      for (const auto& [k, v] : js.items())
        if (!kKeys.count(k)) return invalid(where + ": unknown key '" + k + "'");
      SignalSpec s;
      s.name = js.value("name", where);
      if (!parse_role(js.at("role").get<std::string>(), s.role))
        return invalid(where + ": role must be force_x, force_y, force_z, temperature or counter");
      const auto& id = js.at("can_id");
      s.can_id = id.is_string()
                     ? can_id_text(id.get<std::string>())
                     : static_cast<std::uint32_t>(whole_number(id, "can_id", 0, 0x1FFFFFFF));
      s.extended = js.value("extended", false);
      s.start_bit = static_cast<int>(whole_number(js.at("start_bit"), "start_bit", 0, 511));
      s.length = static_cast<int>(whole_number(js.at("length"), "length", 1, 64));
      const std::string order = js.value("byte_order", "intel");
      if (order != "intel" && order != "motorola")
        return invalid(where + ": byte_order must be intel or motorola");
      s.byte_order = order == "intel" ? ByteOrder::intel : ByteOrder::motorola;
      s.is_signed = js.value("signed", false);
      s.scale = js.value("scale", 1.0);
      s.offset = js.value("offset", 0.0);
      s.unit = js.value("unit", "");
      specs.push_back(std::move(s));
    } catch (const std::exception& e) {
      return invalid(where + ": " + e.what());
    }
  }
  return from_signals(std::move(specs));
}

Result<FrameLayout> FrameLayout::from_file(const std::string& path) {
  std::string text;
  if (Status read = read_layout_text(path, text); !read) return read;
  if (has_dbc_extension(path)) return layout_from_dbc(text, path);
  const auto j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded())
    return Status::error(ErrorKind::invalid_argument,
                         "CAN layout file " + path + " is not valid JSON");
  auto r = j.is_object() && j.contains("dbc") ? from_dbc_reference(j, path) : from_json(j);
  if (!r) return Status::error(r.status().kind, path + ": " + r.status().message);
  return r;
}

bool FrameLayout::decode(std::uint32_t can_id, const std::uint8_t* data, std::size_t len,
                         FrameValues& out) const {
  const CompiledFrame* frame = nullptr;
  for (const auto& f : frames_)
    if (f.key == can_id) {
      frame = &f;
      break;
    }
  if (frame == nullptr || len < frame->min_len) return false;
  out.force_mask = 0;
  out.has_temperature = out.has_counter = false;
  for (const auto& s : frame->signals) {
    const std::uint64_t raw = extract_raw(data, s.start_bit, s.length, s.order);
    if (s.role == SignalRole::counter) {
      out.counter = raw;
      out.has_counter = true;
      continue;
    }
    std::int64_t value = static_cast<std::int64_t>(raw);
    if (s.is_signed && s.length < 64 && ((raw >> (s.length - 1)) & 1U))
      value = static_cast<std::int64_t>(raw | ~low_mask(s.length));
    const double phys =
        (s.is_signed ? static_cast<double>(value) : static_cast<double>(raw)) * s.scale_si +
        s.offset_si;
    if (s.role == SignalRole::temperature) {
      out.temperature_c = phys;
      out.has_temperature = true;
    } else {
      const int axis = static_cast<int>(s.role) - static_cast<int>(SignalRole::force_x);
      out.force_mps2[static_cast<std::size_t>(axis)] = phys;
      out.force_mask = static_cast<std::uint8_t>(out.force_mask | (1U << axis));
    }
  }
  return true;
}

std::vector<EncodedFrame> FrameLayout::encode(const std::array<double, 3>& force_mps2,
                                              double temperature_c, std::uint64_t counter) const {
  std::vector<EncodedFrame> out;
  for (const auto& f : frames_) {
    EncodedFrame e;
    e.can_id = f.key;
    e.len = fd_length(f.min_len);
    for (const auto& s : f.signals) {
      std::uint64_t raw;
      if (s.role == SignalRole::counter) {
        raw = counter;
      } else {
        const double v =
            s.role == SignalRole::temperature
                ? temperature_c
                : force_mps2[static_cast<std::size_t>(static_cast<int>(s.role) -
                                                      static_cast<int>(SignalRole::force_x))];
        double r = std::nearbyint((v - s.offset_si) / s.scale_si);
        // Just below 2^n so the truncating cast below never overflows, even at 64 bits.
        const double hi =
            std::nextafter(std::ldexp(1.0, s.is_signed ? s.length - 1 : s.length), 0.0);
        const double lo = s.is_signed ? -std::ldexp(1.0, s.length - 1) : 0;
        r = std::isfinite(r) ? std::clamp(r, lo, hi) : 0;  // NaN temperature encodes as 0
        raw = s.is_signed ? static_cast<std::uint64_t>(static_cast<std::int64_t>(r))
                          : static_cast<std::uint64_t>(r);
      }
      insert_raw(e.data.data(), s.start_bit, s.length, s.order, raw);
    }
    out.push_back(e);
  }
  return out;
}

std::vector<std::uint32_t> FrameLayout::can_ids() const {
  std::vector<std::uint32_t> ids;
  for (const auto& f : frames_) ids.push_back(f.key);
  return ids;
}

}  // namespace standcal::drivers::can
