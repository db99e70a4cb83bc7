// Whole-renderer tests: the analytic furnace for every estimator, agreement between estimators on the canonical
// scenes, and bit-identical images for any thread count.
#include <doctest/doctest.h>

#include <cstring>
#include <filesystem>
#include <unistd.h>

#include "render/adaptive.h"
#include "render/progressive.h"
#include "io/image_io.h"
#include "scene/scene_json.h"
#include "test_helpers.h"

using namespace pt;
using namespace pt::test;

namespace {
const Estimator kAll[] = {Estimator::Uniform, Estimator::Cosine, Estimator::Nee, Estimator::Mis, Estimator::Bdpt};
}

TEST_CASE("furnace: a closed emitting sphere gives Le·(1−ρ^(k+1))/(1−ρ) for every estimator") {
  // Inside a closed sphere of uniform emission Le and albedo ρ every path sees Le at each vertex, so the
  // radiance after k bounces is the geometric series Le·Σρ^j. Tolerance: 4 standard errors of the image mean
  // (from the film's own variance) plus 1e-5 relative for float rounding (the cosine estimator has zero variance).
  const Rgb Le(1.f, 0.5f, 2.f);
  for (float rho : {0.5f, 0.9f}) {
    for (int k : {0, 1, 3, 10}) {
      for (Estimator est : kAll) {
        const Film film = render_film(furnace_scene(Le, Rgb(rho), k, -1, est), 256);
        const MeanWithError m = film_mean(film);
        const double series = (1.0 - std::pow(rho, k + 1)) / (1.0 - rho);
        for (int c = 0; c < 3; ++c) {
          const double expected = Le[c] * series;
          INFO(std::string(to_string(est)) << " rho " << rho << " k " << k << " channel " << c << ": " << m.mean[c] << " vs "
                              << expected << " (SE " << m.se[c] << ")");
          CHECK(std::abs(m.mean[c] - expected) <= 4 * m.se[c] + 1e-5 * expected);
          CHECK(m.se[c] <= 0.01 * expected);  // capped: inflated noise must fail, not widen its own band
        }
        CHECK(film.rejected() == 0);
      }
    }
  }
}

TEST_CASE("render region: only its pixels are traced, each with the very samples a whole-film render gives it") {
  // Every sample's numbers come from (pixel, sample index, seed): a region's pixels must come out bit for bit as
  // in the whole film, the others untouched, and the film's statistics must cover the region alone.
  SceneDesc d = load_scene("cornell");
  d.width = 40;
  d.height = 30;
  d.render.max_bounces = 4;
  d.render.estimator = Estimator::Mis;
  const auto scene = compile_scene(d);
  const Film whole = render_film(d, 4);
  const PixelRect region{7, 5, 29, 21};  // crosses tile borders (16 px) on every side
  Film part(d.width, d.height);
  Renderer renderer(2);
  const PassStats ps = renderer.render_pass(*scene, d.render, part, 4, nullptr, &region);
  CHECK(ps.samples == 4 * region.area());
  size_t same = 0, untouched = 0;
  for (int y = 0; y < d.height; ++y)
    for (int x = 0; x < d.width; ++x) {
      const size_t i = static_cast<size_t>(y) * d.width + x;
      if (region.contains(x, y)) same += part.count(i) == 4 && part.mean(i) == whole.mean(i);
      else untouched += part.count(i) == 0;
    }
  CHECK(same == region.area());
  CHECK(untouched == part.pixel_count() - region.area());
  CHECK(part.min_count() == 0);
  CHECK(part.min_count(region) == 4);
  CHECK(std::isinf(part.estimated_relmse()));
  CHECK(std::isfinite(part.estimated_relmse(region)));
  CHECK(whole.estimated_relmse(full_rect(d.width, d.height)) == whole.estimated_relmse());
  // A region beyond the film is clipped; one wholly outside traces nothing.
  const PixelRect beyond{30, 20, 100, 100}, outside{50, 50, 60, 60};
  Film clipped(d.width, d.height);
  CHECK(renderer.render_pass(*scene, d.render, clipped, 1, nullptr, &beyond).samples == 10u * 10u);
  CHECK(renderer.render_pass(*scene, d.render, clipped, 1, nullptr, &outside).samples == 0u);
}

