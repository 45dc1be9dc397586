// Fixed-width vector types for the row kernels (mesh, normals, smoothing, segment areas).
//
// The kernels are written once against the interface below (a "traits" struct V with V::F a
// float vector, V::M a vector of 32-bit lane masks, V::B a byte vector of 4 * V::kLanes lanes)
// and compiled once per instruction set; the caller picks the widest one the CPU supports at run
// time. The arithmetic uses the GCC/clang vector extensions (operators on whole vectors), so
// every instantiation performs the same IEEE operations in the same order as scalar code:
// results do not depend on the vector width (and, with contraction off, not on the build flags).
// The exceptions are mul_add, fused (one rounding) where the instruction set has FMA (AVX2,
// AVX-512) and a product and a sum elsewhere, and reciprocal / rsqrt, which start from each
// instruction set's own estimate: kernels that use them agree across widths only to rounding.
//
// - Sse2: 4 lanes, baseline of every x86-64 CPU.
// - Avx2: 8 lanes (with FMA, which every AVX2 CPU has); each member is compiled for AVX2 + FMA,
//   so kernels using it must be compiled for them too (see RANGESEG_SIMD_AVX2_TARGET) and run
//   only when cpu_has_avx2() is true. Files whose AVX2 code must match scalar code bit for bit
//   turn contraction off.
// - Avx512: 16 lanes (AVX-512 F/BW/DQ/VL), the same way (RANGESEG_SIMD_AVX512_TARGET,
//   cpu_has_avx512()).
// - Generic: 4 lanes from plain vector extensions, for other architectures.
//
// Interface (all members static and always inlined):
//   kLanes; F, M, B, Selector;
//   F load(const float*), store(float*, F), set1(float); M set1i(int);
//   F sqrt(F); F mul_add(F a, F b, F c) = a * b + c (see above);
//   F reciprocal(F) ~ 1 / x, F rsqrt(F) ~ 1 / sqrt(x): a hardware estimate and one Newton step,
//   relative error below 1e-6 (SSE2, AVX2) or a few float ulps (AVX-512), exact on Generic;
//   0 and infinity give NaN;
//   F round_nearest(F x): x rounded to an integer, ties to even (|x| < 2^22);
//   F scale_pow2(F p, F n) = p 2^n for an integer n with p 2^n a normal float;
//   F max(F a, F b) = a > b ? a : b per lane (NaN in a gives b, as maxps),
//   min(F a, F b) = a < b ? a : b (likewise);
//   F keep(F x, M m) = m ? x : +0 (bits); F pick(M m, F a, F b) = m ? a : b (m all-ones / zero);
//   Selector bit_selector<k>(M bits) and F keep_selected(F x, Selector) = bit k of the lane ? x :
//   +0; F shift_in(F previous, F x) = {previous[kLanes - 1], x[0], ..., x[kLanes - 2]}; M
//   bytes_to_lanes(const std::uint8_t*) loads kLanes bytes, zero-extended; B pack4(M, M, M, M):
//   lanes 0..kLanes-1 of the four vectors in order, each lane 0..127; B loadb(const std::uint8_t*),
//   storeb(std::uint8_t*, B).
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
#define RANGESEG_SIMD_AVX2_TARGET __attribute__((target("avx2,fma")))
/// Function attribute of kernels that use simd::Avx512.
#define RANGESEG_SIMD_AVX512_TARGET __attribute__((target("avx512f,avx512bw,avx512dq,avx512vl")))
#else
#define RANGESEG_SIMD_X86 0
#endif

