// FNV-1a, 64 bits (Fowler, Noll, Vo; the IETF draft "The FNV Non-Cryptographic Hash Algorithm"): a fast checksum
// of bytes, for film states and the scene identity they record. Not a defence against deliberate collisions.
#pragma once
#include <cstddef>
#include <cstdint>

namespace pt {

inline constexpr uint64_t kFnv1aOffset = 0xcbf29ce484222325ull, kFnv1aPrime = 0x100000001b3ull;

// Continues hash `h` over n bytes (start with kFnv1aOffset).
inline uint64_t fnv1a(const unsigned char* p, size_t n, uint64_t h = kFnv1aOffset) {
  for (size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= kFnv1aPrime;
  }
  return h;
}

}  // namespace pt