TEST_CASE("furnace: Russian roulette with no bounce limit converges to Le/(1−ρ)") {
  // Uniform hemisphere sampling weighs a Lambertian bounce by X = 2ρ·cos θ, and roulette only acts while the
  // throughput β < 1, so above 1 β performs a multiplicative random walk with tail P(β > x) ~ x^−k, where
  // E[X^k] = (2ρ)^k/(k+1) = 1. For ρ = 0.9, k ≈ 1.8: the uniform estimator's variance is infinite and a test in
  // standard errors is meaningless (its mean still converges). ρ = 0.7 gives k ≈ 5.6: finite variance and
  // kurtosis. The other estimators sample cos θ/π, so β = ρ^n exactly and any ρ < 1 will do.
  const Rgb Le(1.f);
  for (Estimator est : kAll) {
    for (float rho : {0.5f, est == Estimator::Uniform ? 0.7f : 0.9f}) {
      const Film film = render_film(furnace_scene(Le, Rgb(rho), stress::unlimited_bounces(est), 0, est), 1024);
      const MeanWithError m = film_mean(film);
      const double expected = 1.0 / (1.0 - rho);
      INFO(std::string(to_string(est)) << " rho " << rho << ": " << m.mean.x << " vs " << expected << " (SE " << m.se.x << ")");
      CHECK(m.se.x > 0.0);  // roulette makes it random even for the cosine estimator
      CHECK(std::abs(m.mean.x - expected) <= 4 * m.se.x);
    }
  }
}

namespace {

// Pixel-block means with standard errors from a film (blocks of b×b pixels).
struct Blocks {
  std::vector<glm::dvec3> mean, var;
};
Blocks blocks_of(const Film& f, int b) {
  const int bw = f.width() / b, bh = f.height() / b;
  Blocks r{std::vector<glm::dvec3>(bw * bh, glm::dvec3(0)), std::vector<glm::dvec3>(bw * bh, glm::dvec3(0))};
  for (int y = 0; y < bh * b; ++y)
    for (int x = 0; x < bw * b; ++x) {
      const size_t i = static_cast<size_t>(y) * f.width() + x;
      const int k = (y / b) * bw + x / b;
      r.mean[k] += glm::dvec3(f.mean(i)) / double(b * b);
      r.var[k] += f.variance_of_mean(i) / double(b * b * b * b);
    }
  return r;
}

// z-scores of the differences of two films' 8×8 (b×b) block means, per channel, from the films' own variances
// (blocks of zero variance in both are skipped).
struct BlockZ {
  double max_abs = 0, sum_sq = 0;
  int n = 0;
  double mean_sq() const { return n ? sum_sq / n : 0.0; }
};
BlockZ block_z_scores(const Film& a, const Film& b, int block) {
  const Blocks ba = blocks_of(a, block), bb = blocks_of(b, block);
  BlockZ z;
  for (size_t k = 0; k < ba.mean.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      const double sd = std::sqrt(ba.var[k][c] + bb.var[k][c]);
      if (!(sd > 0)) continue;
      const double v = (ba.mean[k][c] - bb.mean[k][c]) / sd;
      z.sum_sq += v * v;
      z.max_abs = std::max(z.max_abs, std::abs(v));
      ++z.n;
    }
  return z;
}

// `modify` adjusts the scene; estimators before `first` are left out (for lights only light sampling can find).
void check_estimators_agree(const char* scene_name, int size, int spp, int max_bounces = -1,
                            void (*modify)(SceneDesc&) = nullptr, Estimator first = Estimator::Uniform) {
  SceneDesc desc = load_scene(scene_name);
  desc.width = desc.height = size;
  if (max_bounces >= 0) desc.render.max_bounces = max_bounces;
  if (modify) modify(desc);
  desc.render.sampler = SamplerType::Independent;  // the film's variance is an honest error bar only for these
  std::vector<Film> films;
  for (Estimator est : kAll) {
    desc.render.estimator = est;
    // Different seeds: estimators that consume random numbers alike (nee and mis) would otherwise give
    // correlated images and z-scores far below their true spread.
    desc.render.seed = 100 + static_cast<uint64_t>(est);
    films.push_back(render_film(desc, spp));
    CHECK(films.back().rejected() == 0);
  }
  // Compare every estimator with MIS on 8×8-pixel blocks: z = Δ/√(σa²+σb²) from the films' own variances.
  // 3 channels × (size/8)² blocks × 4 pairs ≈ 200 z-scores: |z| < 4.5 for all (a two-sided 4.5σ event has
  // probability 7e-6 each, 1e-3 for the set) and the mean z² must be near 1 (it is ≈ 1 ± 0.2 for agreeing
  // estimators; a bias of one standard error anywhere pushes it well above 1.5).
  for (int e = static_cast<int>(first); e < static_cast<int>(films.size()); ++e) {
    if (kAll[e] == Estimator::Mis) continue;
    const BlockZ z = block_z_scores(films[e], films[3], 8);
    INFO(std::string(scene_name) << ": " << std::string(to_string(kAll[e])) << " vs mis: max |z| " << z.max_abs << ", mean z² "
                                 << z.mean_sq() << " over " << z.n);
    CHECK(z.n > 0);
    CHECK(z.max_abs < 4.5);
    CHECK(z.mean_sq() < 1.6);
  }
}

}  // namespace

TEST_CASE("agreement: the five estimators agree on cornell") { check_estimators_agree("cornell", 32, 512); }

TEST_CASE("agreement: the five estimators agree on cornell-spheres") {
  check_estimators_agree("cornell-spheres", 32, 512);
}

