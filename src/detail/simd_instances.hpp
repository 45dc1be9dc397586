// Compiles the kernel file named by RANGESEG_SIMD_KERNEL_FILE once per instruction set of
// detail/simd.hpp: in namespaces sse2, avx2 and avx512 on x86, generic elsewhere, each defining
// `V` (the simd traits) and the function attribute RANGESEG_KERNEL for the kernels. No include
// guard: a .cpp includes it once, after the declarations its kernels use; pick the instance at
// run time with detail::simd::by_isa.
#if RANGESEG_SIMD_X86
namespace sse2 {
using V = detail::simd::Sse2;
#define RANGESEG_KERNEL
#include RANGESEG_SIMD_KERNEL_FILE
#undef RANGESEG_KERNEL
}  // namespace sse2
namespace avx2 {
using V = detail::simd::Avx2;
#define RANGESEG_KERNEL RANGESEG_SIMD_AVX2_TARGET
#include RANGESEG_SIMD_KERNEL_FILE
#undef RANGESEG_KERNEL
}  // namespace avx2
namespace avx512 {
using V = detail::simd::Avx512;
#define RANGESEG_KERNEL RANGESEG_SIMD_AVX512_TARGET
#include RANGESEG_SIMD_KERNEL_FILE
#undef RANGESEG_KERNEL
}  // namespace avx512
#else
namespace generic {
using V = detail::simd::Generic;
#define RANGESEG_KERNEL
#include RANGESEG_SIMD_KERNEL_FILE
#undef RANGESEG_KERNEL
}  // namespace generic
#endif
