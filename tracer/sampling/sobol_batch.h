// One 2D Sobol dimension for many samplers at once. The wavefront loop (integrators/wavefront.h) asks every live
// path of a bounce for the same dimensions (sample_dimensions.h: dimension = f(bounce, purpose)), so the
// scrambles of SobolSampler::get_2d can run across SIMD lanes instead of one long chain of dependent multiplies
// per path: hash32, two Laine–Karras permutations and three bit reversals per point become 16-lane integer
// instructions (AVX-512; GFNI reverses the bits of every byte, a byte shuffle the bytes of each lane), and the
// reversed-domain Sobol table is read with gathers. Every lane performs the integer arithmetic of get_2d, and the
// conversion to float is exact, so the points are bit-identical to get_2d's (tested: "sobol batch: ...").
// Without those instruction sets the batch is a loop over get_2d.
#pragma once
#include <algorithm>
#include <cstdint>
#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__GFNI__)
#include <immintrin.h>
#define PT_SOBOL_BATCH_SIMD 1
#endif

#include "sampling/sampler.h"

namespace pt {

class SobolBatch {
 public:
  // out[j] = samplers[index[j]].get_2d(d) for j < n; index may be null (then index[j] = j).
  // Whether get_2d runs across lanes for dimension d (deeper dimensions are hashed: cheap one by one).
  static constexpr bool batched(uint32_t d) {
#if defined(PT_SOBOL_BATCH_SIMD)
    return d < SobolSampler::kSobolPairs;
#else
    (void)d;
    return false;
#endif
  }

  static void get_2d(const SobolSampler* samplers, const uint16_t* index, int n, uint32_t d, Vec2* out) {
#if defined(PT_SOBOL_BATCH_SIMD)
    if (batched(d)) {
      for (int first = 0; first < n; first += 16) get_2d_16(samplers, index, first, std::min(16, n - first), d, out);
      return;
    }
#endif
    for (int j = 0; j < n; ++j) out[j] = samplers[index ? index[j] : j].get_2d(d);
  }

 private:
#if defined(PT_SOBOL_BATCH_SIMD)
  // 16 lanes of uint32 as a GCC vector: +, *, ^ and >> are the lanes' own (AVX-512) instructions.
  using u32x16 = uint32_t __attribute__((vector_size(64)));

  static u32x16 hash32(u32x16 x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    return x ^ (x >> 16);
  }
  static u32x16 laine_karras(u32x16 x, u32x16 seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    return x ^ (x * 0x8d22f6e6u);
  }
  static u32x16 reverse_bits(u32x16 x) {
    alignas(64) static constexpr uint8_t kSwap[64] = {3,  2,  1,  0,  7,  6,  5,  4,  11, 10, 9,  8,  15, 14, 13, 12,
                                                      3,  2,  1,  0,  7,  6,  5,  4,  11, 10, 9,  8,  15, 14, 13, 12,
                                                      3,  2,  1,  0,  7,  6,  5,  4,  11, 10, 9,  8,  15, 14, 13, 12,
                                                      3,  2,  1,  0,  7,  6,  5,  4,  11, 10, 9,  8,  15, 14, 13, 12};
    const __m512i bytes =
        _mm512_gf2p8affine_epi64_epi8(reinterpret_cast<__m512i>(x), _mm512_set1_epi64(0x8040201008040201LL), 0);
    return reinterpret_cast<u32x16>(_mm512_shuffle_epi8(bytes, _mm512_load_si512(kSwap)));
  }
  static u32x16 gather(const uint32_t* table, u32x16 i) {
    // The masked form: GCC 12 warns about the undefined source operand of the unmasked one.
    return reinterpret_cast<u32x16>(
        _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), 0xffff, reinterpret_cast<__m512i>(i), table, 4));
  }
  static u32x16 dim1_reversed(u32x16 r) {
    const auto& t = sobol_detail::kSobolDim1Reversed.t;
    return gather(t[0], r & 0xffu) ^ gather(t[1], (r >> 8) & 0xffu) ^ gather(t[2], (r >> 16) & 0xffu) ^
           gather(t[3], r >> 24);
  }

  static void get_2d_16(const SobolSampler* samplers, const uint16_t* index, int first, int k, uint32_t d,
                        Vec2* out) {
    u32x16 key{}, reversed{};
    for (int l = 0; l < k; ++l) {
      const SobolSampler& s = samplers[index ? index[first + l] : first + l];
      key[l] = s.key_;
      reversed[l] = s.reversed_index_;
    }
    const auto seed = [&](uint32_t j) { return hash32(key ^ (0x9e3779b9u * (3 * d + j))); };
    const u32x16 r = laine_karras(reversed, seed(1));
    const u32x16 x = reverse_bits(laine_karras(reverse_bits(r), seed(2)));
    const u32x16 y = reverse_bits(laine_karras(dim1_reversed(r), seed(3)));
    // As sobol_detail::to_unit: 24-bit integers convert to float exactly.
    using i32x16 = int32_t __attribute__((vector_size(64)));
    using f32x16 = float __attribute__((vector_size(64)));
    const f32x16 xs = __builtin_convertvector(reinterpret_cast<i32x16>(x >> 8), f32x16) * 0x1p-24f;
    const f32x16 ys = __builtin_convertvector(reinterpret_cast<i32x16>(y >> 8), f32x16) * 0x1p-24f;
    for (int l = 0; l < k; ++l) out[first + l] = {xs[l], ys[l]};
  }
#endif
};

// A path's sampler with up to two of its 2D dimensions already computed (by SobolBatch, for a whole batch):
// those are answered from the values, every other query from the sampler itself.
template <class Sampler>
struct SamplerWithPoints {
  static constexpr uint32_t kNone = ~0u;
  const Sampler& base;
  uint32_t dim_a = kNone;
  Vec2 a{};
  uint32_t dim_b = kNone;
  Vec2 b{};
  float get_1d(uint32_t d) const { return base.get_1d(d); }
  Vec2 get_2d(uint32_t d) const { return d == dim_a ? a : d == dim_b ? b : base.get_2d(d); }
};

}  // namespace pt