namespace {
// Raises every glossy roughness to at least 0.3 (smooth lobes stay smooth): see the two tests below.
void widen_glossy_lobes(SceneDesc& d) {
  for (MaterialDesc& m : d.materials)
    if (m.roughness > 0.f) m.roughness = std::max(m.roughness, 0.3f);
}
}  // namespace

// The new materials (every type, several roughness values) and the outdoor sky with its sun: a bias in any
// BSDF's eval/pdf/sample consistency or in the environment's sampling shows up as disagreement. Fewer bounces
// than the scenes' own keep the glass caustics' heavy tails (whose variance the film underestimates at low
// sample counts) from dominating the statistics.
// Near-specular glossy lobes (roughness 0.05) give next-event estimation heavy-tailed noise (a light sample
// that lands in the narrow lobe weighs ~10⁴), which the film's variance underestimates at any affordable
// sample count; the agreement check raises the glossy roughness to 0.3 (smooth lobes stay smooth).
TEST_CASE("agreement: the five estimators agree on materials") {
  check_estimators_agree("materials", 32, 2048, 4, widen_glossy_lobes);
}
// The sun subtends 7e-5 sr: BSDF sampling alone (uniform, cosine) almost never finds it, so its mean stays far
// from converged at any affordable sample count. The four estimators agree on the sky without the sun; with the
// sun, nee agrees with mis. As for `materials`, glossy lobes are widened to roughness 0.3: with the scene's gold
// (0.15) next-event estimation of the sky is heavy-tailed, its 512-spp means fall short of mis in most runs
// (mean block z ≈ −0.35 over 8 seed sets) and agree once the lobe is 0.3 wide (mean z ≈ −0.03). With the sun
// the glass ball is made diffuse: its caustic on the ground is a sun path mis finds only when a BSDF sample
// hits the sun through the glass, so mis's mean lacks most of it, with error bars that do not show it, where
// bdpt traces it from the sun (max |z| 25 at 512 spp, 49 at 2048). bdpt's caustic is checked against bdpt
// without the emission focus instead (test_bdpt.cpp).
TEST_CASE("agreement: the five estimators agree on sky (without the sun), nee, mis and bdpt with it") {
  check_estimators_agree("sky", 64, 512, 4, [](SceneDesc& d) {
    d.environment.sun = false;
    widen_glossy_lobes(d);
  });
  check_estimators_agree("sky", 64, 512, 4, [](SceneDesc& d) {
    widen_glossy_lobes(d);
    for (MaterialDesc& m : d.materials)
      if (m.type == MaterialType::Dielectric) {
        m.type = MaterialType::Diffuse;
        m.albedo = Rgb(0.5f);
      }
  }, Estimator::Nee);
}

TEST_CASE("determinism: identical images for 1, 2 and 3 threads and any pass split") {
  SceneDesc desc = load_scene("cornell-spheres");
  desc.width = 40;  // not a multiple of the tile size
  desc.height = 24;
  // bdpt too: its splats from other tiles are added in tile order after each round, whatever the scheduling.
  std::vector<std::vector<float>> images;
  for (Estimator est : {Estimator::Bdpt, desc.render.estimator}) {
    desc.render.estimator = est;
    const auto scene = compile_scene(desc);
    images.clear();
    for (int threads : {1, 2, 3}) {
      Film film(desc.width, desc.height);
      Renderer r(threads);
      r.render_pass(*scene, desc.render, film, 3);
      r.render_pass(*scene, desc.render, film, 5);
      images.push_back(film.mean_image());
      CHECK(film.min_count() == 8);
    }
    Film film(desc.width, desc.height);
    Renderer(2).render_pass(*scene, desc.render, film, 8);  // same samples, one pass
    images.push_back(film.mean_image());
    for (size_t i = 1; i < images.size(); ++i)
      CHECK(std::memcmp(images[0].data(), images[i].data(), images[0].size() * sizeof(float)) == 0);
  }
  // And the PFM files written from them are byte-identical.
  const std::string a = "determinism_a.pfm", b = "determinism_b.pfm";
  write_pfm(a, Image{desc.width, desc.height, images[0]});
  write_pfm(b, Image{desc.width, desc.height, images[2]});
  const Image ia = read_pfm(a), ib = read_pfm(b);
  CHECK(std::memcmp(ia.rgb.data(), ib.rgb.data(), ia.rgb.size() * sizeof(float)) == 0);
  // A different seed gives a different image.
  desc.render.seed = 1;
  Film other(desc.width, desc.height);
  Renderer(2).render_pass(*compile_scene(desc), desc.render, other, 8);
  CHECK(std::memcmp(images[0].data(), other.mean_image().data(), images[0].size() * sizeof(float)) != 0);
}

TEST_CASE("renderer: a cancelled pass stops early and leaves a consistent film") {
  SceneDesc desc = load_scene("cornell");
  desc.width = desc.height = 64;
  const auto scene = compile_scene(desc);
  Film film(64, 64);
  Renderer r(2);
  std::atomic<bool> cancel{true};
  const PassStats ps = r.render_pass(*scene, desc.render, film, 100, &cancel);
  CHECK(ps.cancelled);
  CHECK(ps.samples == 0);
  CHECK(film.total_count() == 0);
}

