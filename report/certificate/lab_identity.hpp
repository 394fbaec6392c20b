#pragma once
// Who issues a certificate: the laboratory's name, address and accreditation, the prefix of
// its certificate numbers, and who signs (docs/certificate.md, "The laboratory file").
#include <string>
#include <vector>

namespace standcal::report {

inline constexpr const char* kLabFormat = "standcal-lab/1";

struct Signatory {
  std::string name;
  std::string role;  // "Head of calibration laboratory"
};

struct LabIdentity {
  std::string source;  // the file, for messages
  std::string name;
  std::string address;
  std::string accreditation;  // e.g. "Accredited by DAkkS, D-K-12345-01-00"
  std::string certificate_prefix = "SC";
  std::vector<Signatory> signatories;
};

// Reads a standcal-lab/1 file; throws std::runtime_error naming the file and the key.
LabIdentity load_lab_identity(const std::string& path);

// A certificate number unique to the unit and the second of issue:
// PREFIX-YYYYMMDD-HHMMSS-SERIAL (the serial's characters outside [A-Za-z0-9.-] become '_').
std::string default_certificate_number(const std::string& prefix, const std::string& issued_utc,
                                       const std::string& unit_serial);

}  // namespace standcal::report
