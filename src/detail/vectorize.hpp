// RANGESEG_IVDEP: tells the vectoriser that the row buffers of the next loop do not overlap.
// GCC does not use the __restrict of local row pointers to prove that on its own.
#pragma once

// (clang vectorises these loops without the hint and warns where a forced hint cannot apply.)
#if defined(__GNUC__) && !defined(__clang__)
#define RANGESEG_IVDEP _Pragma("GCC ivdep")
#else
#define RANGESEG_IVDEP
#endif
