// Programmes: the paper's Table 2, the classic 24, user JSON, and the axis ranges.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "calib/programs.hpp"
#include "calib/units.hpp"

using namespace standcal;

TEST(Paper9, IsTable2WithConfigurableFirstAngle) {
  const Program p = paper9(10.0, 1);
  ASSERT_EQ(p.positions.size(), 9u);
  for (int k = 0; k < 5; ++k) {
    EXPECT_DOUBLE_EQ(p.positions[static_cast<std::size_t>(k)].alpha1_deg, 10.0 + 72.0 * k);
    EXPECT_DOUBLE_EQ(p.positions[static_cast<std::size_t>(k)].alpha2_deg, 0.0);
  }
  EXPECT_DOUBLE_EQ(p.positions[5].alpha2_deg, 57.5);
  EXPECT_DOUBLE_EQ(p.positions[6].alpha2_deg, 122.5);
  EXPECT_DOUBLE_EQ(p.positions[7].alpha2_deg, 270.0);
  EXPECT_DOUBLE_EQ(p.positions[8].alpha1_deg, 135.0);
  EXPECT_DOUBLE_EQ(p.positions[8].alpha2_deg, 90.0);
  EXPECT_TRUE(p.remount_before().empty());
}

TEST(Classic24, HasThreeMountingsTwoRemountsAndUnitUpVectors) {
  const Program p = classic24();
  ASSERT_EQ(p.positions.size(), 24u);
  EXPECT_EQ(p.remount_before(), (std::vector<std::size_t>{8, 16}));
  for (const auto& pos : p.positions) {
    const Vec3 u = up_vector(pos.alpha1_deg * kDegToRad, pos.alpha2_deg * kDegToRad, pos.mount);
    EXPECT_NEAR(u.cwiseAbs().maxCoeff(), 1.0, 1e-12);  // u = +-e_i
  }
}

TEST(UserProgramme, ReadsPositionsWithOverrides) {
  const auto doc = nlohmann::json::parse(R"({"name": "mine", "positions": [
      {"alpha1_deg": 0, "alpha2_deg": 0},
      {"alpha1_deg": 90, "alpha2_deg": 45, "mount": "y", "dwell_s": 120, "settle_s": 10}]})");
  const Program p = program_from_json(doc, "mine.json");
  EXPECT_EQ(p.name, "mine");
  ASSERT_EQ(p.positions.size(), 2u);
  EXPECT_EQ(p.positions[1].mount, Mount::y);
  EXPECT_EQ(*p.positions[1].dwell_s, 120);
  EXPECT_EQ(p.remount_before(), (std::vector<std::size_t>{1}));
  EXPECT_EQ(program_from_json(program_to_json(p), "again").positions.size(), 2u);
}

TEST(UserProgramme, ErrorsNameTheFileAndThePosition) {
  const auto message = [](const char* text) {
    try {
      program_from_json(nlohmann::json::parse(text), "p.json");
    } catch (const ProgramError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(message(R"({"positions": [{"alpha1_deg": 0, "alpha2_deg": 0}, {"alpha1_deg": 5}]})"),
            "p.json: position 2 of 2: 'alpha2_deg' is missing");
  EXPECT_EQ(message(R"({"positions": [{"alpha1_deg": 0, "alpha2_deg": 0, "alpha_3": 1}]})"),
            "p.json: position 1 of 1: unknown key 'alpha_3' (known: alpha1_deg, alpha2_deg, mount, "
            "dwell_s, settle_s)");
  EXPECT_EQ(message(R"({"positions": [{"alpha1_deg": 0, "alpha2_deg": 0, "mount": "q"}]})"),
            "p.json: position 1 of 1: 'mount' must be \"x\", \"y\" or \"z\"");
  EXPECT_EQ(message(R"({"positions": [{"alpha1_deg": 0, "alpha2_deg": 0, "dwell_s": -1}]})"),
            "p.json: position 1 of 1: 'dwell_s' must be > 0");
  EXPECT_EQ(message(R"({"positions": [{"alpha1_deg": "0", "alpha2_deg": 0}]})"),
            "p.json: position 1 of 1: 'alpha1_deg' must be a number");
  EXPECT_EQ(message(R"({"positions": []})"), "p.json: 'positions' is empty");
  EXPECT_EQ(message(R"([1, 2])"), "p.json: a programme is an object with a 'positions' array");
}

TEST(AxisRange, LimitedAxisTakes270AsMinus90) {
  const AxisRange pm180;
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(270, pm180), -90);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(-270, pm180), 90);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(180, pm180), 180);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(725, pm180), 5);
}