namespace {

// A sphere of the given material under a uniform background of radiance 1, seen from outside.
SceneDesc white_furnace(MaterialType type, Estimator est, float albedo = 1.f, float roughness = 0.f) {
  SceneDesc s;
  s.camera.position = {0, 0, 4};
  s.camera.look_at = {0, 0, 0};
  s.camera.fov_deg = 40;
  s.width = s.height = 16;
  s.environment.radiance = Rgb(1.f);
  s.render.max_bounces = 1000;
  s.render.russian_roulette_depth = -1;
  s.render.estimator = est;
  s.render.sampler = SamplerType::Independent;
  MaterialDesc m;
  m.name = "m";
  m.type = type;
  m.albedo = Rgb(albedo);
  m.ior = 1.5f;
  m.roughness = roughness;
  s.materials = {m};
  ShapeDesc ball;
  ball.type = ShapeType::Sphere;
  ball.center = {0, 0, 0};
  ball.radius = 1.0;
  s.shapes = {ball};
  return s;
}

}  // namespace

TEST_CASE("white furnace: albedo-1 materials under a uniform background return 1") {
  for (Estimator est : kAll) {
    // Diffuse: exactly 1 per sample for cosine, NEE and MIS (light samples and BSDF samples both have the
    // ideal density), 1 on average for uniform.
    const Film film = render_film(white_furnace(MaterialType::Diffuse, est), 64);
    const MeanWithError m = film_mean(film);
    INFO(std::string(to_string(est)) << ": " << m.mean.x << " ± " << m.se.x);
    CHECK(std::abs(m.mean.x - 1.0) <= 4 * m.se.x + 1e-5);
    // (bdpt weighs light tracing and light samples of a uniform sphere of directions in too: not exact per sample)
    if (est != Estimator::Uniform && est != Estimator::Bdpt) CHECK(m.se.x < 1e-5);
    CHECK(film.rejected() == 0);
    // Mirror of albedo 1 and the dielectric: every path returns exactly 1 whatever the estimator (delta
    // scattering only; total internal reflection inside the glass ends when the bounce limit is reached, which
    // loses a negligible share), so the mean is 1 to within the tiny share of trapped paths.
    for (MaterialType t : {MaterialType::Mirror, MaterialType::Dielectric}) {
      const Film f = render_film(white_furnace(t, est), 64);
      const MeanWithError mm = film_mean(f);
      INFO(to_string(t) << ": " << mm.mean.x << " ± " << mm.se.x);
      CHECK(std::abs(mm.mean.x - 1.0) <= 4 * mm.se.x + 1e-4);
    }
  }
}

TEST_CASE("white furnace: a white conductor returns its quadrature albedo at every roughness (Kulla–Conty)") {
  // A convex sphere under a uniform background of radiance 1: each visible point reflects its directional
  // albedo once (its reflection escapes). Single-scattering GGX would lose up to ~40 % at roughness 1; with the
  // energy compensation the directional albedo is 0.99876 to 1.00077 by quadrature (test_materials.cpp, "white
  // conductor"), so the image must lie in [0.9985, 1.0010] within 4 standard errors (at 1024 spp the standard
  // error is at most 6e-4: a 1 % loss fails; the old band, 1 % plus 4 SE at 256 spp, let 1.5 % through).
  for (float roughness : {0.f, 0.25f, 0.5f, 1.f}) {
    for (Estimator est : {Estimator::Cosine, Estimator::Mis}) {
      const Film f = render_film(white_furnace(MaterialType::Conductor, est, 1.f, roughness), 1024);
      const MeanWithError m = film_mean(f);
      INFO("roughness " << roughness << ", " << std::string(to_string(est)) << ": " << m.mean.x << " ± " << m.se.x);
      CHECK(m.mean.x > 0.9985 - 4 * m.se.x);
      CHECK(m.mean.x < 1.0010 + 4 * m.se.x);
      CHECK(m.se.x < 7e-4);
      CHECK(f.rejected() == 0);
    }
  }
}

