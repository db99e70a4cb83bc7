// The real presenter and shaders on an OSMesa core 3.3 context, read back and compared with the CPU definition of
// the display transform (tracer/film/tonemap.h for colour, app/viewer/display_transform.h for the diagnostic views).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "viewer/display_transform.h"
#include "viewer/gl_presenter.h"
#include "osmesa_context.h"
#include "render/render_session.h"

using namespace pt;

namespace {

// A frame where every pixel and channel differs: radiance log-spaced over 2^-12 … 2^6 (plus zero and a negative
// value), relative errors log-spaced over 1e-5 … 10 (plus unknown), counts 0 … 100. A flipped or shifted
// image cannot match.
DisplayFrame test_frame(int w, int h) {
  DisplayFrame f;
  f.width = w;
  f.height = h;
  f.rgba.resize(4ull * w * h);
  f.count.resize(1ull * w * h);
  const size_t n = static_cast<size_t>(w) * h;
  for (size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / static_cast<double>(n - 1);
    f.rgba[4 * i + 0] = static_cast<float>(std::exp2(-12.0 + 18.0 * t));
    f.rgba[4 * i + 1] = static_cast<float>(std::exp2(6.0 - 18.0 * t));
    f.rgba[4 * i + 2] = static_cast<float>(std::exp2(-12.0 + 18.0 * std::fmod(7.31 * t, 1.0)));
    f.rgba[4 * i + 3] = static_cast<float>(std::pow(10.0, -5.0 + 6.0 * std::fmod(3.7 * t, 1.0)));
    f.count[i] = static_cast<float>(std::lround(100.0 * std::fmod(5.3 * t, 1.0)));
  }
  f.rgba[0] = 0.f;           // black
  f.rgba[1] = -0.25f;        // negative (a filter could make one): clamps to 0 in every tone map
  f.rgba[4 + 3] = DisplayFrame::kUnknownError;
  f.max_count = 100.f;
  return f;
}

struct Diff {
  int max = 0;
  size_t off = 0, pixels = 0;
  std::string worst;
};

// Compares RGBA8 pixels (top row first) with present_pixel() for every pixel of the frame.
Diff compare(const std::vector<uint8_t>& px, int stride_w, const DisplayFrame& f, const PresentSettings& s) {
  Diff d;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x) {
      const size_t i = static_cast<size_t>(y) * f.width + x;
      const Rgb mean(f.rgba[4 * i], f.rgba[4 * i + 1], f.rgba[4 * i + 2]);
      const auto want = present_pixel(mean, f.rgba[4 * i + 3], f.count[i], f.max_count, s);
      const uint8_t* got = &px[4 * (static_cast<size_t>(y) * stride_w + x)];
      int worst = 0;
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(got[c]) - int(want[c])));
      if (worst > d.max) {  // remember the worst pixel for the failure message
        char buf[160];
        std::snprintf(buf, sizeof buf, "pixel (%d,%d) mean (%g, %g, %g): got (%d, %d, %d), want (%d, %d, %d)", x, y,
                      mean.x, mean.y, mean.z, got[0], got[1], got[2], want[0], want[1], want[2]);
        d.worst = buf;
      }
      d.max = std::max(d.max, worst);
      d.off += worst > 0;
      ++d.pixels;
    }
  return d;
}

// The radiance of `f` reversed and scaled, 3 floats per pixel: an image unlike f at every pixel (a denoised
// image, a snapshot).
std::vector<float> reversed_means(const DisplayFrame& f, float scale) {
  const size_t n = static_cast<size_t>(f.width) * f.height;
  std::vector<float> out(3 * n);
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) out[3 * i + c] = scale * std::abs(f.rgba[4 * (n - 1 - i) + c]);
  return out;
}

// `f` with its means replaced by `other`'s (3 floats per pixel) in the columns whose centre u satisfies `use`:
// the frame present_pixel() must see when the view mixes two images.
template <class Use>
DisplayFrame mixed(const DisplayFrame& f, const std::vector<float>& other, Use use) {
  DisplayFrame e = f;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x)
      if (use((static_cast<float>(x) + 0.5f) / static_cast<float>(f.width))) {
        const size_t i = static_cast<size_t>(y) * f.width + x;
        for (int c = 0; c < 3; ++c) e.rgba[4 * i + c] = other[3 * i + c];
      }
  return e;
}

}  // namespace

