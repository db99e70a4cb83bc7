// The PTRAYS01 ray file (io/ray_file.h): the exact byte layout, a bit-exact round trip, and a clear error for
// each kind of bad file.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "io/ray_file.h"
#include "io/safe_file.h"

using namespace pt;

namespace {

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

std::string error_of(const std::string& path) {
  try {
    read_ray_file(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

const std::vector<RecordedRay> kRays = {
    {{1.f, -2.5f, 3.25f}, {0.f, 0.6f, -0.8f}, 0.f, 1e30f},
    {{-1e-20f, 7e7f, 0.1f}, {2.f, 0.f, 0.f}, 0.5f, std::numeric_limits<float>::infinity()},
};

}  // namespace

TEST_CASE("ray file: the layout is PTRAYS01, a little-endian uint64 count, then 8 float32 per ray") {
  write_ray_file("rays_layout.bin", kRays);
  const std::string b = read_bytes("rays_layout.bin");
  REQUIRE(b.size() == 16 + 2 * 32);
  CHECK(b.substr(0, 8) == "PTRAYS01");
  const unsigned char count[8] = {2, 0, 0, 0, 0, 0, 0, 0};
  CHECK(std::memcmp(b.data() + 8, count, 8) == 0);
  // 2.5 as float is 0x40200000; -2.5 is 0xC0200000: little-endian bytes 00 00 20 C0 at ray 0, field 1.
  const unsigned char minus_2_5[4] = {0x00, 0x00, 0x20, 0xC0};
  CHECK(std::memcmp(b.data() + 16 + 4, minus_2_5, 4) == 0);
  // Ray 1's tnear (field 6) = 0.5 = 0x3F000000.
  const unsigned char half[4] = {0x00, 0x00, 0x00, 0x3F};
  CHECK(std::memcmp(b.data() + 16 + 32 + 24, half, 4) == 0);

  const std::vector<RecordedRay> back = read_ray_file("rays_layout.bin");
  REQUIRE(back.size() == kRays.size());
  CHECK(std::memcmp(back.data(), kRays.data(), sizeof(RecordedRay) * kRays.size()) == 0);
  std::filesystem::remove("rays_layout.bin");
}

TEST_CASE("ray file: bad files are refused with the file, the ray, the field and the reason") {
  write_ray_file("rays_good.bin", kRays);
  const std::string good = read_bytes("rays_good.bin");
  const auto with = [&](size_t offset, float value) {
    std::string b = good;
    std::memcpy(b.data() + offset, &value, 4);
    write_bytes("rays_bad.bin", b);
    return error_of("rays_bad.bin");
  };
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  CHECK(with(16 + 32 + 4, nan) == "rays_bad.bin: ray 1, origin y = nan: not a finite number");
  CHECK(with(16 + 20, inf) == "rays_bad.bin: ray 0, direction z = inf: not a finite number");
  CHECK(with(16 + 28, nan) == "rays_bad.bin: ray 0, tfar = nan: not a number");
  CHECK(with(16 + 24, -1.f) == "rays_bad.bin: ray 0, tnear = -1.000000: negative");
  CHECK(with(16 + 32 + 28, 0.25f) == "rays_bad.bin: ray 1, tfar = 0.250000: less than tnear");
  {
    std::string b = good;
    std::memset(b.data() + 16 + 12, 0, 12);
    write_bytes("rays_bad.bin", b);
    CHECK(error_of("rays_bad.bin") == "rays_bad.bin: ray 0, direction x = 0.000000: the direction is the zero vector");
  }
  write_bytes("rays_bad.bin", good.substr(0, good.size() - 1));
  CHECK(error_of("rays_bad.bin") ==
        "rays_bad.bin: the header says 2 rays but the file holds 63 bytes of records (32 per ray): truncated or corrupt");
  write_bytes("rays_bad.bin", good + std::string(32, '\0'));
  CHECK(error_of("rays_bad.bin").find("the header says 2 rays but the file holds 96 bytes") != std::string::npos);
  write_bytes("rays_bad.bin", "PTRAYS02" + good.substr(8));
  CHECK(error_of("rays_bad.bin").find("rays_bad.bin: not a ray file") == 0);
  write_bytes("rays_bad.bin", "PTRAYS");
  CHECK(error_of("rays_bad.bin").find("rays_bad.bin: not a ray file") == 0);
  write_bytes("rays_bad.bin", std::string("PTRAYS01") + std::string(8, '\0'));
  CHECK(error_of("rays_bad.bin") == "rays_bad.bin: the header says 0 rays");
  // A count so large that 32·N overflows 64 bits must not pass the size check by wrapping around.
  write_bytes("rays_bad.bin", std::string("PTRAYS01") + std::string(7, '\0') + "\x08" + good.substr(16));
  CHECK(error_of("rays_bad.bin").find("the header says 576460752303423488 rays") != std::string::npos);
  CHECK(error_of("no_such_rays.bin").find("no_such_rays.bin") == 0);
  CHECK_THROWS_AS(write_ray_file("rays_empty.bin", {}), RayFileError);
  CHECK(!std::filesystem::exists("rays_empty.bin"));
  std::filesystem::remove("rays_good.bin");
  std::filesystem::remove("rays_bad.bin");
}
