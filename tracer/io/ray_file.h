// Ray files (PTRAYS01): recorded rays that any ray caster can replay, so the project and a peer such as Intel
// Embree time exactly the same queries (docs/performance.md, "Ray files").
//
// Layout, little-endian: 8 bytes "PTRAYS01", the ray count N as uint64, then N records of 8 float32 (32 bytes):
// origin xyz, direction xyz (any non-zero length), tnear, tfar, in the world coordinates of the scene file.
// A closest-hit query of a ray returns its nearest hit with t in [tnear, tfar] (t in units of the direction's
// length); an any-hit (shadow) query asks whether there is one.
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace pt {

struct RecordedRay {
  float origin[3], direction[3];
  float tnear, tfar;
};

struct RayFileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline constexpr char kRayFileMagic[9] = "PTRAYS01";
inline constexpr size_t kRayFileHeaderBytes = 16, kRayRecordBytes = 32;

// Encodes the rays (an empty list is refused) and writes them through write_file_safely: the file is complete or
// the earlier file is left as it was. Throws RayFileError or FileError naming the path and the reason.
void write_ray_file(const std::string& path, const std::vector<RecordedRay>& rays);

// Reads and validates a whole ray file: the magic, a size of exactly 16 + 32·N bytes, N ≥ 1, memory within the
// machine's budget, and every record finite with a non-zero direction and 0 ≤ tnear ≤ tfar (tfar may be +inf).
// A bad record is named by its index and field. Throws RayFileError or FileError.
std::vector<RecordedRay> read_ray_file(const std::string& path);

}  // namespace pt
