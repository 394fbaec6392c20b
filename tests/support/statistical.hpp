#pragma once
// Statistical tests check a distribution over hundreds of fits (Monte-Carlo z-variances,
// false-alarm rates). The Release build runs them in full (scripts/test.sh). Under
// ASan+UBSan (`scripts/test.sh --asan-all`), where each fit is ~10x slower, they would
// repeat code paths that the other sanitized tests run once, with fewer trials and looser
// bounds: they skip there, saying so.
#include <gtest/gtest.h>

#ifdef STANDCAL_SANITIZED
#define STANDCAL_STATISTICAL_TEST() \
  GTEST_SKIP() << "statistical test: it runs in full in the Release build (scripts/test.sh)"
#else
#define STANDCAL_STATISTICAL_TEST() static_cast<void>(0)
#endif
