#include "integrators/wavefront.h"

namespace pt {

bool wavefront_pays(const Scene& scene) {
  return (scene.kernel_features() & kFeaturePolygons) != 0 && scene.polygon_bvh.empty();
}

}  // namespace pt