TEST_CASE("white furnace: a white glTF metallic-roughness dielectric returns 1 and a half-metal less") {
  // metallic 0, base colour 1: the coupled base takes exactly what the specular layer leaves (directional albedo
  // 1 to the energy table's ~1e-3, test_materials.cpp), so the image is 1 within 4 standard errors plus 3e-3.
  // The specification's own 1 − F weighting would give up to 1.2-1.6 at the sphere's grazing rim.
  for (float roughness : {0.f, 0.3f, 1.f})
    for (Estimator est : {Estimator::Cosine, Estimator::Mis, Estimator::Bdpt}) {
      SceneDesc d = white_furnace(MaterialType::MetallicRoughness, est, 1.f, roughness);
      const Film f = render_film(d, 256);
      const MeanWithError m = film_mean(f);
      INFO("roughness " << roughness << ", " << std::string(to_string(est)) << ": " << m.mean.x << " ± " << m.se.x);
      CHECK(std::abs(m.mean.x - 1.0) <= 4 * m.se.x + 3e-3);
      CHECK(f.rejected() == 0);
      // A half-metal of the same white: its metal half is single-scattering (no compensation, as specified),
      // so a rough one loses energy: visibly below 1 at roughness 1.
      if (roughness == 1.f && est == Estimator::Mis) {
        d.materials[0].metallic = 0.5f;
        const MeanWithError half = film_mean(render_film(d, 256));
        INFO("half-metal: " << half.mean.x << " ± " << half.se.x);
        CHECK(half.mean.x < 0.95);
        CHECK(half.mean.x > 0.7);
      }
    }
}

TEST_CASE("white furnace: a diffuse sphere of albedo ρ under a constant environment of radiance 1 converges to ρ") {
  // Convex, so every visible point sees the whole upper hemisphere of radiance 1: L = ρ·(π·1)/π = ρ exactly.
  for (float rho : {0.2f, 0.5f, 0.9f})
    for (Estimator est : kAll) {
      SceneDesc d = white_furnace(MaterialType::Diffuse, est, rho);
      // Pixels on the sphere only: a narrow field of view inside its silhouette.
      d.camera.fov_deg = 10;
      const MeanWithError m = film_mean(render_film(d, 64));
      INFO("ρ " << rho << ", " << std::string(to_string(est)) << ": " << m.mean.x << " ± " << m.se.x);
      CHECK(std::abs(m.mean.x - rho) <= 4 * m.se.x + 1e-5);
    }
}

TEST_CASE("environment: a constant map renders the image of the constant environment, within noise") {
  // A 16×8 PFM of one colour, read through the scene loader like any map file.
  const std::string path = "env_const_" + std::to_string(::getpid()) + ".pfm";
  Image img{16, 8, std::vector<float>(16 * 8 * 3)};
  for (size_t i = 0; i < img.rgb.size(); i += 3) img.rgb[i] = 0.6f, img.rgb[i + 1] = 0.8f, img.rgb[i + 2] = 1.2f;
  write_pfm(path, img);
  SceneDesc constant = load_scene("cornell-spheres");
  constant.width = constant.height = 32;
  constant.render.sampler = SamplerType::Independent;
  constant.render.max_bounces = 3;
  // Open the box: without its front-facing back wall the room sees the environment.
  constant.shapes.erase(constant.shapes.begin() + 2);
  constant.environment.radiance = Rgb(0.6f, 0.8f, 1.2f);
  SceneDesc map = constant;
  map.environment = EnvironmentDesc{};
  map.environment.type = EnvironmentType::Map;
  map.environment.file = path;
  map.render.seed = 7;
  const Film a = render_film(constant, 256), b = render_film(map, 256);
  std::filesystem::remove(path);
  const BlockZ z = block_z_scores(a, b, 8);
  INFO("max |z| " << z.max_abs << ", mean z² " << z.mean_sq() << " over " << z.n);
  CHECK(z.n >= 24);  // blocks that see only the environment are exactly equal (zero variance): not counted
  CHECK(z.max_abs < 4.5);  // two-sided 4.5σ: 7e-6 per z-score
  CHECK(z.mean_sq() < 1.6);
}

