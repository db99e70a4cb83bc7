// The path-tracing kernels for the SobolSampler (see path_tracer.h), scalar and wavefront.
#include "integrators/wavefront_loop.h"

namespace pt {

template RadianceKernel<SobolSampler> select_kernel(const Scene&, bool);
template BatchKernel<SobolSampler> select_batch_kernel(const Scene&, const RenderSettings&);
template Rgb estimate_radiance(const Scene&, const RenderSettings&, const Ray&, SobolSampler&, RayCount&);

}  // namespace pt
