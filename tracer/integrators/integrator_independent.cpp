// The path-tracing kernels for the IndependentSampler (see integrator_kernels.h).
#include "integrators/integrator_kernels.h"

namespace pt {

template RadianceKernel<IndependentSampler> select_kernel(const Scene&, bool);
template Rgb estimate_radiance(const Scene&, const RenderSettings&, const Ray&, IndependentSampler&, RayCount&);

}  // namespace pt
