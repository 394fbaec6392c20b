#pragma once
// Shared by every fuzz target and by tests/fuzz_regressions: what counts as a finding.
//
// A target feeds one input to a reader. Rejecting bad input with the documented error
// (std::runtime_error and its subclasses, or a Result holding a Status) is the expected
// outcome; anything else is a finding: a crash or a sanitizer report (caught by the
// sanitizers themselves), an exception of another type, or a broken property the target
// checks (e.g. what was written cannot be read back). A finding goes to report_finding():
// under libFuzzer it prints and aborts, so libFuzzer saves the input; in the regression
// test it throws Finding, so the test names the file and carries on with the next one.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <stdexcept>
#include <string>
#include <string_view>
#include <typeinfo>

namespace standcal::fuzz {

// Thrown by the regression test's finding handler. Deliberately not a std::exception,
// so no catch in the code under test or in a target can swallow it.
struct Finding {
  std::string what;
};

// Where findings go; the libFuzzer main leaves the default (print + abort).
using FindingHandler = void (*)(const std::string& what);
void set_finding_handler(FindingHandler handler);
[[noreturn]] void report_finding(const std::string& what);

// Checks a property of the code under test; a broken one is a finding.
inline void require(bool holds, const std::string& what) {
  if (!holds) report_finding(what);
}

// The input as text (readers take text; bytes are passed through unchanged).
inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// Runs `body`; std::runtime_error (the documented rejection) is expected, any other
// exception is a finding naming its type and message.
template <class Body>
int expect_only_runtime_errors(const char* target, Body&& body) {
  try {
    body();
  } catch (const Finding&) {
    throw;
  } catch (const std::runtime_error&) {
    // Documented rejection of bad input.
  } catch (const std::exception& e) {
    report_finding(std::string(target) + ": unexpected exception " + typeid(e).name() + ": " +
                   e.what());
  } catch (...) {
    report_finding(std::string(target) + ": unexpected exception of unknown type");
  }
  return 0;
}

// Runs `body` of a reader that reports errors as a Result/Status: no exception at all is
// expected.
template <class Body>
int expect_no_exceptions(const char* target, Body&& body) {
  try {
    body();
  } catch (const Finding&) {
    throw;
  } catch (const std::exception& e) {
    report_finding(std::string(target) + ": exception " + typeid(e).name() +
                   " escaped a Result-returning reader: " + e.what());
  } catch (...) {
    report_finding(std::string(target) +
                   ": exception of unknown type escaped a Result-returning reader");
  }
  return 0;
}

}  // namespace standcal::fuzz
