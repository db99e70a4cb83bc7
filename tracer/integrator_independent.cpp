// The path-tracing kernels for the IndependentSampler (see integrator_kernels.h).
#include "integrator_kernels.h"

namespace pt {

template RadianceKernel<IndependentSampler> select_kernel(const Scene&, Estimator, bool);
template Rgb estimate_radiance(const Scene&, Estimator, const Ray&, IndependentSampler&, RayCount&);

}  // namespace pt
