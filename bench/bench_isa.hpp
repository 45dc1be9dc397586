// Benchmarks of a kernel capped at an instruction set: state.range(0) = 0 (baseline, SSE2 on
// x86-64), 1 (AVX2) or 2 (AVX-512), where the CPU has it.
#pragma once

#include <benchmark/benchmark.h>

// The bench target has no src/ include path; the header is internal (kernel choice only).
#include "../src/detail/simd.hpp"

namespace rangeseg::bench {

/// Runs `body(state)` with the kernels capped at the instruction set state.range(0).
template <class Body>
void with_isa_limit(benchmark::State& state, Body body) {
  using detail::simd::Isa;
  detail::simd::isa_limit = static_cast<Isa>(state.range(0));
  body(state);
  detail::simd::isa_limit = Isa::avx512;
}

}  // namespace rangeseg::bench
