// PCG32 random number generator (O'Neill 2014, pcg-random.org, "pcg32" = XSH-RR 64/32) and the SplitMix64
// finaliser. (Camera samples do not draw from a stream: sampling/sampler.h hashes each dimension.)
#pragma once
#include <cstdint>

namespace pt {

// SplitMix64 finaliser: a bijective 64-bit mix with good avalanche, used to turn structured
// (pixel, sample, seed) triples into well-spread generator states.
inline uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

class Pcg32 {
 public:
  Pcg32() { seed(0x853c49e6748fea9bULL, 0xda3e39cb94b95bdbULL); }
  Pcg32(uint64_t init_state, uint64_t stream) { seed(init_state, stream); }

  void seed(uint64_t init_state, uint64_t stream) {
    state_ = 0;
    inc_ = (stream << 1u) | 1u;  // the increment must be odd
    next_u32();
    state_ += init_state;
    next_u32();
  }

  uint32_t next_u32() {
    const uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    const uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31u));
  }

  // Uniform float in [0, 1): the top 24 bits scaled by 2^-24, so 1 is never returned.
  float next_float() { return static_cast<float>(next_u32() >> 8) * 0x1p-24f; }

 private:
  uint64_t state_ = 0, inc_ = 1;
};

}  // namespace pt
