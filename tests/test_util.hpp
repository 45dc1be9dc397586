// Helpers shared by the tests: locating ../shared/data and scratch directories.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

namespace rangeseg::test {

/// True in the sanitizer build (ASan + UBSan, RANGESEG_SANITIZE), where everything runs 10-30
/// times slower.
#if defined(RANGESEG_SANITIZED)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

/// For tests that measure accuracy over many full frames: they run in the Release suite; under
/// the sanitizers they would take minutes each, while their code paths run there in the
/// smaller tests. Use as the first statement of the test body.
#define RANGESEG_SKIP_ACCURACY_UNDER_SANITIZERS()                                          \
  do {                                                                                     \
    if (::rangeseg::test::kSanitized) {                                                    \
      GTEST_SKIP() << "accuracy measurement over full frames: runs in the Release suite, " \
                      "not under ASan + UBSan";                                            \
    }                                                                                      \
  } while (false)

/// Directory of the shared sensor data: $RANGESEG_DATA, else ../shared/data beside the repo.
inline std::filesystem::path shared_data_dir() {
  if (const char* env = std::getenv("RANGESEG_DATA")) return env;
  return std::filesystem::path(RANGESEG_SOURCE_DIR) / ".." / "shared" / "data";
}

/// Removes the scratch directories of a test when it ends, unless it failed: a run of the suite
/// writes ~300 MB of frames and results, which would otherwise pile up in the temporary folder.
/// A failed test's directories stay for inspection and are named on stderr.
class ScratchCleaner : public ::testing::EmptyTestEventListener {
 public:
  static ScratchCleaner& instance() {
    // Owned by GoogleTest's listener list once appended; never deleted before exit.
    static auto* cleaner = [] {
      auto* c = new ScratchCleaner;
      ::testing::UnitTest::GetInstance()->listeners().Append(c);
      return c;
    }();
    return *cleaner;
  }
  void track(const std::filesystem::path& dir) { dirs_.push_back(dir); }

  void OnTestEnd(const ::testing::TestInfo& info) override {
    const bool failed = info.result() != nullptr && info.result()->Failed();
    for (const auto& dir : dirs_) {
      if (failed) {
        std::cerr << "scratch directory kept: " << dir.string() << '\n';
      } else {
        std::error_code ignored;
        std::filesystem::remove_all(dir, ignored);
      }
    }
    dirs_.clear();
  }

 private:
  std::vector<std::filesystem::path> dirs_;
};

/// A fresh, empty scratch directory for one test, removed when the test passes.
inline std::filesystem::path scratch_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() /
             ("rangeseg_test_" + name + "_" +
              std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ScratchCleaner::instance().track(dir);
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