namespace rangeseg::detail::simd {

/// Instruction sets of the kernels, narrowest first.
enum class Isa { baseline, avx2, avx512 };
/// For tests and benchmarks: kernels chosen afterwards use at most this instruction set (e.g.
/// Isa::baseline = SSE2 on x86 even when the CPU has more), so that the paths can be compared.
inline std::atomic<Isa> isa_limit{Isa::avx512};

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
  using Selector = M;
  static RANGESEG_SIMD_INLINE F load(const float* p) { return _mm_loadu_ps(p); }
  static RANGESEG_SIMD_INLINE void store(float* p, F v) { _mm_storeu_ps(p, v); }
  static RANGESEG_SIMD_INLINE F set1(float x) { return _mm_set1_ps(x); }
  static RANGESEG_SIMD_INLINE M set1i(int x) { return (M)_mm_set1_epi32(x); }
  static RANGESEG_SIMD_INLINE F sqrt(F x) { return _mm_sqrt_ps(x); }
  static RANGESEG_SIMD_INLINE F mul_add(F a, F b, F c) { return _mm_add_ps(_mm_mul_ps(a, b), c); }
  // Newton steps (relative error e -> ~e^2): r (2 - x r) for 1 / x, r (1.5 - 0.5 x r^2) for
  // 1 / sqrt(x). The same in every struct below.
  static RANGESEG_SIMD_INLINE F reciprocal(F x) {
    const F r = _mm_rcp_ps(x);
    return r * (set1(2.0f) - x * r);
  }
  static RANGESEG_SIMD_INLINE F rsqrt(F x) {
    const F r = _mm_rsqrt_ps(x);
    return r * (set1(1.5f) - set1(0.5f) * x * (r * r));
  }
  static RANGESEG_SIMD_INLINE F round_nearest(F x) {
    const F magic = set1(12582912.0f);  // 1.5 * 2^23: adding it rounds to an integer
    return (x + magic) - magic;
  }
  static RANGESEG_SIMD_INLINE F scale_pow2(F p, F n) {
    return (F)((M)p + ((M)_mm_cvtps_epi32(n) << 23));
  }
  static RANGESEG_SIMD_INLINE F max(F a, F b) { return _mm_max_ps(a, b); }
  static RANGESEG_SIMD_INLINE F min(F a, F b) { return _mm_min_ps(a, b); }
  static RANGESEG_SIMD_INLINE F keep(F x, M m) { return _mm_and_ps(x, (F)m); }
  static RANGESEG_SIMD_INLINE F pick(M m, F a, F b) {
    return _mm_or_ps(_mm_and_ps((F)m, a), _mm_andnot_ps((F)m, b));
  }
  template <int kBit>
  static RANGESEG_SIMD_INLINE M bit_selector(M bits) {
    return (M)((bits & (1 << kBit)) == (1 << kBit));
  }
  static RANGESEG_SIMD_INLINE F keep_selected(F x, M selector) { return keep(x, selector); }
  static RANGESEG_SIMD_INLINE Selector less(F a, F b) { return (M)_mm_cmplt_ps(a, b); }
  static RANGESEG_SIMD_INLINE Selector ordered(F a) { return (M)_mm_cmpord_ps(a, a); }
  static RANGESEG_SIMD_INLINE Selector both(Selector a, Selector b) { return a & b; }
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
  using Selector = M;
  static RANGESEG_AVX2_INLINE F load(const float* p) { return _mm256_loadu_ps(p); }
  static RANGESEG_AVX2_INLINE void store(float* p, F v) { _mm256_storeu_ps(p, v); }
  static RANGESEG_AVX2_INLINE F set1(float x) { return _mm256_set1_ps(x); }
  static RANGESEG_AVX2_INLINE M set1i(int x) { return (M)_mm256_set1_epi32(x); }
  static RANGESEG_AVX2_INLINE F sqrt(F x) { return _mm256_sqrt_ps(x); }
  static RANGESEG_AVX2_INLINE F mul_add(F a, F b, F c) { return _mm256_fmadd_ps(a, b, c); }
  static RANGESEG_AVX2_INLINE F reciprocal(F x) {
    const F r = _mm256_rcp_ps(x);
    return r * _mm256_fnmadd_ps(x, r, set1(2.0f));
  }
  static RANGESEG_AVX2_INLINE F rsqrt(F x) {
    const F r = _mm256_rsqrt_ps(x);
    return r * _mm256_fnmadd_ps(set1(0.5f) * x, r * r, set1(1.5f));
  }
  static RANGESEG_AVX2_INLINE F round_nearest(F x) {
    return _mm256_round_ps(x, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  }
  static RANGESEG_AVX2_INLINE F scale_pow2(F p, F n) {
    return (F)((M)p + ((M)_mm256_cvtps_epi32(n) << 23));
  }
  static RANGESEG_AVX2_INLINE F max(F a, F b) { return _mm256_max_ps(a, b); }
  static RANGESEG_AVX2_INLINE F min(F a, F b) { return _mm256_min_ps(a, b); }
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
  static RANGESEG_AVX2_INLINE Selector less(F a, F b) { return (M)_mm256_cmp_ps(a, b, _CMP_LT_OQ); }
  static RANGESEG_AVX2_INLINE Selector ordered(F a) { return (M)_mm256_cmp_ps(a, a, _CMP_ORD_Q); }
  // Selectors count by their sign bit only: the and of two is one.
  static RANGESEG_AVX2_INLINE Selector both(Selector a, Selector b) { return a & b; }
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

using i32x16 = std::int32_t __attribute__((vector_size(64)));
using u8x64 = std::uint8_t __attribute__((vector_size(64)));

#define RANGESEG_AVX512_INLINE RANGESEG_SIMD_INLINE RANGESEG_SIMD_AVX512_TARGET
struct Avx512 {
  static constexpr int kLanes = 16;
  using F = __m512;
  using M = i32x16;
  using B = u8x64;
  // A selector is a lane mask register: keep_selected becomes one zero-masking move that the
  // compiler folds into the preceding subtraction.
  using Selector = __mmask16;
  static RANGESEG_AVX512_INLINE F load(const float* p) { return _mm512_loadu_ps(p); }
  static RANGESEG_AVX512_INLINE void store(float* p, F v) { _mm512_storeu_ps(p, v); }
  static RANGESEG_AVX512_INLINE F set1(float x) { return _mm512_set1_ps(x); }
  static RANGESEG_AVX512_INLINE M set1i(int x) { return (M)_mm512_set1_epi32(x); }
  // The maskz forms with every lane on: the plain intrinsics start from _mm512_undefined_*(),
  // which GCC 12 reports as maybe-uninitialized.
  static constexpr __mmask16 kAll = 0xFFFF;
  static RANGESEG_AVX512_INLINE F sqrt(F x) { return _mm512_maskz_sqrt_ps(kAll, x); }
  static RANGESEG_AVX512_INLINE F mul_add(F a, F b, F c) {
    return _mm512_maskz_fmadd_ps(kAll, a, b, c);
  }
  static RANGESEG_AVX512_INLINE F reciprocal(F x) {
    const F r = _mm512_maskz_rcp14_ps(kAll, x);
    return r * _mm512_maskz_fnmadd_ps(kAll, x, r, set1(2.0f));
  }
  static RANGESEG_AVX512_INLINE F rsqrt(F x) {
    const F r = _mm512_maskz_rsqrt14_ps(kAll, x);
    return r * _mm512_maskz_fnmadd_ps(kAll, set1(0.5f) * x, r * r, set1(1.5f));
  }
  static RANGESEG_AVX512_INLINE F round_nearest(F x) {
    return _mm512_maskz_roundscale_ps(kAll, x, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  }
  static RANGESEG_AVX512_INLINE F scale_pow2(F p, F n) {
    return _mm512_maskz_scalef_ps(kAll, p, n);
  }
  static RANGESEG_AVX512_INLINE F max(F a, F b) { return _mm512_maskz_max_ps(kAll, a, b); }
  static RANGESEG_AVX512_INLINE F min(F a, F b) { return _mm512_maskz_min_ps(kAll, a, b); }
  static RANGESEG_AVX512_INLINE F keep(F x, M m) { return (F)((M)x & m); }
  static RANGESEG_AVX512_INLINE F pick(M m, F a, F b) {
    return _mm512_mask_blend_ps(_mm512_movepi32_mask((__m512i)m), b, a);
  }
  template <int kBit>
  static RANGESEG_AVX512_INLINE Selector bit_selector(M bits) {
    return _mm512_test_epi32_mask((__m512i)bits, _mm512_set1_epi32(1 << kBit));
  }
  static RANGESEG_AVX512_INLINE F keep_selected(F x, Selector selector) {
    return _mm512_maskz_mov_ps(selector, x);
  }
  static RANGESEG_AVX512_INLINE Selector less(F a, F b) {
    return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ);
  }
  static RANGESEG_AVX512_INLINE Selector ordered(F a) {
    return _mm512_cmp_ps_mask(a, a, _CMP_ORD_Q);
  }
  static RANGESEG_AVX512_INLINE Selector both(Selector a, Selector b) {
    return static_cast<Selector>(a & b);
  }
  static RANGESEG_AVX512_INLINE F shift_in(F previous, F x) {
    // Lanes 15..30 of the 32-lane concatenation (previous, x).
    return _mm512_castsi512_ps(
        _mm512_maskz_alignr_epi32(kAll, _mm512_castps_si512(x), _mm512_castps_si512(previous), 15));
  }
  static RANGESEG_AVX512_INLINE M bytes_to_lanes(const std::uint8_t* p) {
    return (M)_mm512_maskz_cvtepu8_epi32(kAll,
                                         _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
  }
  static RANGESEG_AVX512_INLINE B pack4(M a, M b, M c, M d) {
    const __m256i ab = _mm256_inserti128_si256(
        _mm256_castsi128_si256(_mm512_maskz_cvtepi32_epi8(kAll, (__m512i)a)),
        _mm512_maskz_cvtepi32_epi8(kAll, (__m512i)b), 1);
    const __m256i cd = _mm256_inserti128_si256(
        _mm256_castsi128_si256(_mm512_maskz_cvtepi32_epi8(kAll, (__m512i)c)),
        _mm512_maskz_cvtepi32_epi8(kAll, (__m512i)d), 1);
    return (B)_mm512_maskz_inserti64x4(0xFF, _mm512_castsi256_si512(ab), cd, 1);
  }
  static RANGESEG_AVX512_INLINE B loadb(const std::uint8_t* p) { return (B)_mm512_loadu_si512(p); }
  static RANGESEG_AVX512_INLINE void storeb(std::uint8_t* p, B v) {
    _mm512_storeu_si512(p, (__m512i)v);
  }
};
#undef RANGESEG_AVX512_INLINE

/// True when the CPU (and OS) support AVX2; evaluated once.
inline bool cpu_has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
/// True when the CPU (and OS) support the AVX-512 subsets simd::Avx512 uses; evaluated once.
inline bool cpu_has_avx512() {
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
  return has;
}

/// The widest kernel set to run: the best the CPU supports, capped by `isa_limit`.
inline Isa chosen_isa() {
  const Isa limit = isa_limit.load();
  if (limit >= Isa::avx512 && cpu_has_avx512()) return Isa::avx512;
  if (limit >= Isa::avx2 && cpu_has_avx2()) return Isa::avx2;
  return Isa::baseline;
}

/// The one of three per-instruction-set instances to run (see chosen_isa).
template <class T>
const T& by_isa(const T& baseline, const T& avx2, const T& avx512) {
  switch (chosen_isa()) {
    case Isa::avx512:
      return avx512;
    case Isa::avx2:
      return avx2;
    case Isa::baseline:
      break;
  }
  return baseline;
}

#else  // !RANGESEG_SIMD_X86

struct Generic {
  static constexpr int kLanes = 4;
  using F = f32x4;
  using M = i32x4;
  using B = u8x16;
  using Selector = M;
  static RANGESEG_SIMD_INLINE F load(const float* p) { return load_bytes<F>(p); }
  static RANGESEG_SIMD_INLINE void store(float* p, F v) { store_bytes(p, v); }
  static RANGESEG_SIMD_INLINE F set1(float x) { return F{x, x, x, x}; }
  static RANGESEG_SIMD_INLINE M set1i(int x) { return M{x, x, x, x}; }
  static RANGESEG_SIMD_INLINE F sqrt(F x) {
    for (int k = 0; k < kLanes; ++k) x[k] = __builtin_sqrtf(x[k]);
    return x;
  }
  static RANGESEG_SIMD_INLINE F mul_add(F a, F b, F c) { return a * b + c; }
  static RANGESEG_SIMD_INLINE F reciprocal(F x) { return F{1.0f, 1.0f, 1.0f, 1.0f} / x; }
  static RANGESEG_SIMD_INLINE F rsqrt(F x) { return reciprocal(sqrt(x)); }
  static RANGESEG_SIMD_INLINE F round_nearest(F x) {
    for (int k = 0; k < kLanes; ++k) x[k] = __builtin_rintf(x[k]);
    return x;
  }
  static RANGESEG_SIMD_INLINE F scale_pow2(F p, F n) {
    for (int k = 0; k < kLanes; ++k) p[k] = __builtin_ldexpf(p[k], static_cast<int>(n[k]));
    return p;
  }
  static RANGESEG_SIMD_INLINE F max(F a, F b) {
    for (int k = 0; k < kLanes; ++k) a[k] = a[k] > b[k] ? a[k] : b[k];
    return a;
  }
  static RANGESEG_SIMD_INLINE F min(F a, F b) {
    for (int k = 0; k < kLanes; ++k) a[k] = a[k] < b[k] ? a[k] : b[k];
    return a;
  }
  static RANGESEG_SIMD_INLINE F keep(F x, M m) { return (F)((M)x & m); }
  static RANGESEG_SIMD_INLINE F pick(M m, F a, F b) { return (F)(((M)a & m) | ((M)b & ~m)); }
  template <int kBit>
  static RANGESEG_SIMD_INLINE M bit_selector(M bits) {
    return (M)((bits & (1 << kBit)) == (1 << kBit));
  }
  static RANGESEG_SIMD_INLINE F keep_selected(F x, M selector) { return keep(x, selector); }
  static RANGESEG_SIMD_INLINE Selector less(F a, F b) { return (M)(a < b); }
  static RANGESEG_SIMD_INLINE Selector ordered(F a) { return (M)(a == a); }
  static RANGESEG_SIMD_INLINE Selector both(Selector a, Selector b) { return a & b; }
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

/// The body of a function that returns (by reference) the instance of type T for the CPU it runs
/// on: make(ns) builds one instance from the kernels compiled into namespace ns by
/// detail/simd_instances.hpp; x86 picks with by_isa.
#if RANGESEG_SIMD_X86
#define RANGESEG_SIMD_PICK(T, make)                                                       \
  static const T rangeseg_sse2_instance = make(sse2);                                     \
  static const T rangeseg_avx2_instance = make(avx2);                                     \
  static const T rangeseg_avx512_instance = make(avx512);                                 \
  return ::rangeseg::detail::simd::by_isa(rangeseg_sse2_instance, rangeseg_avx2_instance, \
                                          rangeseg_avx512_instance)
#else
#define RANGESEG_SIMD_PICK(T, make)                         \
  static const T rangeseg_generic_instance = make(generic); \
  return rangeseg_generic_instance
#endif
