#include "report/certificate/lab_identity.hpp"

#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace standcal::report {

using nlohmann::json;

namespace {

std::string lab_text(const json& obj, const char* key, const std::string& where, bool required) {
  if (!obj.contains(key)) {
    if (required) throw std::runtime_error(where + key + ": missing");
    return "";
  }
  const json& v = obj.at(key);
  if (!v.is_string() || v.get<std::string>().empty() || v.get<std::string>().size() > 400) {
    throw std::runtime_error(where + key + ": must be text of 1 to 400 characters");
  }
  return v.get<std::string>();
}

void lab_only_keys(const json& obj, const std::string& where,
                   std::initializer_list<const char*> keys) {
  if (!obj.is_object()) throw std::runtime_error(where + "must be an object");
  for (const auto& item : obj.items()) {
    bool known = false;
    for (const char* k : keys) known = known || item.key() == k;
    if (!known) throw std::runtime_error(where + item.key() + ": unknown key");
  }
}

}  // namespace

LabIdentity load_lab_identity(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read the laboratory file");
  const json doc = json::parse(in, nullptr, false);
  if (doc.is_discarded()) throw std::runtime_error(path + ": not valid JSON");
  const std::string where = path + ": ";
  lab_only_keys(
      doc, where,
      {"format", "name", "address", "accreditation", "certificate_prefix", "signatories"});
  if (doc.value("format", "") != kLabFormat) {
    throw std::runtime_error(where + "format: must be \"" + kLabFormat + "\"");
  }
  LabIdentity lab;
  lab.source = path;
  lab.name = lab_text(doc, "name", where, true);
  lab.address = lab_text(doc, "address", where, false);
  lab.accreditation = lab_text(doc, "accreditation", where, false);
  if (doc.contains("certificate_prefix"))
    lab.certificate_prefix = lab_text(doc, "certificate_prefix", where, false);
  if (doc.contains("signatories")) {
    const json& list = doc.at("signatories");
    if (!list.is_array()) throw std::runtime_error(where + "signatories: must be an array");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string at = where + "signatories[" + std::to_string(i) + "].";
      lab_only_keys(list[i], at, {"name", "role"});
      lab.signatories.push_back(
          {lab_text(list[i], "name", at, true), lab_text(list[i], "role", at, true)});
    }
  }
  return lab;
}

std::string default_certificate_number(const std::string& prefix, const std::string& issued_utc,
                                       const std::string& unit_serial) {
  // "2026-12-03T00:49:15Z" -> "20261203-004915"
  std::string stamp;
  for (char c : issued_utc) {
    if (c >= '0' && c <= '9') stamp += c;
    if (c == 'T') stamp += '-';
  }
  std::string serial = unit_serial.empty() ? "NOSERIAL" : unit_serial;
  for (char& c : serial) {
    const bool plain = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                       c == '.' || c == '-';
    if (!plain) c = '_';
  }
  return prefix + "-" + stamp + "-" + serial;
}

}  // namespace standcal::report
