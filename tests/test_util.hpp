// Helpers shared by the tests: locating ../shared/data and scratch directories.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace rangeseg::test {

/// Directory of the shared sensor data: $RANGESEG_DATA, else ../shared/data beside the repo.
inline std::filesystem::path shared_data_dir() {
  if (const char* env = std::getenv("RANGESEG_DATA")) return env;
  return std::filesystem::path(RANGESEG_SOURCE_DIR) / ".." / "shared" / "data";
}

/// A fresh, empty scratch directory for one test.
inline std::filesystem::path scratch_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() /
             ("rangeseg_test_" + name + "_" +
              std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// Expects `f` to throw std::runtime_error whose message contains `needle`.
template <class F>
void expect_runtime_error_with(F&& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one mentioning " << needle;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

}  // namespace rangeseg::test

/// Skips the current test with a clear message when a shared data file is absent.
#define RANGESEG_REQUIRE_DATA(relpath)                                                     \
  const std::filesystem::path data_file = ::rangeseg::test::shared_data_dir() / (relpath); \
  if (!std::filesystem::exists(data_file)) {                                               \
    GTEST_SKIP() << "shared data not found: " << data_file                                 \
                 << " (set RANGESEG_DATA or put ../shared/data beside the repository)";    \
  }
