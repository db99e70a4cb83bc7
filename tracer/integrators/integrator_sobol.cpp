// The path-tracing kernels for the SobolSampler (see integrator_kernels.h).
#include "integrators/integrator_kernels.h"

namespace pt {

template RadianceKernel<SobolSampler> select_kernel(const Scene&, bool);
template Rgb estimate_radiance(const Scene&, const RenderSettings&, const Ray&, SobolSampler&, RayCount&);

}  // namespace pt