TEST_CASE("sobol sampler: unbiased, and lower error than independent samples at equal sample count") {
  // Scrambled Sobol samples within a pixel are not independent, so the film's variance is no error bar for
  // them. Instead: 16 renders with different seeds are independent replicas; their spread gives the standard
  // error of the replica mean. Blocks of 8×8 pixels of cornell (32×32, mis): the replica mean must agree with
  // a 1024-spp independent render (z from both error bars), and the per-pixel squared error of one 64-spp
  // Sobol render against the independent 1024-spp image must be smaller than that of a 64-spp independent one.
  SceneDesc desc = load_scene("cornell");
  desc.width = desc.height = 32;
  desc.render.sampler = SamplerType::Independent;
  const Film reference = render_film(desc, 1024);
  const Film independent64 = render_film(desc, 64);
  desc.render.sampler = SamplerType::Sobol;
  const int replicas = 16, spp = 64;
  std::vector<std::vector<float>> images;
  for (int r = 0; r < replicas; ++r) {
    desc.render.seed = 1000 + r;
    const Film f = render_film(desc, spp);
    CHECK(f.rejected() == 0);
    images.push_back(f.mean_image());
  }
  const Blocks ref = blocks_of(reference, 8);
  const int bw = 4;
  double z2 = 0, zmax = 0;
  int n = 0;
  for (int k = 0; k < bw * bw; ++k)
    for (int c = 0; c < 3; ++c) {
      std::vector<double> block_means;
      for (const auto& img : images) {
        double m = 0;
        for (int y = (k / bw) * 8; y < (k / bw + 1) * 8; ++y)
          for (int x = (k % bw) * 8; x < (k % bw + 1) * 8; ++x) m += img[3 * (y * 32 + x) + c] / 64.0;
        block_means.push_back(m);
      }
      double mean = 0, var = 0;
      for (double m : block_means) mean += m / replicas;
      for (double m : block_means) var += (m - mean) * (m - mean) / (replicas - 1);
      const double z = (mean - ref.mean[k][c]) / std::sqrt(var / replicas + ref.var[k][c]);
      z2 += z * z;
      zmax = std::max(zmax, std::abs(z));
      ++n;
    }
  INFO("sobol replicas vs independent: max |z| " << zmax << ", mean z² " << z2 / n);
  // 48 z-scores with a t-like tail (15 degrees of freedom): |z| < 6 (p < 1e-4 each) and mean z² near 1
  // (a t15 variable has E[z²] = 15/13 ≈ 1.15).
  CHECK(zmax < 6.0);
  CHECK(z2 / n < 1.8);
  // Error of one Sobol render against the reference vs an independent render of equal spp.
  double err_sobol = 0, err_indep = 0;
  const std::vector<float> r_img = reference.mean_image(), i_img = independent64.mean_image();
  for (size_t i = 0; i < r_img.size(); ++i) {
    err_sobol += sqr(images[0][i] - r_img[i]);
    err_indep += sqr(i_img[i] - r_img[i]);
  }
  INFO("squared error at 64 spp: sobol " << err_sobol << ", independent " << err_indep);
  CHECK(err_sobol < err_indep);
}

TEST_CASE("adaptive sampling: the converged image agrees with uniform sampling") {
  // cornell 32×32, mis, independent samples: 64 uniform passes of 8 spp with adaptive plans vs a 1024-spp
  // uniform render. Adaptive pixels have unequal sample counts, but each pixel's mean stays an average of
  // its own samples; a bias from choosing counts by the pixels' own variance would show as block z-scores
  // far from N(0,1). Same criteria and confidence as the estimator agreement test.
  SceneDesc desc = load_scene("cornell");
  desc.width = desc.height = 32;
  desc.render.sampler = SamplerType::Independent;
  const Film uniform = render_film(desc, 1024);
  desc.render.seed = 7;  // independent of the uniform render's samples
  const auto scene = compile_scene(desc);
  Film adaptive(32, 32);
  Renderer r(0);
  for (uint64_t pass = 0; pass < 64; ++pass)
    r.render_pass(*scene, desc.render, adaptive, plan_adaptive_pass(adaptive, Renderer::kTileSize, 8, pass));
  // The plan really is uneven once past the uniform start.
  const std::vector<int> plan = plan_adaptive_pass(adaptive, Renderer::kTileSize, 8, 1);
  CHECK(*std::max_element(plan.begin(), plan.end()) > *std::min_element(plan.begin(), plan.end()));
  CHECK(adaptive.total_count() == doctest::Approx(64.0 * 8 * 32 * 32).epsilon(0.02));
  const Blocks a = blocks_of(adaptive, 8), u = blocks_of(uniform, 8);
  double z2 = 0, zmax = 0;
  int n = 0;
  for (size_t k = 0; k < a.mean.size(); ++k)
    for (int c = 0; c < 3; ++c) {
      const double z = (a.mean[k][c] - u.mean[k][c]) / std::sqrt(a.var[k][c] + u.var[k][c]);
      z2 += z * z;
      zmax = std::max(zmax, std::abs(z));
      ++n;
    }
  INFO("adaptive vs uniform: max |z| " << zmax << ", mean z² " << z2 / n);
  CHECK(zmax < 4.5);
  CHECK(z2 / n < 1.6);
}

TEST_CASE("kernels: each scene runs the kernel of exactly its features, with the generic kernel's image") {
  struct Expect {
    const char* scene;
    uint32_t features;
  };
  // cornell: Lambertian polygons only; cornell-spheres: polygons and spheres of mirror and glass.
  for (const Expect& e : {Expect{"cornell", kFeaturePolygons},
                          Expect{"cornell-spheres", kFeaturePolygons | kFeatureSpheres | kFeatureGeneralMaterials}}) {
    INFO(e.scene);
    CHECK(compile_scene(load_scene(e.scene))->kernel_features() == e.features);
  }
  for (const std::string& name : builtin_scene_names()) {
    SceneDesc desc = load_scene(name);
    desc.width = 24;
    desc.height = 16;
    std::vector<float> images[2];
    for (bool generic : {false, true}) {
      desc.render.generic_kernel = generic;
      images[generic] = render_film(desc, 4, 2).mean_image();
    }
    INFO(name);
    // Same samples through both kernels: the specialised one must leave out only code that cannot run.
    CHECK(std::memcmp(images[0].data(), images[1].data(), images[0].size() * sizeof(float)) == 0);
  }
  // Lights do not select kernels (they are a run-time choice): a background leaves the cornell kernel as it is. A
  // material other than Lambert selects the general-material kernel, and an in-place edit back to Lambert
  // returns to the lean one.
  SceneDesc desc = load_scene("cornell");
  desc.environment.radiance = Rgb(0.5f);
  CHECK(compile_scene(desc)->kernel_features() == kFeaturePolygons);
  SceneDesc mirror = desc;
  mirror.materials[0].type = MaterialType::Mirror;
  const std::shared_ptr<Scene> scene = compile_scene(mirror);
  CHECK(scene->kernel_features() == (kFeaturePolygons | kFeatureGeneralMaterials));
  REQUIRE(update_scene_appearance(*scene, mirror, desc));
  CHECK(scene->kernel_features() == kFeaturePolygons);
}