TEST(AxisRange, ContinuousAxisWrapsToPlusMinus180) {
  const AxisRange continuous{true, 0, 0};
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(270, continuous), -90);
  // One convention with the stand drivers (docs/stand-modbus.md): [-180, 180).
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(-180, continuous), -180);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(180, continuous), -180);
  EXPECT_DOUBLE_EQ(wrap_deg(540), -180);
  EXPECT_DOUBLE_EQ(wrap_deg(179.5), 179.5);
}

TEST(AxisRange, TheDefaultIsALimitedPlusMinus180Axis) {
  const AxisRange range;
  EXPECT_FALSE(range.continuous);
  EXPECT_DOUBLE_EQ(range.min_deg, -180);
  EXPECT_DOUBLE_EQ(range.max_deg, 180);
  EXPECT_EQ(range.cable_wrap, CableWrap::nearest);
  EXPECT_TRUE(AxisRange::continuous_axis().continuous);
}

TEST(AxisRange, TheEquivalentInsideTheRangeNearestTheReference) {
  const AxisRange wide{false, -270, 270};
  EXPECT_DOUBLE_EQ(*equivalent_angle_deg(wide, 250, 200), 250);
  EXPECT_DOUBLE_EQ(*equivalent_angle_deg(wide, 250, -200), -110);
  // Both edges of a ±180° axis are the same angle: the one nearer the reference.
  EXPECT_DOUBLE_EQ(*equivalent_angle_deg(AxisRange{}, 180, 170), 180);
  EXPECT_DOUBLE_EQ(*equivalent_angle_deg(AxisRange{}, 180, -170), -180);
  EXPECT_FALSE(equivalent_angle_deg(AxisRange{false, -90, 90}, 200, 0));
  EXPECT_FALSE(equivalent_angle_deg(AxisRange{}, std::numeric_limits<double>::quiet_NaN(), 0));
  EXPECT_FALSE(equivalent_angle_deg(AxisRange::continuous_axis(),
                                    std::numeric_limits<double>::infinity(), 0));
  // The programme's rule keeps an angle that is inside, else goes nearest the middle.
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(250, wide), 250);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(600, wide), -120);
}

TEST(AxisRange, UnreachableAngleIsAnErrorNamingPositionAndAxis) {
  StandLimits limits;
  limits.alpha2 = AxisRange{false, -90, 90};
  EXPECT_FALSE(normalise_angle_deg(150, limits.alpha2));
  try {
    normalise_program(paper9(), limits);
    FAIL() << "paper9 needs alpha2 = 122.5";
  } catch (const ProgramError& e) {
    EXPECT_NE(std::string(e.what()).find("paper9: position 7 of 9: alpha2 = 122.5"),
              std::string::npos);
    EXPECT_NE(std::string(e.what()).find("inner axis range"), std::string::npos);
  }
  // An angle just past the end is said as written: six digits said "alpha2 = 90 deg has no
  // equivalent angle in the inner axis range [-90, 90] deg".
  Program past_end = paper9();
  past_end.positions.resize(1);
  past_end.positions[0].alpha2_deg = 90.00001;
  try {
    normalise_program(past_end, limits);
    FAIL() << "alpha2 = 90.00001 is outside [-90, 90]";
  } catch (const ProgramError& e) {
    EXPECT_NE(std::string(e.what()).find("alpha2 = 90.00001 deg has no equivalent angle in the "
                                         "inner axis range [-90, 90] deg"),
              std::string::npos)
        << e.what();
  }
}

