#include "io/ray_file.h"

#include <cmath>
#include <cstring>

#include "core/memory_budget.h"
#include "io/little_endian.h"
#include "io/safe_file.h"

namespace pt {

namespace {

const char* const kFieldNames[8] = {"origin x", "origin y", "origin z", "direction x",
                                    "direction y", "direction z", "tnear", "tfar"};

}  // namespace

void write_ray_file(const std::string& path, const std::vector<RecordedRay>& rays) {
  if (rays.empty()) throw RayFileError(path + ": no rays to write");
  std::string out;
  out.reserve(kRayFileHeaderBytes + kRayRecordBytes * rays.size());
  out.append(kRayFileMagic, 8);
  put_le_u64(out, rays.size());
  for (const RecordedRay& r : rays) {
    for (float f : r.origin) put_le_f32(out, f);
    for (float f : r.direction) put_le_f32(out, f);
    put_le_f32(out, r.tnear);
    put_le_f32(out, r.tfar);
  }
  write_file_safely(path, out);
}

std::vector<RecordedRay> read_ray_file(const std::string& path) {
  // The bytes and the decoded records take about the same room: together within the memory budget.
  const uint64_t budget = memory_budget_bytes() / 2;
  const std::string bytes = read_file_limited(path, budget);
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() < kRayFileHeaderBytes || std::memcmp(p, kRayFileMagic, 8) != 0)
    throw RayFileError(path + ": not a ray file (it must start with the 8 bytes PTRAYS01 and a uint64 ray count)");
  const uint64_t n = get_le_u64(p + 8);
  const uint64_t records = (bytes.size() - kRayFileHeaderBytes) / kRayRecordBytes;
  if (n == 0) throw RayFileError(path + ": the header says 0 rays");
  if (n != records || (bytes.size() - kRayFileHeaderBytes) % kRayRecordBytes != 0)
    throw RayFileError(path + ": the header says " + std::to_string(n) + " rays but the file holds " +
                       std::to_string(bytes.size() - kRayFileHeaderBytes) + " bytes of records (" +
                       std::to_string(kRayRecordBytes) + " per ray): truncated or corrupt");
  std::vector<RecordedRay> rays(n);
  for (uint64_t i = 0; i < n; ++i) {
    const unsigned char* rec = p + kRayFileHeaderBytes + kRayRecordBytes * i;
    float f[8];
    for (int k = 0; k < 8; ++k) f[k] = get_le_f32(rec + 4 * k);
    const auto bad = [&](int field, const char* why) {
      return RayFileError(path + ": ray " + std::to_string(i) + ", " + kFieldNames[field] + " = " +
                          std::to_string(f[field]) + ": " + why);
    };
    for (int k = 0; k < 7; ++k)
      if (!std::isfinite(f[k])) throw bad(k, "not a finite number");
    if (std::isnan(f[7])) throw bad(7, "not a number");
    if (f[3] == 0.f && f[4] == 0.f && f[5] == 0.f) throw bad(3, "the direction is the zero vector");
    if (f[6] < 0.f) throw bad(6, "negative");
    if (f[7] < f[6]) throw bad(7, "less than tnear");
    RecordedRay& r = rays[i];
    std::memcpy(r.origin, f, sizeof r.origin);
    std::memcpy(r.direction, f + 3, sizeof r.direction);
    r.tnear = f[6];
    r.tfar = f[7];
  }
  return rays;
}

}  // namespace pt
