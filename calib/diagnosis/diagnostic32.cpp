// diagnostic32 (diagnosis.hpp): the programme of the blind tests and the harness.
#include <utility>
#include <vector>

#include "calib/diagnosis/diagnosis.hpp"

namespace standcal {

Program diagnostic32() {
  std::vector<std::pair<double, double>> a;
  for (double a1 : {0.0, 60.0, 120.0, 180.0, 240.0, 300.0}) a.emplace_back(a1, 0.0);
  for (double a2 : {45.0, 90.0, 135.0, 225.0, 270.0, 315.0}) a.emplace_back(0.0, a2);
  a.emplace_back(45.0, 90.0);
  a.emplace_back(45.0, 270.0);
  a.emplace_back(30.0, 60.0);
  a.emplace_back(330.0, 120.0);
  Program p;
  p.name = "diagnostic32";
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t i = 0; i < a.size(); ++i) {
      const auto& [a1, a2] = pass == 0 ? a[i] : a[a.size() - 1 - i];
      ProgramPosition pos;
      pos.alpha1_deg = a1;
      pos.alpha2_deg = a2;
      p.positions.push_back(pos);
    }
  return p;
}

}  // namespace standcal