TEST_CASE("gl: OSMesa gives a core 3.3+ context") {
  test::OsMesaContext ctx(8, 8);
  const std::string v = ctx.version();
  INFO(v);
  CHECK(v.find("Core Profile") != std::string::npos);
  CHECK(std::atof(v.c_str()) >= 3.3);
}

TEST_CASE("gl: colour view matches tonemap.h within 1/255 for every tone map and several exposures") {
  const int w = 61, h = 37;  // odd sizes: no alignment luck
  test::OsMesaContext ctx(w, h);
  GlPresenter presenter;
  const DisplayFrame f = test_frame(w, h);
  presenter.upload(f);
  REQUIRE(presenter.width() == w);
  REQUIRE(presenter.height() == h);
  std::vector<uint8_t> px;
  for (ToneMap tm : {ToneMap::Clamp, ToneMap::Reinhard, ToneMap::AcesFitted})
    for (float ev : {-2.f, 0.f, 1.5f, 4.f}) {
      PresentSettings s;
      s.display.tone_map = tm;
      s.display.exposure_ev = ev;
      CAPTURE(static_cast<int>(tm));
      CAPTURE(ev);
      // The offscreen read-back (what "save PNG" writes) …
      presenter.read_image(s, px);
      REQUIRE(px.size() == 4ull * w * h);
      const Diff offscreen = compare(px, w, f, s);
      INFO(offscreen.worst);
      CHECK(offscreen.max <= 1);
      CHECK(offscreen.off * 20 < offscreen.pixels);  // off-by-one is rare rounding, not a habit
      // … and the on-screen draw into the default framebuffer.
      ctx.clear(0, 0, 0);
      presenter.draw(0, 0, w, h, s);
      const Diff onscreen = compare(ctx.read_pixels(), w, f, s);
      INFO(onscreen.worst);
      CHECK(onscreen.max <= 1);
    }
}

TEST_CASE("gl: relative-error heat map and sample-count views match the CPU false colour within 1/255") {
  const int w = 40, h = 30;
  test::OsMesaContext ctx(w, h);
  GlPresenter presenter;
  const DisplayFrame f = test_frame(w, h);
  presenter.upload(f);
  std::vector<uint8_t> px;
  for (auto [lo, hi] : {std::pair{-3.f, 0.f}, std::pair{-5.f, 1.f}}) {
    PresentSettings s;
    s.mode = ViewMode::RelativeError;
    s.error_log10_min = lo;
    s.error_log10_max = hi;
    presenter.read_image(s, px);
    const Diff d = compare(px, w, f, s);
    CHECK(d.max <= 1);
  }
  // Unknown error (fewer than 2 samples) shows as the top of the map.
  PresentSettings s;
  s.mode = ViewMode::RelativeError;
  presenter.read_image(s, px);
  CHECK(std::abs(int(px[4]) - int(kFalseColour.back()[0])) <= 1);
  CHECK(std::abs(int(px[5]) - int(kFalseColour.back()[1])) <= 1);

  s.mode = ViewMode::SampleCount;
  presenter.read_image(s, px);
  CHECK(compare(px, w, f, s).max <= 1);
}

TEST_CASE("gl: the denoised image shows in the denoised view, on the right half in the split view, raw otherwise") {
  const int w = 60, h = 24;  // even width: no pixel centre on the split line
  test::OsMesaContext ctx(w, h);
  GlPresenter presenter;
  DisplayFrame f = test_frame(w, h);
  // A "denoised" image unlike the raw one: the raw radiance reversed and halved.
  f.denoised = reversed_means(f, 0.5f);
  presenter.upload(f);
  // The frame present_pixel() must see: the raw mean where the view shows it, the denoised one elsewhere.
  auto expected = [&](DenoiseView view) {
    return mixed(f, f.denoised, [&](float u) { return u >= denoised_from_u(view); });
  };
  std::vector<uint8_t> px;
  for (const DenoiseView view : {DenoiseView::Raw, DenoiseView::Denoised, DenoiseView::Split}) {
    CAPTURE(static_cast<int>(view));
    PresentSettings s;
    s.denoise = true;
    s.denoise_view = view;
    presenter.read_image(s, px);
    const Diff d = compare(px, w, expected(view), s);
    INFO(d.worst);
    CHECK(d.max <= 1);
    // The other view's image must not match: the test can tell them apart.
    CHECK(compare(px, w, expected(view == DenoiseView::Raw ? DenoiseView::Denoised : DenoiseView::Raw), s).max > 1);
  }
  // With denoising off (a view: the frame still has its denoised image) the raw mean shows.
  PresentSettings off;
  off.denoise = false;
  off.denoise_view = DenoiseView::Denoised;
  presenter.read_image(off, px);
  CHECK(compare(px, w, f, off).max <= 1);
  // A frame without a denoised image shows the raw mean in every view.
  DisplayFrame plain = test_frame(w, h);
  presenter.upload(plain);
  PresentSettings s;
  s.denoise = true;
  s.denoise_view = DenoiseView::Denoised;
  presenter.read_image(s, px);
  CHECK(compare(px, w, plain, s).max <= 1);
}

