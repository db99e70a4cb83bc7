// Instantiates the bidirectional estimator (bdpt_kernels.h) for both samplers.
#include "integrators/bdpt_kernels.h"

namespace pt {

template BdptKernel<IndependentSampler> select_bdpt_kernel<IndependentSampler>(const Scene&, const RenderSettings&);
template BdptKernel<SobolSampler> select_bdpt_kernel<SobolSampler>(const Scene&, const RenderSettings&);

}  // namespace pt
