// Fixed-width vector types for the row kernels of mesh.cpp and normals.cpp.
//
// The kernels are written once against the interface below (a "traits" struct V with V::F a
// float vector, V::M a vector of 32-bit lane masks, V::B a byte vector of 4 * V::kLanes lanes)
// and compiled once per instruction set; the caller picks the widest one the CPU supports at run
// time. The arithmetic uses the GCC/clang vector extensions (operators on whole vectors), so
// every instantiation performs the same IEEE operations in the same order as scalar code:
// results do not depend on the vector width (and, with contraction off, not on the build flags).
//
// - Sse2: 4 lanes, baseline of every x86-64 CPU.
// - Avx2: 8 lanes; each member is compiled for AVX2, so kernels using it must be compiled for
//   AVX2 too (see RANGESEG_SIMD_AVX2_TARGET) and run only when cpu_has_avx2() is true.
// - Generic: 4 lanes from plain vector extensions, for other architectures.
//
// Interface (all members static and always inlined):
//   kLanes; F, M, B;
//   F load(const float*), store(float*, F), set1(float); M set1i(int);
//   F sqrt(F), max(F a, F b) = a > b ? a : b per lane (NaN in a gives b, as maxps);
//   F keep(F x, M m) = m ? x : +0 (bits); F pick(M m, F a, F b) = m ? a : b (m all-ones / zero);
//   bit_selector<k>(M bits) and F keep_selected(F x, selector) = bit k of the lane ? x : +0;
//   F shift_in(F previous, F x) = {previous[kLanes - 1], x[0], ..., x[kLanes - 2]};
//   M bytes_to_lanes(const std::uint8_t*) loads kLanes bytes, zero-extended;
//   B pack4(M, M, M, M): lanes 0..kLanes-1 of the four vectors in order, each lane 0..127;
//   B loadb(const std::uint8_t*), storeb(std::uint8_t*, B).
#pragma once

#include <atomic>
#include <cstdint>
#include <cstring>

#if defined(__GNUC__) || defined(__clang__)
#define RANGESEG_SIMD_INLINE inline __attribute__((always_inline))
#else
#error "rangeseg needs GCC or clang (vector extensions)"
#endif

#if (defined(__x86_64__) || defined(__i386__)) && defined(__SSE2__)
#define RANGESEG_SIMD_X86 1
#include <immintrin.h>
/// Function attribute of kernels that use simd::Avx2.
#define RANGESEG_SIMD_AVX2_TARGET __attribute__((target("avx2")))
#else
#define RANGESEG_SIMD_X86 0
#endif

