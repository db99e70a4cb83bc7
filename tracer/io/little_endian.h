// Little-endian encoding of binary file fields, whatever the machine's byte order (ray files, the peers'
// triangle file, film states).
#pragma once
#include <cstdint>
#include <cstring>
#include <string>

namespace pt {

inline void put_le_u32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xffu));
}
inline void put_le_u64(std::string& out, uint64_t v) {
  put_le_u32(out, static_cast<uint32_t>(v));
  put_le_u32(out, static_cast<uint32_t>(v >> 32));
}
inline void put_le_f32(std::string& out, float f) {
  uint32_t v;
  std::memcpy(&v, &f, 4);
  put_le_u32(out, v);
}

inline void put_le_f64(std::string& out, double d) {
  uint64_t v;
  std::memcpy(&v, &d, 8);
  put_le_u64(out, v);
}

inline uint32_t get_le_u32(const unsigned char* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}
inline uint64_t get_le_u64(const unsigned char* p) { return uint64_t(get_le_u32(p)) | uint64_t(get_le_u32(p + 4)) << 32; }
inline float get_le_f32(const unsigned char* p) {
  const uint32_t v = get_le_u32(p);
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}
inline double get_le_f64(const unsigned char* p) {
  const uint64_t v = get_le_u64(p);
  double d;
  std::memcpy(&d, &v, 8);
  return d;
}

}  // namespace pt
