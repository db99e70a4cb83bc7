// What the shading lanes (shading_lanes.h) know of their kLanes paths, in structure of arrays: one aligned array
// of kLanes floats per quantity, so that each stage loads a quantity of every lane as one vfloat. The stages fill
// the parts in order (gather, hit point, frame, light choice, light sample, BSDF sample, continuation); a part is
// read only by
// the stages after the one that writes it. A lane the lanes do not shade keeps the harmless values `clear`
// writes into every lane before the gather (the lanes compute every lane; its results are never used).
#pragma once
#include <cstdint>

#include "core/lanes.h"
#include "materials/material.h"

namespace pt {
namespace integrator_detail {

inline constexpr int kPacket = kLanes;

// Writes v into every lane of the array a (one vector store: the packet is cleared whole, not lane by lane).
[[gnu::always_inline]] inline void fill_lanes(float* a, float v) { vfloat(v).copy_to(a, stdx::vector_aligned); }
template <class... A>
[[gnu::always_inline]] inline void fill_lanes(float v, A*... arrays) {
  (fill_lanes(arrays, v), ...);
}

// The path's ray and state, gathered from its PathState and Hit.
struct LaneRays {
  alignas(64) float ox[kPacket], oy[kPacket], oz[kPacket];  // the ray's origin
  alignas(64) float dx[kPacket], dy[kPacket], dz[kPacket];  // its direction
  alignas(64) float t[kPacket];                             // the hit's distance along it
  alignas(64) float beta_r[kPacket], beta_g[kPacket], beta_b[kPacket];  // the throughput
  alignas(64) float eta[kPacket];                           // the η scale (the roulette's worth)

  void clear() {
    fill_lanes(0.f, ox, oy, oz, dx, dy, t);
    fill_lanes(1.f, dz, beta_r, beta_g, beta_b, eta);
  }
};

// The hit polygon (PolygonSoA): what make_interaction and vertex_shading read of it. A lane whose hit is on a
// sphere or on a kept instance's triangle has its geometric normal here (and as its three vertex normals, so that
// vertex_shading's lanes leave it flat), `sphere` or `instance` set, and its point and error bound (make_interaction's,
// in the gather), which lane_hit_points copies; an instance's shading normal and terminator offset too
// (instance_point's vertex_shading, in double-placed vertices).
struct LanePolygons {
  // Its corners a, v1, v2 and v3 (a triangle's v3 is unused).
  alignas(64) float ax[kPacket], ay[kPacket], az[kPacket], v1x[kPacket], v1y[kPacket], v1z[kPacket];
  alignas(64) float v2x[kPacket], v2y[kPacket], v2z[kPacket], v3x[kPacket], v3y[kPacket], v3z[kPacket];
  // The dual vectors of its two triangles (barycentrics by dot products: PolygonSoA::dual).
  alignas(64) float d00x[kPacket], d00y[kPacket], d00z[kPacket], d01x[kPacket], d01y[kPacket], d01z[kPacket];
  alignas(64) float d10x[kPacket], d10y[kPacket], d10z[kPacket], d11x[kPacket], d11y[kPacket], d11z[kPacket];
  // The barycentric margins of its two triangles (PolygonSoA::edge_margin).
  alignas(64) float m0x[kPacket], m0y[kPacket], m0z[kPacket], m1x[kPacket], m1y[kPacket], m1z[kPacket];
  alignas(64) float ngx[kPacket], ngy[kPacket], ngz[kPacket];  // the geometric normal
  alignas(64) float quad[kPacket];                             // 1 for a parallelogram, 0 for a triangle
  alignas(64) float vn[3][3][kPacket];  // on a smooth-shaded scene, its vertex normals: [vertex][axis][lane]
  alignas(64) float sphere[kPacket];    // 1 for a sphere's hit (no polygon); set where the packet holds one
  alignas(64) float instance[kPacket];  // 1 for a kept instance's hit; set where the packet holds a sphere or one
  alignas(64) float spx[kPacket], spy[kPacket], spz[kPacket], sex[kPacket], sey[kPacket], sez[kPacket];  // its p, bound
  // An instance's hit on a smooth-shaded scene: its shading normal, terminator offset and whether rays leave from it.
  alignas(64) float insx[kPacket], insy[kPacket], insz[kPacket], ilfx[kPacket], ilfy[kPacket], ilfz[kPacket];
  alignas(64) float ilifted[kPacket];

