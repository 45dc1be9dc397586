// Benchmarks on the real sensor data in ../shared/data skip, with the path, when it is absent.
#pragma once

#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

namespace rangeseg::bench {

/// Whether `path` exists; if not, marks the benchmark skipped with the path in the message.
inline bool have_shared_data(benchmark::State& state, const std::string& path) {
  if (std::filesystem::exists(path)) return true;
  state.SkipWithError(("shared data not found: " + path).c_str());
  return false;
}

}  // namespace rangeseg::bench