namespace {

// The same 4 samples per pixel through two compiled scenes give the same image, bit for bit.
bool same_image(const Scene& a, const Scene& b, const RenderSettings& settings) {
  std::vector<float> images[2];
  int k = 0;
  for (const Scene* scene : {&a, &b}) {
    Film film(scene->width, scene->height);
    Renderer(2).render_pass(*scene, settings, film, 4);
    images[k++] = film.mean_image();
  }
  return images[0].size() == images[1].size() &&
         std::memcmp(images[0].data(), images[1].data(), images[0].size() * sizeof(float)) == 0;
}

}  // namespace

TEST_CASE("edits in place: materials and environment without recompiling geometry") {
  SceneDesc before = load_scene("cornell-spheres");
  before.width = 24;
  before.height = 16;
  SceneDesc after = before;
  after.materials[0].albedo = Rgb(0.3f, 0.6f, 0.9f);
  after.materials[4].type = MaterialType::Conductor;  // the chrome ball becomes brushed gold
  after.materials[4].metal = MetalPreset::Gold;
  after.materials[4].roughness = 0.4f;
  after.materials[3].emission = Rgb(5.f, 5.f, 5.f);   // the light dims
  after.environment.type = EnvironmentType::Sky;
  after.render.max_bounces = 3;
  REQUIRE(same_geometry(before, after));
  const std::shared_ptr<Scene> edited = compile_scene(before);
  const Vec3 vertex = edited->polygons.v[0][0];
  REQUIRE(update_scene_appearance(*edited, before, after));
  CHECK(edited->polygons.v[0][0] == vertex);
  CHECK(edited->environment.present);
  // The same samples through the scene edited in place and through a scene compiled from `after`: bit for bit.
  const std::shared_ptr<const Scene> fresh = compile_scene(after);
  CHECK(same_image(*edited, *fresh, after.render));
  // A geometry edit is refused (the caller recompiles instead).
  SceneDesc moved = after;
  moved.shapes[0].vertices[0].x += 1.0;
  CHECK_FALSE(same_geometry(after, moved));
  CHECK_THROWS_AS(update_scene_appearance(*edited, after, moved), std::invalid_argument);
}

TEST_CASE("edits in place: a camera move keeps the geometry and renders like a fresh compile, a far move refuses") {
  SceneDesc before = load_scene("cornell");
  before.width = before.height = 32;
  before.render.sampler = SamplerType::Independent;
  SceneDesc after = before;
  after.camera.position += DVec3(40.0, -25.0, 150.0);
  after.camera.look_at += DVec3(-30.0, 10.0, 0.0);
  after.camera.fov_deg = 45.0;
  const std::shared_ptr<Scene> edited = compile_scene(before);
  const Vec3 vertex = edited->polygons.v[0][0];
  REQUIRE(update_scene_appearance(*edited, before, after));
  CHECK(edited->polygons.v[0][0] == vertex);  // the geometry was not touched
  CHECK(edited->camera.origin == Vec3(40.f, -25.f, 150.f));
  // Against a scene compiled at the new camera: the same image within noise (independent seeds, 8×8 blocks).
  SceneDesc fresh_desc = after;
  fresh_desc.render.seed = 11;
  const std::shared_ptr<const Scene> fresh = compile_scene(fresh_desc);
  Film a(32, 32), b(32, 32);
  Renderer(2).render_pass(*edited, after.render, a, 256);
  Renderer(2).render_pass(*fresh, fresh_desc.render, b, 256);
  const BlockZ z = block_z_scores(a, b, 8);
  INFO("max |z| " << z.max_abs << ", mean z² " << z.mean_sq() << " over " << z.n);
  CHECK(z.n == 48);
  CHECK(z.max_abs < 4.5);
  CHECK(z.mean_sq() < 1.6);
  // Moving beyond the scene's bounding radius from where it was compiled asks for a recompile instead.
  SceneDesc far = after;
  far.camera.position += DVec3(0.0, 0.0, -1e5);
  far.camera.look_at += DVec3(0.0, 0.0, -1e5);
  const Camera kept = edited->camera;
  CHECK_FALSE(update_scene_appearance(*edited, after, far));
  CHECK(edited->camera.origin == kept.origin);
}