  void clear(bool smooth_scene) {
    fill_lanes(0.f, ax, ay, az, v1x, v1y, v1z, v2x, v2y, v2z, v3x, v3y, v3z);
    fill_lanes(0.f, d00x, d00y, d00z, d01x, d01y, d01z, d10x, d10y, d10z, d11x, d11y, d11z);
    fill_lanes(0.f, m0x, m0y, m0z, m1x, m1y, m1z, ngx, ngy, quad);
    fill_lanes(1.f, ngz);
    if (smooth_scene)
      for (auto& n : vn) fill_lanes(0.f, n[0], n[1]), fill_lanes(1.f, n[2]);
  }
  // Before the first sphere's or instance's lane (these arrays are read only in packets holding one).
  void clear_given_points(bool smooth_scene) {
    fill_lanes(0.f, sphere, instance, spx, spy, spz, sex, sey, sez);
    if (smooth_scene) fill_lanes(0.f, insx, insy, ilfx, ilfy, ilfz, ilifted), fill_lanes(1.f, insz);
  }
};

// The material each lane shades with (the rough lobes' parameters are lane_lobes.h's LaneLobes).
struct LaneMaterials {
  alignas(64) float alb_r[kPacket], alb_g[kPacket], alb_b[kPacket];  // the albedo (the Lambert lobe's ρ)
  alignas(64) uint32_t index[kPacket];   // the hit polygon's material in Scene::materials
  alignas(64) uint8_t textured[kPacket];  // 1: resolved at the hit by material_at (into the caller's scratch)
  alignas(64) uint8_t emits[kPacket];     // 1: it emits (an area light)
  const Material* of[kPacket];            // the material (the scene's, or its resolved copy)

  void clear() { fill_lanes(1.f, alb_r, alb_g, alb_b); }
};

// The hit point (make_interaction) and, on a smooth-shaded scene, vertex_shading's normal and terminator offset.
struct LaneHits {
  alignas(64) float px[kPacket], py[kPacket], pz[kPacket];  // the point, re-interpolated from the corners
  alignas(64) float ex[kPacket], ey[kPacket], ez[kPacket];  // its error bound (offset_ray_origin)
  alignas(64) float bary[3][kPacket];                       // its barycentrics (textured lanes only)
  alignas(64) float u[kPacket], v[kPacket];                 // its texture coordinates (textured lanes only)
  alignas(64) float nsx[kPacket], nsy[kPacket], nsz[kPacket];  // the shading normal (a normal map's, if any)
  alignas(64) float lfx[kPacket], lfy[kPacket], lfz[kPacket];  // the terminator offset (it.lift)
  alignas(64) float lifted[kPacket];                        // 1 where rays leave the front from p + lift
};

// The shading frame: s, t and fn (its z); wo's z in it; the geometric normal on wo's side.
struct LaneFrames {
  alignas(64) float sx[kPacket], sy[kPacket], sz[kPacket], tx[kPacket], ty[kPacket], tz[kPacket];
  alignas(64) float fnx[kPacket], fny[kPacket], fnz[kPacket];
  alignas(64) float wlz[kPacket];                           // wo's z in the frame
  alignas(64) float nx[kPacket], ny[kPacket], nz[kPacket];  // the geometric normal facing wo (lights' side)
  alignas(64) float smooth[kPacket];                        // 1 where the frame is about a bent shading normal
};

// The chosen light and its sample: a parallelogram's corners and emission, sampled in the lanes, or any other
// light's own sample (sample_li, taken one lane at a time).
struct LaneLights {
  alignas(64) float light_ok[kPacket];  // 1: the light gives a sample (a one-sided light seen from its front)
  alignas(64) float ux[kPacket], uy[kPacket];  // the parallelogram's 2D point
  alignas(64) float la_x[kPacket], la_y[kPacket], la_z[kPacket], lb_x[kPacket], lb_y[kPacket], lb_z[kPacket];
  alignas(64) float lc_x[kPacket], lc_y[kPacket], lc_z[kPacket];  // its corners a, b, c
  alignas(64) float ln_x[kPacket], ln_y[kPacket], ln_z[kPacket];  // its normal
  alignas(64) float l_area[kPacket], l_pmf[kPacket];              // its area, its choice probability
  alignas(64) float le_r[kPacket], le_g[kPacket], le_b[kPacket];  // the emission (either kind of light)
  alignas(64) float two_sided[kPacket];                           // 1: it emits from both faces
  // Any other light: 1 where the lane has its sample; the sample's direction, point, density (with the choice
  // probability), and whether it is at infinity or punctual (0 or 1).
  alignas(64) float general[kPacket], g_wx[kPacket], g_wy[kPacket], g_wz[kPacket];
  alignas(64) float g_px[kPacket], g_py[kPacket], g_pz[kPacket], g_pdf[kPacket], g_inf[kPacket], g_delta[kPacket];
  alignas(64) uint32_t prim[kPacket];  // the light's primitive (the shadow ray skips it)

