// The feature buffers (features.h) of one camera ray through the centre of every pixel, without the path behind
// the first non-specular vertex: a guide image for the viewer's preview, whose radiance is rendered at a fraction
// of the resolution and upsampled with these (denoise/preview.h). Smooth mirrors and glass are followed as a
// path would follow them (along the likelier lobe), up to the render settings' bounce limit.
//
// Cost: about one ray per pixel (more behind glass and mirrors), no light samples, no shading beyond the albedo.
#pragma once
#include <vector>

#include "core/thread_pool.h"
#include "film/pixel_features.h"
#include "scene/scene.h"

namespace pt {

// Fills `out` at the scene's resolution (reusing its planes' capacity). Rows run on `pool`.
void trace_feature_image(const Scene& scene, const RenderSettings& settings, ThreadPool& pool, FeatureImage& out);

}  // namespace pt
