// Copyright Cairn authors.
//
// Test helpers: a scratch directory and the path of the shared real data.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <fstream>
#include <string>

#include "cairn/core/build_paths.h"

namespace cairn::sim::testing {

/// A fresh directory under the gtest temp dir, created once per call.
inline std::string MakeTempDir() {
  std::string pattern = ::testing::TempDir() + "cairn_sim_XXXXXX";
  if (::mkdtemp(pattern.data()) == nullptr) return ::testing::TempDir();
  return pattern;
}

/// Writes `contents` to `path` (binary).
inline void WriteFile(const std::string& path, const std::string& contents) {
  std::ofstream out(path, std::ios::binary);
  out << contents;
}

/// Reads the whole file at `path` (binary).
inline std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Path of the real scan shared beside the repository: <repo root>/data/geb079.bt.
inline std::string Geb079Path() { return cairn::core::SourceDir() + "/data/geb079.bt"; }

/// Predicate-formatter for EXPECT_CONTAINS: succeeds if `haystack` contains `needle`.
inline ::testing::AssertionResult AssertContains(const char* haystack_expr, const char* needle_expr,
                                                 const std::string& haystack, const std::string& needle) {
  if (haystack.find(needle) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << haystack_expr << " = \"" << haystack << "\"\ndoes not contain "
                                       << needle_expr << " = \"" << needle << "\"";
}

/// True if the file exists and can be opened.
inline bool FileExists(const std::string& path) { return std::ifstream(path).good(); }

}  // namespace cairn::sim::testing

/// Expects string `haystack` to contain string `needle` (GoogleTest only, no GoogleMock needed).
#define EXPECT_CONTAINS(haystack, needle) \
  EXPECT_PRED_FORMAT2(::cairn::sim::testing::AssertContains, haystack, needle)

/// Skips the current test when the shared geb079.bt scan is absent (data/ missing from the checkout).
#define CAIRN_SKIP_WITHOUT_GEB079()                                              \
  if (!::cairn::sim::testing::FileExists(::cairn::sim::testing::Geb079Path())) { \
    GTEST_SKIP() << "real scan " << ::cairn::sim::testing::Geb079Path()          \
                 << " is absent (it ships in data/); builtin worlds cover "      \
                    "the same behaviour";                                        \
  }
