// Image files and the display transform.
#include <doctest/doctest.h>

#include <cstdio>
#include <stb_image.h>

#include "io/image_io.h"
#include "render/metrics.h"

using namespace pt;

TEST_CASE("PFM round trip is exact and stores rows bottom to top") {
  Image img{3, 2, {}};
  for (int i = 0; i < 18; ++i) img.rgb.push_back(0.1f * i - 0.5f);
  write_pfm("roundtrip.pfm", img);
  const Image back = read_pfm("roundtrip.pfm");
  REQUIRE(back.width == 3);
  REQUIRE(back.height == 2);
  CHECK(back.rgb == img.rgb);
  // The first stored row is the image's bottom row.
  std::FILE* f = std::fopen("roundtrip.pfm", "rb");
  REQUIRE(f);
  char header[16];
  REQUIRE(std::fread(header, 1, 11, f) == 11);  // "PF\n3 2\n-1.0\n" is 12 bytes
  REQUIRE(std::fread(header, 1, 1, f) == 1);
  float first;
  REQUIRE(std::fread(&first, 4, 1, f) == 1);
  std::fclose(f);
  CHECK(first == img.rgb[9]);
  CHECK_THROWS_AS(read_pfm("does-not-exist.pfm"), ImageError);
}

TEST_CASE("display transform: sRGB encoding and tone curves") {
  CHECK(to_srgb8(0.f) == 0);
  CHECK(to_srgb8(1.f) == 255);
  CHECK(to_srgb8(0.5f) == 188);       // 1.055·0.5^(1/2.4) − 0.055 = 0.7354
  CHECK(to_srgb8(0.002f) == 7);       // linear segment: 12.92·0.002·255 = 6.59
  CHECK(srgb_encode(0.0031308f) == doctest::Approx(0.04045f).epsilon(1e-3));
  DisplaySettings d;
  d.exposure_ev = 1.f;
  CHECK(tone_map(Rgb(0.25f), d).x == doctest::Approx(0.5f));
  d.tone_map = ToneMap::Reinhard;
  d.exposure_ev = 0.f;
  CHECK(tone_map(Rgb(1.f), d).x == doctest::Approx(0.5f));
  d.tone_map = ToneMap::AcesFitted;
  CHECK(tone_map(Rgb(1e6f), d).x == doctest::Approx(1.f).epsilon(1e-3));
  CHECK(tone_map(Rgb(0.f), d).x == doctest::Approx(0.f));
}

TEST_CASE("PNG writer produces an 8-bit RGB file of the right size") {
  Image img{5, 4, std::vector<float>(60, 0.5f)};
  write_png("tiny.png", img);
  int w = 0, h = 0, n = 0;
  unsigned char* px = stbi_load("tiny.png", &w, &h, &n, 3);
  REQUIRE(px);
  CHECK(w == 5);
  CHECK(h == 4);
  CHECK(px[0] == 188);
  stbi_image_free(px);
}

TEST_CASE("metrics: RMSE, relMSE, block averages") {
  Image a{2, 2, std::vector<float>(12, 1.f)}, b{2, 2, std::vector<float>(12, 1.f)};
  CHECK(rmse(a, b) == 0.0);
  b.rgb[0] = 2.f;
  CHECK(rmse(a, b) == doctest::Approx(std::sqrt(1.0 / 12)));
  CHECK(relmse(a, b) == doctest::Approx((1.0 / (4 + 0.01)) / 12));
  const Image avg = block_average(b, 2);
  CHECK(avg.width == 1);
  CHECK(avg.rgb[0] == doctest::Approx(1.25f));
  CHECK(mean_rgb(b).x == doctest::Approx(1.25));
}

TEST_CASE("metrics: block errors count the blocks whose mean luminance is off the reference by more than the tolerance") {
  // 8×4 pixels of grey 0.5: two whole 4×4 blocks (a 3-wide block size leaves partial ones out).
  Image ref{8, 4, std::vector<float>(96, 0.5f)};
  Image x = ref;
  CHECK(block_errors(x, ref, 4, 0.03).blocks == 2);
  CHECK(block_errors(x, ref, 4, 0.03).off == 0);
  CHECK(block_errors(x, ref, 3, 0.03).blocks == 2);
  // One pixel of the right block raised so that the block mean is 4 % high: off at 3 %, not at 5 %.
  const float raised = 0.5f * (1 + 0.04f * 16);
  for (int c = 0; c < 3; ++c) x.rgb[3 * (2 * 8 + 6) + c] = raised;
  BlockErrors e = block_errors(x, ref, 4, 0.03);
  CHECK(e.off == 1);
  CHECK(e.worst == doctest::Approx(0.04).epsilon(1e-5));
  CHECK(e.worst_x == 4);
  CHECK(e.worst_y == 0);
  CHECK(block_errors(x, ref, 4, 0.05).off == 0);
  // Energy moved within a block leaves its mean alone; a darker left block gives a negative worst.
  x = ref;
  x.rgb[0] = 0.f;
  x.rgb[3 * 1] = 1.f;
  CHECK(block_errors(x, ref, 4, 1e-9).off == 0);
  for (int c = 0; c < 3; ++c) x.rgb[3 * 9 + c] = 0.f;  // pixel (1, 1): the left block's mean drops by 1/16
  e = block_errors(x, ref, 4, 0.03);
  CHECK(e.off == 1);
  CHECK(e.worst == doctest::Approx(-1.0 / 16).epsilon(1e-4));
  // A black reference block: off unless the image is black there too.
  Image black{4, 4, std::vector<float>(48, 0.f)};
  CHECK(block_errors(black, black, 4, 0.03).off == 0);
  Image lit = black;
  lit.rgb[5] = 1e-6f;
  e = block_errors(lit, black, 4, 0.03);
  CHECK(e.off == 1);
  CHECK(e.black_off == 1);
  CHECK(e.black_worst == doctest::Approx(kLuminanceWeights[2] * 1e-6 / 16).epsilon(1e-4));
  // A black block beside a lit one: the worst relative difference is the lit block's, not an infinity.
  Image wide{8, 4, std::vector<float>(96, 0.5f)}, shown = wide;
  for (int y = 0; y < 4; ++y)
    for (int px = 0; px < 4; ++px)
      for (int c = 0; c < 3; ++c) wide.rgb[3 * (y * 8 + px) + c] = 0.f;
  shown.rgb[3 * 1] = 0.1f;                                  // light in the reference's black block
  for (int c = 0; c < 3; ++c) shown.rgb[3 * 6 + c] = 0.5f * 1.16f;  // the lit block 1 % high
  e = block_errors(shown, wide, 4, 0.03);
  CHECK(e.off == 1);
  CHECK(e.black_off == 1);
  CHECK(e.worst == doctest::Approx(0.01).epsilon(1e-4));
  CHECK(e.worst_x == 4);
}
