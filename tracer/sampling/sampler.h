// Sample generators for one camera sample (one path). Dimensions are numbered explicitly by the integrator
// (sample_dimensions.h: dimension = f(bounce, purpose), as pbrt-v4's per-bounce RaySamples), never by call order,
// so a value is the same whatever was asked before it: paths of different lengths sharing a wavefront batch, or
// a vertex that skips its light sample, leave every other dimension where it was.
//
// - IndependentSampler: every value a hash of (pixel, sample index, seed, dimension): independent, counter-based.
// - SobolSampler: the 2D Sobol (0,2)-sequence, Owen-scrambled and padded (Burley 2020, "Practical Hash-based
//   Owen Scrambling", JCGT 9(4)): 2D dimension k of sample i uses the Sobol point of a shuffled index
//   i' = owen(i, hash(pixel, k, seed)) with its own scramble seed. Each dimension is stratified across the pixel's
//   samples (any power-of-two prefix is a (0,2)-net), dimensions are decorrelated from each other and from
//   neighbouring pixels, and every point is uniformly distributed over seeds, so estimates stay unbiased.
//   Only 2D dimensions below kSobolPairs are Sobol points; later ones and all 1D dimensions are hashed as in the
//   IndependentSampler.
#pragma once
#if defined(__GFNI__)
#include <immintrin.h>
#endif

#include "core/math.h"
#include "core/rng.h"

namespace pt {

// Uniform values in [0,1) from a 64-bit hash of the sample's key and the dimension (SplitMix64's finaliser over
// a Weyl sequence, as in Steele et al. 2014, "Fast splittable pseudorandom number generators"): 1D and 2D
// dimensions are separate name spaces; a 2D value takes the hash's two 24-bit halves.
class HashedDimensions {
 public:
  HashedDimensions() = default;
  explicit HashedDimensions(uint64_t key) : key_(key) {}
  float get_1d(uint32_t dim) const { return static_cast<float>(hash(2 * uint64_t{dim}) >> 40) * 0x1p-24f; }
  Vec2 get_2d(uint32_t dim) const {
    const uint64_t h = hash(2 * uint64_t{dim} + 1);
    return {static_cast<float>(h >> 40) * 0x1p-24f, static_cast<float>((h >> 8) & 0xffffffu) * 0x1p-24f};
  }

 private:
  uint64_t hash(uint64_t d) const { return mix64(key_ + (d + 1) * 0x9e3779b97f4a7c15ULL); }
  uint64_t key_ = 0;
};

// The key of one camera sample: distinct (pixel, sample, seed) give unrelated keys.
inline uint64_t sample_key(uint64_t pixel, uint64_t sample, uint64_t seed) {
  const uint64_t a = mix64(pixel * 0x9e3779b97f4a7c15ULL ^ mix64(seed + 0x632be59bd9b4e019ULL));
  return mix64(sample ^ (a + 0x2545f4914f6cdd1dULL));
}

class IndependentSampler {
 public:
  IndependentSampler() = default;  // for arrays of samplers to be filled in (integrators/wavefront.h)
  IndependentSampler(uint64_t pixel, uint64_t sample, uint64_t seed)
      : dims_(sample_key(pixel, sample, seed)), sample_(static_cast<uint32_t>(sample)) {}
  float get_1d(uint32_t dim) const { return dims_.get_1d(dim); }
  Vec2 get_2d(uint32_t dim) const { return dims_.get_2d(dim); }
  uint32_t sample_index() const { return sample_; }  // which of its pixel's samples this is