  void clear() {
    fill_lanes(0.f, light_ok, la_x, la_y, la_z, lb_x, lb_y, lb_z, lc_x, lc_y, lc_z, ln_x, ln_y);
    fill_lanes(0.f, le_r, le_g, le_b, two_sided, general, g_inf, g_delta, g_wx, g_wy, g_px, g_py, g_pz);
    fill_lanes(0.5f, ux, uy);
    fill_lanes(1.f, ln_z, l_area, l_pmf, g_wz, g_pdf);
    for (uint32_t& p : prim) p = kNoPrimitive;
  }
};

// The vertex's other random numbers: the BSDF sample's 2D point and lobe choice, and the roulette's.
struct LaneNumbers {
  alignas(64) float bux[kPacket], buy[kPacket], u_lobe[kPacket], u_rr[kPacket];

  void clear() { fill_lanes(0.5f, bux, buy, u_lobe, u_rr); }
};

// The light sample's shadow ray and what it adds if unblocked.
struct LaneShadows {
  alignas(64) float traced[kPacket];     // 1: sample_direct counts a ray (it has a sample worth testing)
  alignas(64) float ok[kPacket];         // 1: the shadow ray is cast
  alignas(64) float ox[kPacket], oy[kPacket], oz[kPacket], dx[kPacket], dy[kPacket], dz[kPacket], t_max[kPacket];
  alignas(64) float c_r[kPacket], c_g[kPacket], c_b[kPacket];  // its contribution

  void none() { fill_lanes(0.f, traced, ok); }  // a packet of Dirac lobes alone: no light sample
};

// The BSDF sample of each lane, as bsdf_sample<Any> returns it (in the shading frame mirrored to the front), before
// the path takes it.
struct LaneSamples {
  alignas(64) float ok[kPacket];                           // 1: there is a sample
  alignas(64) float wx[kPacket], wy[kPacket], wz[kPacket];  // its direction
  alignas(64) float f_r[kPacket], f_g[kPacket], f_b[kPacket], pdf[kPacket];
  // Written where some lane has a Dirac lobe (lane_dirac_samples), rough glass or a smooth layer (lane_bsdf_samples):
  // whether the sample is a Dirac lobe's, whether it refracted (0 or 1), the refraction's η (1 elsewhere), and the
  // path's η scale after it (times η²).
  alignas(64) float specular[kPacket], transmits[kPacket], eta_t[kPacket], eta[kPacket];

  // In a packet of Dirac lobes alone, before lane_dirac_samples (which writes every lane of one).
  void none() { fill_lanes(0.f, ok, wx, wy, wz, f_r, f_g, f_b, pdf, specular); }
};

// The BSDF sample's continuation: the next ray and the path's new throughput.
struct LaneContinuations {
  alignas(64) float goes_on[kPacket];  // 1: the path continues (it survived the roulette)
  alignas(64) float beta_r[kPacket], beta_g[kPacket], beta_b[kPacket];
  alignas(64) float ox[kPacket], oy[kPacket], oz[kPacket], dx[kPacket], dy[kPacket], dz[kPacket];
};

// The whole packet.
struct LanePacket {
  alignas(64) uint8_t active[kPacket];  // 1: the lanes shade this path (a 0 lane takes shade_vertex)
  LaneRays ray;
  LanePolygons polygon;
  LaneMaterials material;
  LaneHits hit;
  LaneFrames frame;
  LaneLights light;
  LaneNumbers u;
  LaneShadows shadow;
  LaneSamples sample;
  LaneContinuations next;
};

}  // namespace integrator_detail
}  // namespace pt
