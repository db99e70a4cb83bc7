// Silences a false warning around code that takes std::experimental::simd square roots: GCC 12's AVX-512 square
// root (avx512fintrin.h, _mm512_sqrt_ps/pd) passes an undefined vector as the masked-off source and warns about
// it (-Wuninitialized, -Wmaybe-uninitialized) from inside the header, wherever such code is inlined. Every lane
// is computed, so nothing uninitialised is read. Bracket the code with PT_SIMD_SQRT_WARNINGS_OFF and
// PT_SIMD_SQRT_WARNINGS_ON (a push and a pop of the diagnostic state). -Wmaybe-uninitialized is GCC's own:
// clang (the fuzz build) would warn that it does not know it.
#pragma once

#ifdef __clang__
#define PT_SIMD_SQRT_WARNINGS_OFF \
  _Pragma("GCC diagnostic push") _Pragma("GCC diagnostic ignored \"-Wuninitialized\"")
#else
#define PT_SIMD_SQRT_WARNINGS_OFF                                             \
  _Pragma("GCC diagnostic push") _Pragma("GCC diagnostic ignored \"-Wuninitialized\"") \
      _Pragma("GCC diagnostic ignored \"-Wmaybe-uninitialized\"")
#endif
#define PT_SIMD_SQRT_WARNINGS_ON _Pragma("GCC diagnostic pop")
