#include "calib/compensation.hpp"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>

#include "calib/atomic_file.hpp"
#include "calib/json_text.hpp"
#include "calib/model.hpp"
#include "calib/norm_estimator.hpp"
#include "calib/parameters.hpp"
#include "calib/raw_input.hpp"
#include "calib/utc_time.hpp"
#include "standcal/version.hpp"

namespace standcal {

using nlohmann::json;

namespace {

using CompensationValues = Eigen::Matrix<double, kCompensationValues, 1>;

CompensationValues pack_compensation(const Vec3& bias, const Mat3& matrix) {
  CompensationValues v;
  v.head<3>() = bias;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) v[3 + 3 * i + k] = matrix(i, k);
  return v;
}

constexpr std::array<const char*, kCompensationValues> kValueNames{
    "b_x", "b_y", "b_z", "M_11", "M_12", "M_13", "M_21", "M_22", "M_23", "M_31", "M_32", "M_33"};

// Covariance of the 12 values from the covariance of the fit's parameters, through the
// Jacobian of the map by central differences (the map is smooth; steps a thousandth of
// each parameter's sigma, so curvature errors are ~1e-6 of the variance).
CompensationCovariance propagate_to_compensation(
    const std::function<CompensationValues(const Eigen::VectorXd&)>& map, const Eigen::VectorXd& x,
    const Eigen::MatrixXd& cov) {
  Eigen::MatrixXd jacobian(kCompensationValues, x.size());
  for (Eigen::Index j = 0; j < x.size(); ++j) {
    const double sigma = std::sqrt(std::max(cov(j, j), 0.0));
    const double h = sigma > 0 ? 1e-3 * sigma : 1e-7 * std::max(1.0, std::abs(x[j]));
    Eigen::VectorXd up = x, down = x;
    up[j] += h;
    down[j] -= h;
    jacobian.col(j) = (map(up) - map(down)) / (2 * h);
  }
  return jacobian * cov * jacobian.transpose();
}

// b in m/s^2 and M = A^-1 from the paper's nine (bias in g, scale, gamma pair sums in rad).
CompensationValues stand_compensation_values(const Eigen::VectorXd& p, double g_mps2) {
  const UnitErrors unit = UnitErrors::from_parameters(p);
  return pack_compensation(unit.bias_g * g_mps2, unit.output_matrix().inverse());
}

// b and M = T diag(1/scale) from the norm fit's bias, scale and misalignment.
CompensationValues norm_compensation_values(const Eigen::VectorXd& p) {
  NormCompensation k;
  k.misalignment = p.tail<3>();
  return pack_compensation(p.head<3>(),
                           k.triangular() * Vec3(p.segment<3>(3).cwiseInverse()).asDiagonal());
}

std::string compensation_units_name(InputUnits u) {
  switch (u) {
    case InputUnits::counts:
      return "counts";
    case InputUnits::g:
      return "g";
    default:
      return "m/s^2";
  }
}

json vec3_array_json(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

json mat3_rows_json(const Mat3& m) {
  json rows = json::array();
  for (int i = 0; i < 3; ++i) rows.push_back({m(i, 0), m(i, 1), m(i, 2)});
  return rows;
}

Vec3 compensation_bias_sigma(const Compensation& c) {
  return c.covariance.diagonal().head<3>().cwiseSqrt();
}

Mat3 compensation_matrix_sigma(const Compensation& c) {
  Mat3 s;
  for (int i = 0; i < 9; ++i) s(i / 3, i % 3) = std::sqrt(c.covariance(3 + i, 3 + i));
  return s;
}

json text_or_null(const std::string& s) { return s.empty() ? json(nullptr) : json(s); }

std::string identity_text(const json& doc, const char* section, const char* key) {
  const json& v = doc.at(section).at(key);
  return v.is_null() ? "" : v.get<std::string>();
}

Vec3 read_vec3(const json& v, const std::string& where) {
  if (!v.is_array() || v.size() != 3) throw CompensationError(where + " is not 3 numbers");
  return {v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
}

Mat3 read_mat3(const json& v, const std::string& where) {
  if (!v.is_array() || v.size() != 3) throw CompensationError(where + " is not 3 rows");
  Mat3 m;
  for (int i = 0; i < 3; ++i) m.row(i) = read_vec3(v[i], where + " row " + std::to_string(i + 1));
  return m;
}

}  // namespace

CompensationIdentity compensation_identity(const RunIdentity& run,
                                           const std::vector<PositionAverage>& averages) {
  CompensationIdentity id;
  id.unit_serial = run.unit_serial;
  id.unit_type = run.unit_type;
  id.run_id = run.run_id;
  id.stand_id = run.stand_id;
  id.calibrated_utc = run.calibrated_utc;
  id.source = run.source;
  id.g_source = run.g_source;
  id.temperature_reference_c = mean_dwell_temperature_c(averages);
  if (id.temperature_reference_c) id.temperature_how = "mean over the dwells";
  return id;
}

CompensationIdentity compensation_identity(const Recording& rec,
                                           const std::vector<PositionAverage>& averages) {
  std::string g_source = rec.header_value("g_source");
  if (g_source.empty()) {
    g_source =
        rec.g_from_header ? "given (recording header or --g-mps2)" : "standard gravity assumed";
  }
  return compensation_identity(RunIdentity{rec.unit_serial, rec.header_value("unit_type"),
                                           rec.header_value("run_id"), rec.header_value("stand_id"),
                                           rec.header_value("started_utc"), rec.source, g_source},
                               averages);
}

Compensation make_compensation(const FitResult& fit, double g_local_mps2) {
  Compensation c;
  c.estimator = fit.estimator;
  c.g_local_mps2 = g_local_mps2;
  Eigen::VectorXd p = Eigen::VectorXd::Zero(kUnitParameterCount);
  for (int j = 0; j < kUnitParameterCount; ++j) {
    const ParameterEstimate& e = fit.unit[static_cast<std::size_t>(j)];
    if (!e.value) {
      c.notes.push_back(std::string(kUnitParameterNames[static_cast<std::size_t>(j)]) +
                        " was not observable in this calibration; the compensation assumes 0 "
                        "and its covariance does not include that parameter's uncertainty");
      continue;
    }
    p[j] = *e.value;
  }
  const Eigen::MatrixXd cov = unit_parameter_covariance(fit);
  const CompensationValues v = stand_compensation_values(p, g_local_mps2);
  c.bias = v.head<3>();
  for (int i = 0; i < 9; ++i) c.matrix(i / 3, i % 3) = v[3 + i];
  c.covariance = propagate_to_compensation(
      [g_local_mps2](const Eigen::VectorXd& x) {
        return stand_compensation_values(x, g_local_mps2);
      },
      p, cov);
  c.notes.push_back(
      "Only the symmetric part of the non-orthogonality is known (gravity reveals the pair sums "
      "gamma_ij + gamma_ji); each pair is split equally, so the corrected axes are orthogonal "
      "but their common rotation relative to the case is not calibrated.");
  return c;
}

Compensation make_compensation(const NormFit& fit, const RawInput& input) {
  Compensation c;
  c.estimator = "norm";
  c.input_units = compensation_units_name(input.units);
  c.g_local_mps2 = input.g_mps2;
  c.bias = fit.compensation.bias;
  c.matrix = fit.compensation.matrix;
  Eigen::VectorXd p(9);
  p << fit.compensation.bias, fit.compensation.scale, fit.compensation.misalignment;
  c.covariance = propagate_to_compensation(norm_compensation_values, p, fit.covariance);
  c.identity.source = input.source;
  c.notes.push_back(
      "M = T K with T unit upper-triangular: the calibrated x axis is the unit's x axis and y "
      "lies in its x-y plane; the unit's attitude was not known, so nothing else fixes the "
      "calibrated frame to the case.");
  return c;
}

std::string compensation_checksum(const Compensation& c) {
  std::string text = "raw_units=" + c.input_units + "\n";
  char number[40];
  const CompensationValues v = pack_compensation(c.bias, c.matrix);
  for (int i = 0; i < kCompensationValues; ++i) {
    std::snprintf(number, sizeof number, "%.17g\n", v[i]);
    text += number;
  }
  const uLong crc = crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(text.data()),
                          static_cast<uInt>(text.size()));
  char hex[9];
  std::snprintf(hex, sizeof hex, "%08lx", static_cast<unsigned long>(crc));
  return hex;
}

void stamp_written(Compensation& c) {
  if (c.written_utc.empty()) c.written_utc = utc_now_iso();
  if (c.standcal_version.empty()) c.standcal_version = kVersionLine;
}

json compensation_to_json(Compensation c) {
  stamp_written(c);
  json cov = json::array();
  for (int i = 0; i < kCompensationValues; ++i) {
    json row = json::array();
    for (int k = 0; k < kCompensationValues; ++k) row.push_back(c.covariance(i, k));
    cov.push_back(row);
  }
  const CompensationIdentity& id = c.identity;
  return {
      {"format", kCompensationFormat},
      {"equation", "f = M * (raw - b)"},
      {"unit", {{"serial", text_or_null(id.unit_serial)}, {"type", text_or_null(id.unit_type)}}},
      {"calibration",
       {{"run_id", text_or_null(id.run_id)},
        {"stand_id", text_or_null(id.stand_id)},
        {"calibrated_utc", text_or_null(id.calibrated_utc)},
        {"source", text_or_null(id.source)},
        {"estimator", c.estimator},
        {"g_local_mps2", c.g_local_mps2},
        {"g_source", text_or_null(id.g_source)},
        {"temperature_reference_c",
         id.temperature_reference_c ? json(*id.temperature_reference_c) : json(nullptr)},
        {"temperature_how", text_or_null(id.temperature_how)}}},
      {"written", {{"utc", c.written_utc}, {"standcal_version", c.standcal_version}}},
      {"raw_units", c.input_units},
      {"output_units", "m/s^2"},
      {"bias",
       {{"values", vec3_array_json(c.bias)},
        {"sigma", vec3_array_json(compensation_bias_sigma(c))},
        {"unit", c.input_units}}},
      {"matrix",
       {{"rows", mat3_rows_json(c.matrix)},
        {"sigma", mat3_rows_json(compensation_matrix_sigma(c))},
        {"unit", "m/s^2 per " + c.input_units}}},
      {"covariance",
       {{"order", json(std::vector<std::string>(kValueNames.begin(), kValueNames.end()))},
        {"values", cov}}},
      {"notes", c.notes},
      {"checksum",
       {{"algorithm", "crc32"},
        {"over",
         "\"raw_units=\" and raw_units, a newline, then b_x, b_y, b_z, M_11, M_12, ... M_33, each "
         "printed with %.17g and a newline"},
        {"value", compensation_checksum(c)}}}};
}

Compensation compensation_from_json(const json& doc) {
  try {
    if (!doc.is_object() || doc.value("format", "") != kCompensationFormat) {
      throw CompensationError(std::string("format: not ") + kCompensationFormat);
    }
    Compensation c;
    c.input_units = doc.at("raw_units").get<std::string>();
    c.bias = read_vec3(doc.at("bias").at("values"), "bias.values");
    c.matrix = read_mat3(doc.at("matrix").at("rows"), "matrix.rows");
    const json& cov = doc.at("covariance").at("values");
    if (!cov.is_array() || cov.size() != kCompensationValues) {
      throw CompensationError("covariance.values is not 12 rows");
    }
    for (int i = 0; i < kCompensationValues; ++i) {
      const json& row = cov[static_cast<std::size_t>(i)];
      if (!row.is_array() || row.size() != kCompensationValues) {
        throw CompensationError("covariance.values row " + std::to_string(i + 1) +
                                " is not 12 numbers");
      }
      for (int k = 0; k < kCompensationValues; ++k)
        c.covariance(i, k) = row[static_cast<std::size_t>(k)].get<double>();
    }
    const json& cal = doc.at("calibration");
    c.estimator = cal.at("estimator").get<std::string>();
    c.g_local_mps2 = cal.at("g_local_mps2").get<double>();
    CompensationIdentity& id = c.identity;
    id.unit_serial = identity_text(doc, "unit", "serial");
    id.unit_type = identity_text(doc, "unit", "type");
    id.run_id = identity_text(doc, "calibration", "run_id");
    id.stand_id = identity_text(doc, "calibration", "stand_id");
    id.calibrated_utc = identity_text(doc, "calibration", "calibrated_utc");
    id.source = identity_text(doc, "calibration", "source");
    id.g_source = identity_text(doc, "calibration", "g_source");
    id.temperature_how = identity_text(doc, "calibration", "temperature_how");
    if (!cal.at("temperature_reference_c").is_null()) {
      id.temperature_reference_c = cal.at("temperature_reference_c").get<double>();
    }
    c.notes = doc.value("notes", std::vector<std::string>{});
    c.written_utc = doc.at("written").at("utc").get<std::string>();
    c.standcal_version = doc.at("written").at("standcal_version").get<std::string>();
    const std::string stated = doc.at("checksum").at("value").get<std::string>();
    const std::string actual = compensation_checksum(c);
    if (stated != actual) {
      throw CompensationError("checksum: the file says " + stated + " but its numbers give " +
                              actual + "; the file was damaged or edited");
    }
    return c;
  } catch (const json::exception& e) {
    throw CompensationError(std::string("not a valid ") + kCompensationFormat +
                            " document: " + e.what());
  }
}

std::string compensation_to_csv(const Compensation& c) {
  const CompensationIdentity& id = c.identity;
  std::string out = std::string("# format: ") + kCompensationFormat + " (CSV view)\n";
  out += "# equation: f = M * (raw - b); raw and b in " + c.input_units + ", f in m/s^2\n";
  const auto line = [&out](const char* key, std::string value) {
    std::replace_if(
        value.begin(), value.end(), [](char ch) { return ch == '\n' || ch == '\r'; }, ' ');
    if (!value.empty()) out += std::string("# ") + key + ": " + value + "\n";
  };
  line("raw_units", c.input_units);
  line("unit_serial", id.unit_serial);
  line("unit_type", id.unit_type);
  line("run_id", id.run_id);
  line("stand_id", id.stand_id);
  line("calibrated_utc", id.calibrated_utc);
  line("source", id.source);
  line("estimator", c.estimator);
  char number[64];
  if (id.temperature_reference_c) {
    std::snprintf(number, sizeof number, "%.2f", *id.temperature_reference_c);
    line("temperature_reference_c", number);
  }
  std::snprintf(number, sizeof number, "%.6f", c.g_local_mps2);
  line("g_local_mps2", number);
  line("g_source", id.g_source);
  line("written_utc", c.written_utc);
  line("standcal_version", c.standcal_version.empty() ? kVersionLine : c.standcal_version);
  line("checksum_crc32", compensation_checksum(c));
  out += "name,c1,c2,c3,sigma1,sigma2,sigma3\n";
  const auto row = [&](const std::string& name, const Vec3& values, const Vec3& sigmas) {
    out += name;
    for (int k = 0; k < 3; ++k) {
      std::snprintf(number, sizeof number, ",%.17g", values[k]);
      out += number;
    }
    for (int k = 0; k < 3; ++k) {
      std::snprintf(number, sizeof number, ",%.3g", sigmas[k]);
      out += number;
    }
    out += "\n";
  };
  row("b", c.bias, compensation_bias_sigma(c));
  const Mat3 s = compensation_matrix_sigma(c);
  for (int i = 0; i < 3; ++i) {
    row("M_row" + std::to_string(i + 1), c.matrix.row(i).transpose(), s.row(i).transpose());
  }
  return out;
}

std::string write_compensation(Compensation c, const std::string& path, unsigned mode) {
  stamp_written(c);
  std::string stem = path;
  if (stem.ends_with(".json")) stem.resize(stem.size() - 5);
  write_file_atomically(stem + ".json", json_text(compensation_to_json(c)) + "\n",
                        "the compensation", static_cast<mode_t>(mode));
  write_file_atomically(stem + ".csv", compensation_to_csv(c), "the compensation",
                        static_cast<mode_t>(mode));
  return stem;
}

}  // namespace standcal