namespace rangeseg::detail::simd {

/// For tests: while true, kernels chosen afterwards use the baseline instruction set (SSE2 on
/// x86) even when the CPU has AVX2, so that both paths can be compared.
inline std::atomic<bool> force_baseline{false};

using i32x4 = std::int32_t __attribute__((vector_size(16)));
using u8x16 = std::uint8_t __attribute__((vector_size(16)));
using f32x4 = float __attribute__((vector_size(16)));

template <class T>
RANGESEG_SIMD_INLINE T load_bytes(const void* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <class T>
RANGESEG_SIMD_INLINE void store_bytes(void* p, T v) {
  std::memcpy(p, &v, sizeof v);
}

#if RANGESEG_SIMD_X86

struct Sse2 {
  static constexpr int kLanes = 4;
  using F = __m128;
  using M = i32x4;
  using B = u8x16;
  static RANGESEG_SIMD_INLINE F load(const float* p) { return _mm_loadu_ps(p); }
  static RANGESEG_SIMD_INLINE void store(float* p, F v) { _mm_storeu_ps(p, v); }
  static RANGESEG_SIMD_INLINE F set1(float x) { return _mm_set1_ps(x); }
  static RANGESEG_SIMD_INLINE M set1i(int x) { return (M)_mm_set1_epi32(x); }
  static RANGESEG_SIMD_INLINE F sqrt(F x) { return _mm_sqrt_ps(x); }
  static RANGESEG_SIMD_INLINE F max(F a, F b) { return _mm_max_ps(a, b); }
  static RANGESEG_SIMD_INLINE F keep(F x, M m) { return _mm_and_ps(x, (F)m); }
  static RANGESEG_SIMD_INLINE F pick(M m, F a, F b) {
    return _mm_or_ps(_mm_and_ps((F)m, a), _mm_andnot_ps((F)m, b));
  }
  template <int kBit>
  static RANGESEG_SIMD_INLINE M bit_selector(M bits) {
    return (M)((bits & (1 << kBit)) == (1 << kBit));
  }
  static RANGESEG_SIMD_INLINE F keep_selected(F x, M selector) { return keep(x, selector); }
  static RANGESEG_SIMD_INLINE F shift_in(F previous, F x) {
    return _mm_castsi128_ps(_mm_or_si128(_mm_slli_si128(_mm_castps_si128(x), 4),
                                         _mm_srli_si128(_mm_castps_si128(previous), 12)));
  }
  static RANGESEG_SIMD_INLINE M bytes_to_lanes(const std::uint8_t* p) {
    std::int32_t word;
    std::memcpy(&word, p, sizeof word);
    const __m128i zero = _mm_setzero_si128();
    const __m128i b = _mm_cvtsi32_si128(word);
    return (M)_mm_unpacklo_epi16(_mm_unpacklo_epi8(b, zero), zero);
  }
  static RANGESEG_SIMD_INLINE B pack4(M a, M b, M c, M d) {
    return (B)_mm_packus_epi16(_mm_packs_epi32((__m128i)a, (__m128i)b),
                               _mm_packs_epi32((__m128i)c, (__m128i)d));
  }
  static RANGESEG_SIMD_INLINE B loadb(const std::uint8_t* p) {
    return (B)_mm_loadu_si128(reinterpret_cast<const __m128i*>(p));
  }
  static RANGESEG_SIMD_INLINE void storeb(std::uint8_t* p, B v) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(p), (__m128i)v);
  }
};

using i32x8 = std::int32_t __attribute__((vector_size(32)));
using u8x32 = std::uint8_t __attribute__((vector_size(32)));

#define RANGESEG_AVX2_INLINE RANGESEG_SIMD_INLINE RANGESEG_SIMD_AVX2_TARGET
struct Avx2 {
  static constexpr int kLanes = 8;
  using F = __m256;
  using M = i32x8;
  using B = u8x32;
  static RANGESEG_AVX2_INLINE F load(const float* p) { return _mm256_loadu_ps(p); }
  static RANGESEG_AVX2_INLINE void store(float* p, F v) { _mm256_storeu_ps(p, v); }
  static RANGESEG_AVX2_INLINE F set1(float x) { return _mm256_set1_ps(x); }
  static RANGESEG_AVX2_INLINE M set1i(int x) { return (M)_mm256_set1_epi32(x); }
  static RANGESEG_AVX2_INLINE F sqrt(F x) { return _mm256_sqrt_ps(x); }
  static RANGESEG_AVX2_INLINE F max(F a, F b) { return _mm256_max_ps(a, b); }
  static RANGESEG_AVX2_INLINE F keep(F x, M m) { return _mm256_and_ps(x, (F)m); }
  // blendv reads the sign bit only; the masks here are all-ones or zero.
  static RANGESEG_AVX2_INLINE F pick(M m, F a, F b) { return _mm256_blendv_ps(b, a, (F)m); }
  // Bit k moved to the sign bit, which is all blendv reads: one shift per selector.
  template <int kBit>
  static RANGESEG_AVX2_INLINE M bit_selector(M bits) {
    return (M)_mm256_slli_epi32((__m256i)bits, 31 - kBit);
  }
  static RANGESEG_AVX2_INLINE F keep_selected(F x, M selector) {
    return _mm256_blendv_ps(_mm256_setzero_ps(), x, (F)selector);
  }
  static RANGESEG_AVX2_INLINE F shift_in(F previous, F x) {
    // [previous 4-7, x 0-3], then per 128-bit half the last lane of the lower and the first
    // three of the upper: [previous 7, x 0-2 | x 3-6].
    const __m256 straddle = _mm256_permute2f128_ps(previous, x, 0x21);
    return _mm256_castsi256_ps(
        _mm256_alignr_epi8(_mm256_castps_si256(x), _mm256_castps_si256(straddle), 12));
  }
  static RANGESEG_AVX2_INLINE M bytes_to_lanes(const std::uint8_t* p) {
    return (M)_mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)));
  }
  static RANGESEG_AVX2_INLINE B pack4(M a, M b, M c, M d) {
    // packs work within 128-bit halves: the dwords come out as a0 b0 c0 d0 | a1 b1 c1 d1
    // (x0 = lanes 0-3 of x, x1 = lanes 4-7), so one permutation restores a b c d order.
    const __m256i ab = _mm256_packs_epi32((__m256i)a, (__m256i)b);
    const __m256i cd = _mm256_packs_epi32((__m256i)c, (__m256i)d);
    const __m256i abcd = _mm256_packus_epi16(ab, cd);
    return (B)_mm256_permutevar8x32_epi32(abcd, _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7));
  }
  static RANGESEG_AVX2_INLINE B loadb(const std::uint8_t* p) {
    return (B)_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
  }
  static RANGESEG_AVX2_INLINE void storeb(std::uint8_t* p, B v) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(p), (__m256i)v);
  }
};
#undef RANGESEG_AVX2_INLINE

