// Dispatch from the material type to its lobe (materials/*.h). This is the only place that names a material
// type: the integrator sees flags only (bsdf.h).
//
// Reflection-only materials are two-sided: when wo is below the surface (wo.z < 0), both directions are mirrored
// in z before calling the lobe (which assumes wo.z ≥ 0) and the sampled direction is mirrored back. Dielectrics
// distinguish the two sides themselves (dielectric.h).
#include "materials/bsdf.h"

#include "materials/conductor.h"
#include "materials/dielectric.h"
#include "materials/diffuse.h"
#include "materials/plastic.h"
#include "materials/subsurface.h"

namespace pt {

namespace {

Vec3 front(Vec3 w, bool flip) { return flip ? Vec3(w.x, w.y, -w.z) : w; }

}  // namespace

uint32_t bsdf_flags(const Material& m) {
  const bool smooth = effectively_smooth(m.alpha);
  switch (m.type) {
    case MaterialType::Diffuse:
      return kBsdfReflection | kBsdfDiffuse;
    case MaterialType::Mirror:
      return kBsdfReflection | kBsdfSpecular;
    case MaterialType::Conductor:
      return kBsdfReflection | (smooth ? kBsdfSpecular : kBsdfGlossy);
    case MaterialType::Dielectric:
      return kBsdfReflection | kBsdfTransmission | (smooth ? kBsdfSpecular : kBsdfGlossy);
    case MaterialType::Plastic:
      return kBsdfReflection | kBsdfDiffuse | (smooth ? kBsdfSpecular : kBsdfGlossy);
    case MaterialType::Subsurface:
      return kBsdfReflection | kBsdfDiffuse;
  }
  return kBsdfNone;
}

Rgb bsdf_eval(const Material& m, Vec3 wo, Vec3 wi) {
  if (m.type == MaterialType::Dielectric) return dielectric_eval(m, wo, wi);
  const bool flip = wo.z < 0.f;
  wo = front(wo, flip);
  wi = front(wi, flip);
  switch (m.type) {
    case MaterialType::Diffuse:
      return diffuse_eval(m, wo, wi);
    case MaterialType::Mirror:
      return Rgb(0.f);
    case MaterialType::Conductor:
      return conductor_eval(m, wo, wi);
    case MaterialType::Plastic:
      return plastic_eval(m, wo, wi);
    case MaterialType::Subsurface:
      return subsurface_eval(m, wo, wi);
    case MaterialType::Dielectric:
      break;
  }
  return Rgb(0.f);
}

float bsdf_pdf(const Material& m, Vec3 wo, Vec3 wi) {
  if (m.type == MaterialType::Dielectric) return dielectric_pdf(m, wo, wi);
  const bool flip = wo.z < 0.f;
  wo = front(wo, flip);
  wi = front(wi, flip);
  switch (m.type) {
    case MaterialType::Diffuse:
      return diffuse_pdf(wo, wi);
    case MaterialType::Mirror:
      return 0.f;
    case MaterialType::Conductor:
      return conductor_pdf(m, wo, wi);
    case MaterialType::Plastic:
      return plastic_pdf(m, wo, wi);
    case MaterialType::Subsurface:
      return subsurface_pdf(wo, wi);
    case MaterialType::Dielectric:
      break;
  }
  return 0.f;
}

bool bsdf_sample(const Material& m, Vec3 wo, float uc, Vec2 u, BsdfSample& out) {
  if (m.type == MaterialType::Dielectric) return dielectric_sample(m, wo, uc, u, out);
  const bool flip = wo.z < 0.f;
  wo = front(wo, flip);
  bool ok = false;
  switch (m.type) {
    case MaterialType::Diffuse:
      ok = diffuse_sample(m, wo, u, out);
      break;
    case MaterialType::Mirror:
      ok = mirror_sample(m, wo, out);
      break;
    case MaterialType::Conductor:
      ok = conductor_sample(m, wo, uc, u, out);
      break;
    case MaterialType::Plastic:
      ok = plastic_sample(m, wo, uc, u, out);
      break;
    case MaterialType::Subsurface:
      ok = subsurface_sample(m, wo, u, out);
      break;
    case MaterialType::Dielectric:
      break;
  }
  if (ok) out.wi = front(out.wi, flip);
  return ok;
}

}  // namespace pt