 private:
  HashedDimensions dims_;
  uint32_t sample_ = 0;
};

namespace sobol_detail {

constexpr uint32_t reverse_bits_portable(uint32_t x) {
  x = (x << 16) | (x >> 16);
  x = ((x & 0x00ff00ffu) << 8) | ((x & 0xff00ff00u) >> 8);
  x = ((x & 0x0f0f0f0fu) << 4) | ((x & 0xf0f0f0f0u) >> 4);
  x = ((x & 0x33333333u) << 2) | ((x & 0xccccccccu) >> 2);
  x = ((x & 0x55555555u) << 1) | ((x & 0xaaaaaaaau) >> 1);
  return x;
}

// Four bit reversals per Sobol point make them the sampler's main cost. With GFNI (AVX-512-class CPUs) one
// affine transform over GF(2) reverses the bits of every byte (matrix 0x8040201008040201) and a byte swap
// finishes the job: 3 instructions instead of ~20.
#if defined(__GFNI__)
inline uint32_t reverse_bits(uint32_t x) {
  const __m128i bytes_reversed =
      _mm_gf2p8affine_epi64_epi8(_mm_cvtsi32_si128(static_cast<int>(x)), _mm_set1_epi64x(0x8040201008040201LL), 0);
  return __builtin_bswap32(static_cast<uint32_t>(_mm_cvtsi128_si32(bytes_reversed)));
}
#else
inline uint32_t reverse_bits(uint32_t x) { return reverse_bits_portable(x); }
#endif

// Laine–Karras permutation with the constants of Burley's paper: a hash in which each bit is affected only by
// lower bits. Applied to a bit-reversed value it is a nested uniform (Owen) scramble of it.
inline uint32_t laine_karras(uint32_t x, uint32_t seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

// Owen scramble of a 32-bit fixed-point value in [0,1).
inline uint32_t owen_scramble(uint32_t x, uint32_t seed) { return reverse_bits(laine_karras(reverse_bits(x), seed)); }

// Second Sobol dimension of index i as 32-bit fixed point: the XOR of the generator-matrix columns v_k of i's set
// bits, with v_1 = 2^31, v_k = v_{k−1} ⊕ (v_{k−1} >> 1) (primitive polynomial x + 1). The sampler needs it in
// the bit-reversed domain, T(r) = reverse(sobol_dim1(reverse(r))), which saves two bit reversals per point
// (T is linear over GF(2) like the matrix: bit j of r contributes reverse(v_{32−j})). Shuffled indices use all
// 32 bits, so the columns are combined a byte at a time from four 256-entry tables built at compile time.
struct SobolDim1ReversedTables {
  uint32_t t[4][256];
  constexpr SobolDim1ReversedTables() : t{} {
    uint32_t v[32] = {};
    v[0] = 1u << 31;
    for (int k = 1; k < 32; ++k) v[k] = v[k - 1] ^ (v[k - 1] >> 1);
    for (int b = 0; b < 4; ++b)
      for (uint32_t byte = 0; byte < 256; ++byte) {
        uint32_t y = 0;
        for (int bit = 0; bit < 8; ++bit)
          if (byte & (1u << bit)) y ^= reverse_bits_portable(v[31 - (8 * b + bit)]);
        t[b][byte] = y;
      }
  }
};
inline constexpr SobolDim1ReversedTables kSobolDim1Reversed{};

inline uint32_t sobol_dim1_reversed(uint32_t r) {
  const auto& t = kSobolDim1Reversed.t;
  return t[0][r & 0xffu] ^ t[1][(r >> 8) & 0xffu] ^ t[2][(r >> 16) & 0xffu] ^ t[3][r >> 24];
}

// 32-bit integer hash (a "lowbias32" finaliser): cheap, well mixed, for per-dimension seeds.
inline uint32_t hash32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

inline float to_unit(uint32_t x) { return static_cast<float>(x >> 8) * 0x1p-24f; }

}  // namespace sobol_detail

class SobolSampler {
 public:
  // Stratification pays where the integrand still varies a lot over a pixel's samples: the pixel footprint and the
  // first few bounces. Deeper 2D dimensions, and every 1D decision (light choice, Russian roulette, reflect or
  // refract), are hashed: those carry little of the variance, and an Owen-scrambled point costs ~140 integer
  // operations against ~10 for a hash. 8 dimensions cover the camera jitter and the light and BSDF samples of
  // the first three and a half bounces (sample_dimensions.h).
  static constexpr uint32_t kSobolPairs = 8;

  SobolSampler() = default;  // for arrays of samplers to be filled in (integrators/wavefront.h)
  SobolSampler(uint64_t pixel, uint64_t sample, uint64_t seed)
      : reversed_index_(sobol_detail::reverse_bits(static_cast<uint32_t>(sample))),
        key_(static_cast<uint32_t>(mix64(pixel ^ mix64(seed + 0x51ed270b27a1c3f5ULL)))),
        hashed_(sample_key(pixel, sample, seed)) {}

  // Out of line: inlined twice per bounce it would crowd the path loop out of the compiler's inlining budget.
  [[gnu::noinline]] Vec2 get_2d(uint32_t d) const {
    using namespace sobol_detail;
    if (d >= kSobolPairs) return hashed_.get_2d(d);
    const uint32_t shuffle_seed = hash32(key_ ^ (0x9e3779b9u * (3 * d + 1)));
    const uint32_t x_seed = hash32(key_ ^ (0x9e3779b9u * (3 * d + 2)));
    const uint32_t y_seed = hash32(key_ ^ (0x9e3779b9u * (3 * d + 3)));
    // Shuffled index i' = owen(i) = reverse(r) with r = LK(reverse(i)). Sobol's first dimension of i' is
    // reverse(i'), and its Owen scramble reverse(LK(i')); the second is sobol_dim1(i'), whose scramble
    // reverse(LK(reverse(sobol_dim1(i')))) is reverse(LK(T(r))) with the reversed-domain table T. Three bit
    // reversals per point (reverse(i) is kept from the constructor).
    const uint32_t r = laine_karras(reversed_index_, shuffle_seed);
    const uint32_t x = reverse_bits(laine_karras(reverse_bits(r), x_seed));
    const uint32_t y = reverse_bits(laine_karras(sobol_dim1_reversed(r), y_seed));
    return {to_unit(x), to_unit(y)};
  }
  float get_1d(uint32_t d) const { return hashed_.get_1d(d); }
  uint32_t sample_index() const { return sobol_detail::reverse_bits(reversed_index_); }  // which of its pixel's samples

 private:
  friend class SobolBatch;  // the same scrambles across SIMD lanes (sampling/sobol_batch.h)
  uint32_t reversed_index_ = 0;  // the sample index, bit-reversed
  uint32_t key_ = 0;
  HashedDimensions hashed_;
};

}  // namespace pt