TEST_CASE("gl: A/B compare: the snapshot view, the split (snapshot left) and the difference heat map match the CPU") {
  const int w = 60, h = 24;  // even width: no pixel centre on the split line
  test::OsMesaContext ctx(w, h);
  GlPresenter presenter;
  const DisplayFrame live = test_frame(w, h);
  // The snapshot: the live radiance reversed and scaled, so every pixel differs by a different amount.
  const std::vector<float> snap_means = reversed_means(live, 0.7f);
  const DisplayFrame snap = mixed(live, snap_means, [](float) { return true; });
  const size_t n = static_cast<size_t>(w) * h;
  presenter.upload(snap);
  presenter.upload_snapshot(snap);
  presenter.upload(live);
  REQUIRE(presenter.has_snapshot());
  std::vector<uint8_t> px;
  for (const SnapshotView view : {SnapshotView::Off, SnapshotView::Snapshot, SnapshotView::Split}) {
    CAPTURE(static_cast<int>(view));
    PresentSettings s;
    s.snapshot_view = view;
    const DisplayFrame e = mixed(live, snap_means, [&](float u) { return u < snapshot_until_u(view); });
    presenter.read_image(s, px);
    const Diff d = compare(px, w, e, s);
    INFO(d.worst);
    CHECK(d.max <= 1);
    if (view != SnapshotView::Off) CHECK(compare(px, w, live, s).max > 1);  // tells the two apart
  }
  PresentSettings s;
  s.mode = ViewMode::Difference;
  presenter.read_image(s, px);
  int worst = 0;
  for (size_t i = 0; i < n; ++i) {
    const Rgb a(live.rgba[4 * i], live.rgba[4 * i + 1], live.rgba[4 * i + 2]);
    const Rgb b(snap.rgba[4 * i], snap.rgba[4 * i + 1], snap.rgba[4 * i + 2]);
    const auto want = present_pixel(a, 0.f, 0.f, 1.f, s, b);
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int(px[4 * i + c]) - int(want[c])));
  }
  CHECK(worst <= 1);
  // A new size leaves the snapshot behind: the A/B views show the live image.
  const DisplayFrame bigger = test_frame(w + 2, h);
  presenter.upload(bigger);
  CHECK_FALSE(presenter.has_snapshot());
  presenter.read_image(s, px);
  PresentSettings colour;
  CHECK(compare(px, w + 2, bigger, colour).max <= 1);
}

TEST_CASE("gl: new frame sizes reallocate, and a preview drawn larger is magnified smoothly") {
  test::OsMesaContext ctx(64, 64);
  GlPresenter presenter;
  CHECK(!presenter.has_image());
  DisplayFrame big = test_frame(64, 64);
  presenter.upload(big);
  CHECK(presenter.width() == 64);

  // A 2×1 preview: left black, right white. Drawn 64 wide, the middle columns must blend (bilinear), which a
  // full-resolution frame (nearest) would not.
  DisplayFrame preview;
  preview.width = 2;
  preview.height = 1;
  preview.preview = true;
  preview.rgba = {0, 0, 0, 1, 1, 1, 1, 1};
  preview.count = {1, 1};
  preview.max_count = 1;
  presenter.upload(preview);
  CHECK(presenter.width() == 2);
  ctx.clear(0, 0, 0);
  presenter.draw(0, 0, 64, 64, PresentSettings{});
  const std::vector<uint8_t> px = ctx.read_pixels();
  const int mid = px[4 * (32 * 64 + 31)];
  CHECK(mid > 20);
  CHECK(mid < 250);

  preview.preview = false;
  presenter.upload(preview);
  ctx.clear(0, 0, 0);
  presenter.draw(0, 0, 64, 64, PresentSettings{});
  const std::vector<uint8_t> crisp = ctx.read_pixels();
  CHECK(crisp[4 * (32 * 64 + 31)] == 0);
  CHECK(crisp[4 * (32 * 64 + 32)] == 255);
}
