#pragma once
// JSON text as standcal prints, stores and writes it.
#include <nlohmann/json.hpp>
#include <string>

namespace standcal {

// `j` as text, indented by `indent` (-1: one line), with any byte that is not UTF-8 written
// as U+FFFD: a file name, column name or unit serial from another tool's file may be Latin-1
// (`standcal noise --json` of "\xd6.csv", and `records --json` of a database holding one
// recording whose serial was, printed nothing but nlohmann's "type_error.316 invalid UTF-8").
inline std::string json_text(const nlohmann::json& j, int indent = 2) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace standcal