TEST(AxisRange, WideRangeKeepsAnAngleAlreadyInside) {
  const AxisRange wide{false, -270, 270};
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(200, wide), 200);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(300, wide), -60);
}

TEST(AxisRange, AHugeAngleTakesItsExactEquivalent) {
  // 1e308 ≡ -64 (mod 360) exactly; std::remainder is exact, 1e308 - 360·k is not.
  const double equivalent = std::remainder(1e308, 360.0);
  ASSERT_NEAR(equivalent, -64.0, 1e-9);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(1e308, AxisRange{}), equivalent);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(-1e308, AxisRange{}), -equivalent);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(1e308, AxisRange{false, 0, 540}), equivalent + 360.0);
  EXPECT_DOUBLE_EQ(*normalise_angle_deg(1e308, AxisRange{true, 0, 0}), equivalent);
}

TEST(UserProgramme, DwellAndSettleBeyondTheRunLimitsAreRefusedNamingPositionAndLimit) {
  const auto message = [](const char* text) {
    try {
      program_from_json(nlohmann::json::parse(text), "p.json");
    } catch (const ProgramError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(
      message(R"({"positions": [{"alpha1_deg": 0, "alpha2_deg": 0},
                                      {"alpha1_deg": 0, "alpha2_deg": 90, "dwell_s": 1e9}]})"),
      "p.json: position 2 of 2: 'dwell_s' must be at most 36000 s (the run limit), not 1e+09");
  EXPECT_EQ(message(R"({"positions": [{"alpha1_deg": 0, "alpha2_deg": 0, "settle_s": 3601}]})"),
            "p.json: position 1 of 1: 'settle_s' must be at most 3600 s (the run limit), not 3601");
  EXPECT_EQ(
      message(
          R"({"positions": [{"alpha1_deg": 0, "alpha2_deg": 0, "dwell_s": 36000, "settle_s": 3600}]})"),
      "");
  // The first position's warm-up (Program::warmup_s), within the same limit as a dwell.
  EXPECT_EQ(message(R"({"warmup_s": 36001, "positions": [{"alpha1_deg": 0, "alpha2_deg": 0}]})"),
            "p.json: 'warmup_s' must be at most 36000 s (the run limit), not 36001");
  EXPECT_EQ(message(R"({"warmup_s": -1, "positions": [{"alpha1_deg": 0, "alpha2_deg": 0}]})"),
            "p.json: 'warmup_s' must be >= 0");
  EXPECT_EQ(message(R"({"warmup_s": "2h", "positions": [{"alpha1_deg": 0, "alpha2_deg": 0}]})"),
            "p.json: 'warmup_s' must be a number");
  const Program warmed = program_from_json(
      nlohmann::json::parse(
          R"({"warmup_s": 7200, "positions": [{"alpha1_deg": 0, "alpha2_deg": 0}]})"),
      "p.json");
  EXPECT_DOUBLE_EQ(warmed.warmup_s, 7200);
  EXPECT_DOUBLE_EQ(program_from_json(program_to_json(warmed), "again").warmup_s, 7200);
  EXPECT_FALSE(program_to_json(paper9()).contains("warmup_s"));
}

TEST(UserProgramme, UnknownKeysAndAWrongNameAreRefusedNamingThem) {
  const auto message = [](const char* text) {
    try {
      program_from_json(nlohmann::json::parse(text), "p.json");
    } catch (const ProgramError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(
      message(R"({"name": "a", "positions": [{"alpha1_deg": 0, "alpha2_deg": 0}], "dwel_s": 5})"),
      "p.json: unknown key 'dwel_s' (known: name, positions, warmup_s)");
  EXPECT_EQ(message(R"({"name": 5, "positions": [{"alpha1_deg": 0, "alpha2_deg": 0}]})"),
            "p.json: 'name' must be a string");
  EXPECT_EQ(message("{\"name\": \"a\\n# mount: y\", \"positions\": [{\"alpha1_deg\": 0, "
                    "\"alpha2_deg\": 0}]}"),
            "p.json: 'name' must be printable text on one line: it contains the control character "
            "U+000A at "
            "character 2");
}