/// True when the CPU (and OS) support AVX2; evaluated once.
inline bool cpu_has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}

#else  // !RANGESEG_SIMD_X86

struct Generic {
  static constexpr int kLanes = 4;
  using F = f32x4;
  using M = i32x4;
  using B = u8x16;
  static RANGESEG_SIMD_INLINE F load(const float* p) { return load_bytes<F>(p); }
  static RANGESEG_SIMD_INLINE void store(float* p, F v) { store_bytes(p, v); }
  static RANGESEG_SIMD_INLINE F set1(float x) { return F{x, x, x, x}; }
  static RANGESEG_SIMD_INLINE M set1i(int x) { return M{x, x, x, x}; }
  static RANGESEG_SIMD_INLINE F sqrt(F x) {
    for (int k = 0; k < kLanes; ++k) x[k] = __builtin_sqrtf(x[k]);
    return x;
  }
  static RANGESEG_SIMD_INLINE F max(F a, F b) {
    for (int k = 0; k < kLanes; ++k) a[k] = a[k] > b[k] ? a[k] : b[k];
    return a;
  }
  static RANGESEG_SIMD_INLINE F keep(F x, M m) { return (F)((M)x & m); }
  static RANGESEG_SIMD_INLINE F pick(M m, F a, F b) { return (F)(((M)a & m) | ((M)b & ~m)); }
  template <int kBit>
  static RANGESEG_SIMD_INLINE M bit_selector(M bits) {
    return (M)((bits & (1 << kBit)) == (1 << kBit));
  }
  static RANGESEG_SIMD_INLINE F keep_selected(F x, M selector) { return keep(x, selector); }
  static RANGESEG_SIMD_INLINE F shift_in(F previous, F x) {
    return F{previous[3], x[0], x[1], x[2]};
  }
  static RANGESEG_SIMD_INLINE M bytes_to_lanes(const std::uint8_t* p) {
    return M{p[0], p[1], p[2], p[3]};
  }
  static RANGESEG_SIMD_INLINE B pack4(M a, M b, M c, M d) {
    B out;
    for (int k = 0; k < kLanes; ++k) {
      out[k] = static_cast<std::uint8_t>(a[k]);
      out[kLanes + k] = static_cast<std::uint8_t>(b[k]);
      out[2 * kLanes + k] = static_cast<std::uint8_t>(c[k]);
      out[3 * kLanes + k] = static_cast<std::uint8_t>(d[k]);
    }
    return out;
  }
  static RANGESEG_SIMD_INLINE B loadb(const std::uint8_t* p) { return load_bytes<B>(p); }
  static RANGESEG_SIMD_INLINE void storeb(std::uint8_t* p, B v) { store_bytes(p, v); }
};

#endif  // RANGESEG_SIMD_X86

}  // namespace rangeseg::detail::simd
