#pragma once
// The fuzz entry points, one per input surface. Each takes one input, returns 0 and
// reports findings through fuzz_support.hpp. libfuzzer_main.cpp wraps one of them as
// LLVMFuzzerTestOneInput; tests/fuzz_regressions replays the corpora through all of them.
#include <cstddef>
#include <cstdint>

int standcal_fuzz_recording(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_raw_input(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_program_json(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_model_json(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_wander_curves(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_certificate_configs(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_diagnosis(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_can_layout_json(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_can_layout_dbc(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_can_frames(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_modbus_url(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_modbus_config(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_modbus_registers(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_jsonrpc_request(const std::uint8_t* data, std::size_t size);
int standcal_fuzz_daemon_config(const std::uint8_t* data, std::size_t size);