TEST_CASE("typed edits: a material, the environment and the camera applied in place render like a fresh compile") {
  SceneDesc desc = load_scene("cornell-spheres");
  desc.width = 24;
  desc.height = 16;
  const std::shared_ptr<Scene> edited = compile_scene(desc);
  const Vec3 vertex = edited->polygons.v[0][0];
  MaterialDesc gold = desc.materials[4];
  gold.type = MaterialType::Conductor;
  gold.metal = MetalPreset::Gold;
  gold.roughness = 0.4f;
  MaterialDesc dim = desc.materials[3];
  dim.emission = Rgb(5.f);
  EnvironmentDesc sky;
  sky.type = EnvironmentType::Sky;
  CameraDesc camera = desc.camera;
  camera.position += DVec3(20.0, -10.0, 40.0);
  camera.fov_deg = 50.0;
  SceneDesc after = desc;
  for (const SceneEdit& e : {SceneEdit{MaterialEdit{4, gold}}, SceneEdit{MaterialEdit{3, dim}}, SceneEdit{sky},
                             SceneEdit{camera}}) {
    REQUIRE(validate_edit(after, e).empty());
    apply_edit(after, e);
    REQUIRE(apply_edit(*edited, e));
  }
  CHECK(after.materials[4].type == MaterialType::Conductor);
  CHECK(after.camera.fov_deg == 50.0);
  CHECK(edited->polygons.v[0][0] == vertex);  // the geometry was not touched
  CHECK(edited->environment.present);
  CHECK(edited->environment.sun.kind == LightKind::Sun);
  CHECK(edited->lights.size() == compile_scene(after)->lights.size());
  // Bit for bit against a fresh compile, except for the camera: a moved eye has camera-relative geometry of
  // its own, so compare the camera with the original eye position back.
  SceneDesc fresh_desc = after;
  fresh_desc.camera = desc.camera;
  REQUIRE(apply_edit(*edited, SceneEdit{desc.camera}));
  const std::shared_ptr<const Scene> fresh = compile_scene(fresh_desc);
  CHECK(same_image(*edited, *fresh, after.render));
}

TEST_CASE("typed edits: invalid ones are refused with the field and the reason") {
  const SceneDesc desc = load_scene("cornell");
  CHECK(validate_edit(desc, SceneEdit{MaterialEdit{desc.materials.size(), desc.materials[0]}}) ==
        "materials[" + std::to_string(desc.materials.size()) + "]: no such material");
  MaterialDesc bad = desc.materials[0];
  bad.roughness = 2.f;
  CHECK(validate_edit(desc, SceneEdit{MaterialEdit{0, bad}}) == "materials." + bad.name + ".roughness: must be in [0, 1]");
  CameraDesc camera = desc.camera;
  camera.fov_deg = 180.0;
  CHECK(validate_edit(desc, SceneEdit{camera}) == "camera.fov_deg: must be in (0, 180) degrees");
  EnvironmentDesc env;
  env.type = EnvironmentType::Sky;
  env.turbidity = 20.f;
  CHECK(validate_edit(desc, SceneEdit{env}) == "environment.turbidity: must be in [1.7, 10]");
  RenderSettings render;
  render.max_bounces = -1;
  CHECK(validate_render_settings(render) == "render.max_bounces: must be >= 0");
}

TEST_CASE("progressive passes: adaptive passes add the samples they plan, and under bdpt they stay uniform") {
  // bdpt runs a per-tile plan's largest count for every pixel (its light subpaths reach every tile): adaptive
  // plans (tiles at up to 8x the mean) made a pass of mean 8 spp trace up to 64 everywhere, and the measured cost
  // per spp came out 8x too high (bench's budgets were missed). ProgressivePasses keeps bdpt's passes uniform.
  SceneDesc d = load_scene("cornell-spheres");
  d.width = d.height = 48;
  for (Estimator est : {Estimator::Mis, Estimator::Bdpt}) {
    d.render.estimator = est;
    const auto scene = compile_scene(d);
    Film film(d.width, d.height);
    film.enable_features(false);
    Renderer renderer(2);
    ProgressivePasses passes(renderer, *scene, d.render, film, true);
    for (int i = 0; i < 4; ++i) passes.render(8);  // passes 1-3 adaptive once every pixel has 8 spp
    INFO(std::string(enum_name(est)) << ": min " << film.min_count() << ", samples " << passes.samples());
    CHECK(passes.passes_spp() == 32u);
    // Every pass adds about its planned total, mean 8 spp over the image (per-tile counts are rounded); under
    // bdpt exactly, every pixel 32 (before: up to 8x more on the adaptive passes).
    const double planned = 32.0 * d.width * d.height;
    CHECK(std::abs(static_cast<double>(passes.samples()) / planned - 1.0) < 0.02);
    if (est == Estimator::Bdpt) {
      CHECK(passes.samples() == static_cast<uint64_t>(planned));
      CHECK(film.min_count() == 32u);
    }
  }
}
