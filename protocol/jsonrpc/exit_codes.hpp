#pragma once
// standcal's and standcald's exit status, the one table a bench script can rely on. The
// README's table and the man pages' EXIT STATUS section are this table (the man pages get
// it from `--help-all`; tests/exit_codes/exit_code_test.cpp checks the README against it).
#include <array>
#include <cstdio>
#include <string>
#include <string_view>

namespace standcal {

enum class ExitCode : int {
  success = 0,
  runtime_error = 1,
  usage_error = 2,
  verdict_fail = 3,
  verdict_indeterminate = 4,
  unexplained_mismatch = 5,
};

struct ExitCodeMeaning {
  ExitCode code;
  const char* meaning;
};

inline constexpr std::array<ExitCodeMeaning, 6> kExitCodes{{
    {ExitCode::success,
     "success (a certificate passes or has no limits; a recording the model explains)"},
    {ExitCode::runtime_error,
     "runtime error: a file, the daemon, the stand or the unit failed (the message says which)"},
    {ExitCode::usage_error,
     "usage error: the command line does not parse (an unknown command or option, a required "
     "option missing, a value that is not a number or out of its range)"},
    {ExitCode::verdict_fail,
     "certificate: a parameter is outside its limit even allowing for U (FAIL)"},
    {ExitCode::verdict_indeterminate,
     "indeterminate: a limit lies within value +- U or was not evaluated (certificate); "
     "too few positions to judge (diagnose)"},
    {ExitCode::unexplained_mismatch,
     "diagnose: the model does not explain the recording and no catalogued physics does "
     "(unexplained, or ambiguous between explanations)"},
}};

inline int exit_status(ExitCode c) { return static_cast<int>(c); }

// What a bench script acts on after `standcal diagnose`: "explained" is a finding the
// report states, not a failure; a mismatch nothing explains, or that several explanations
// fit equally, is; too few positions to judge is indeterminate.
inline ExitCode diagnosis_exit_code(std::string_view verdict) {
  if (verdict == "unexplained" || verdict == "ambiguous") return ExitCode::unexplained_mismatch;
  if (verdict == "insufficient_redundancy") return ExitCode::verdict_indeterminate;
  return ExitCode::success;
}

// Whether a status of `standcal diagnose` is one of its verdicts (what diagnosis_exit_code
// gives), not a failure to diagnose.
inline bool is_diagnosis_answer(int status) {
  for (ExitCode c :
       {ExitCode::success, ExitCode::verdict_indeterminate, ExitCode::unexplained_mismatch})
    if (status == exit_status(c)) return true;
  return false;
}

// A command line CLI11 could not parse: its own codes (105 a bad value, 106 a missing one,
// 109 an extra one, ...) become the one usage code; 0 (--help, --version) stays 0.
inline int parse_error_exit_status(int cli11_code) {
  return cli11_code == 0 ? 0 : exit_status(ExitCode::usage_error);
}

// The table as `--help-all` ends it (and so the man pages).
inline std::string exit_code_table_text() {
  std::string text = "Exit status:\n";
  for (const ExitCodeMeaning& row : kExitCodes) {
    char code[16];
    std::snprintf(code, sizeof code, "  %d  ", exit_status(row.code));
    text += code + std::string(row.meaning) + "\n";
  }
  return text;
}

}  // namespace standcal
