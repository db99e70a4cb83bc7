#include "integrators/feature_pass.h"

#include "geometry/scene_queries.h"
#include "integrators/path_tracer.h"

namespace pt {

namespace {

// Every kind of primitive and material: one kernel serves every scene (a guide pass is one ray per pixel, so the
// specialised kernels' savings would not pay for their code).
constexpr uint32_t F = kAllFeatures;
constexpr MaterialSet kM = MaterialSet::Any;

// The features of one camera ray whose first hit (if any) is known: `found`, `hit`. At a specular vertex with two
// lobes (smooth glass) the chain takes the likelier one (the lobe a path draws with u = 1/2: refraction unless the
// Fresnel reflectance passes 1/2), so neighbouring guide pixels agree, where a random lobe per pixel would make
// a glass ball's guide (and the preview multiplied by its albedo) a salt-and-pepper mix of the two.
PixelFeatures features_along(const Scene& s, const RenderSettings& settings, Ray ray, bool found, Hit hit) {
  PixelFeatures out;
  FeatureTrace trace{&out};
  Rgb L(0.f), beta(1.f);
  uint32_t skip = ~0u;
  // The ray cone of the pixel's centre ray, a whole pixel wide: the guide is one sample per pixel, and a textured
  // albedo filtered over the pixel is what the preview multiplies back.
  const float spread = integrator_detail::PathOptions(settings, s.camera).pixel_angle;
  float cone_width = 0.f;
  for (int depth = 0;; ++depth) {
    if (depth > 0) found = intersect_scene<F>(s, ray, kInfinity, skip, hit);
    if (!found) {
      if (!s.infinite_lights.empty()) L += beta * integrator_detail::escaped_radiance<false>(s, ray.d, Vec3(0.f), 0.f);
      trace.escaped(L);
      return out;
    }
    Interaction it = make_interaction<F>(s, ray, hit);
    cone_width += spread * hit.t;
    MaterialScratch scratch;
    const Material& m = material_at<kM>(s, it, ray.d, cone_width, scratch);
    const Vec3 wo = -ray.d;
    if (!is_black(m.emission)) {
      const Light& light = s.lights[s.light_of(it.prim)];
      L += beta * area_light_emission(light, it.ng, wo) * (light.emission_map.texture ? emission_texel(light, it.uv) : Rgb(1.f));
    }
    trace.at_vertex<kM>(depth, ray.o, it, wo, m, depth >= settings.max_bounces, L);
    if (!trace.out) return out;
    // A specular vertex: continue along the lobe a path would draw here.
    const Frame frame = Frame::from_normal(it.ns != it.ng ? shading_normal(it, wo) : it.ng);
    BsdfSample bs;
    if (!bsdf_sample<kM>(m, frame.to_local(wo), 0.5f, Vec2(0.5f), bs) ||
        !(bs.pdf > 0.f) || bs.wi.z == 0.f)
      return out;  // the features of this vertex stand
    beta *= bs.f * (std::abs(bs.wi.z) / bs.pdf);
    trace.through_specular(bs);
    const Vec3 wi = frame.to_world(bs.wi);
    ray = {offset_ray_origin(it, wi), wi};
    skip = skip_on_leave(it);
  }
}

}  // namespace

void trace_feature_image(const Scene& scene, const RenderSettings& settings, ThreadPool& pool, FeatureImage& out) {
  const int w = scene.width, h = scene.height;
  out.width = w;
  out.height = h;
  const size_t n = out.pixel_count();
  out.albedo.resize(3 * n);
  out.normal.resize(3 * n);
  out.depth.resize(n);
  out.emission.resize(3 * n);
  pool.parallel_for(h, [&](int y, int) {
    // Camera rays of a row in packets of kLanes: coherent, so the first hit is found a packet at a time.
    for (int x0 = 0; x0 < w; x0 += kLanes) {
      const int lanes = std::min(kLanes, w - x0);
      Ray rays[kLanes];
      float t_max[kLanes];
      uint32_t skip[kLanes];
      Hit hits[kLanes];
      bool found[kLanes];
      for (int l = 0; l < lanes; ++l) {
        rays[l] = scene.camera.generate_ray(static_cast<float>(x0 + l) + 0.5f, static_cast<float>(y) + 0.5f);
        t_max[l] = kInfinity;
        skip[l] = ~0u;
      }
      intersect_scene_packet<F>(scene, rays, t_max, skip, lanes, hits, found);
      for (int l = 0; l < lanes; ++l) {
        const size_t i = static_cast<size_t>(y) * w + static_cast<size_t>(x0 + l);
        const PixelFeatures f = features_along(scene, settings, rays[l], found[l], hits[l]);
        for (int c = 0; c < 3; ++c) {
          out.albedo[3 * i + c] = f.albedo[c];
          out.normal[3 * i + c] = f.normal[c];
          out.emission[3 * i + c] = f.emission[c];
        }
        out.depth[i] = f.depth;
      }
    }
  });
}

}  // namespace pt
