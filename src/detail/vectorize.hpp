// RANGESEG_IVDEP: tells the vectoriser that the row buffers of the next loop do not overlap.
// GCC does not use the __restrict of local row pointers to prove that on its own.
#pragma once

#if defined(__clang__)
#define RANGESEG_IVDEP _Pragma("clang loop vectorize(assume_safety)")
#elif defined(__GNUC__)
#define RANGESEG_IVDEP _Pragma("GCC ivdep")
#else
#define RANGESEG_IVDEP
#endif
