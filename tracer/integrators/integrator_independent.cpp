// The path-tracing kernels for the IndependentSampler (see path_tracer.h), scalar and wavefront.
#include "integrators/wavefront_loop.h"

namespace pt {

template RadianceKernel<IndependentSampler> select_kernel(const Scene&, bool);
template BatchKernel<IndependentSampler> select_batch_kernel(const Scene&, const RenderSettings&);
template Rgb estimate_radiance(const Scene&, const RenderSettings&, const Ray&, IndependentSampler&, RayCount&);

}  // namespace pt
