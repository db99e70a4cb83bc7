#include "scene/scene_identity.h"

#include <bit>

#include "core/fnv1a.h"
#include "io/little_endian.h"
#include "scene/scene.h"
#include "scene/scene_json.h"

namespace pt {

namespace {

// An array of floats or 32-bit integers by its bytes, which are its little-endian encoding on the machines the
// tracer runs on (the assertion says so), as put_le_* would write them.
template <class T>
uint64_t hash_array(const std::vector<T>& v, uint64_t h) {
  static_assert(std::endian::native == std::endian::little, "the scene hash reads arrays as little-endian bytes");
  return fnv1a(reinterpret_cast<const unsigned char*>(v.data()), v.size() * sizeof(T), h);
}

}  // namespace

uint64_t scene_content_hash(const SceneDesc& scene) {
  // Everything but the shapes goes through the scene writer, with the seed set to 0 (it is kept apart: renders
  // with other seeds may still be merged). The shapes, which meshes make numerous, go in by their bits: writing
  // a million triangles' doubles as JSON took 10 s of every render (docs/performance.md, session 20).
  SceneDesc head{scene.camera, scene.width, scene.height, scene.render, scene.environment, scene.materials, {}, {}, {}, {}, {}, {}};
  head.render.seed = 0;
  const std::string json = scene_to_json(head);
  uint64_t h = fnv1a(reinterpret_cast<const unsigned char*>(json.data()), json.size());
  std::string record;
  for (const ShapeDesc& shape : scene.shapes) {
    record.clear();
    put_le_u32(record, static_cast<uint32_t>(shape.type));
    put_le_u32(record, static_cast<uint32_t>(shape.material));
    // The fields the shape's type uses, as the writer does (parse_scene(scene_to_json(s)) keeps the hash).
    if (shape.type == ShapeType::Sphere) {
      for (int a = 0; a < 3; ++a) put_le_f64(record, shape.center[a]);
      put_le_f64(record, shape.radius);
    } else {
      for (int k = 0; k < (shape.type == ShapeType::Quad ? 4 : 3); ++k)
        for (int a = 0; a < 3; ++a) put_le_f64(record, shape.vertices[k][a]);
      if (shape.shading != kNoShading && scene.shading && shape.shading < scene.shading->size()) {
        const TriangleShading& t = (*scene.shading)[shape.shading];  // the vertex normals and uv shade it
        for (int k = 0; k < 3; ++k) {
          for (int a = 0; a < 3; ++a) put_le_u32(record, std::bit_cast<uint32_t>(t.normal[k][a]));
          for (int a = 0; a < 2; ++a) put_le_u32(record, std::bit_cast<uint32_t>(t.uv[k][a]));
        }
      }
    }
    h = fnv1a(reinterpret_cast<const unsigned char*>(record.data()), record.size(), h);
  }
  // Instanced meshes by their bits, and each placement (its object's transform included) with its materials.
  for (const std::shared_ptr<const MeshDesc>& m : scene.meshes) {
    record.clear();
    put_le_u32(record, m->slots);
    for (size_t n : {m->position.size(), m->normal.size(), m->uv.size(), m->tangent.size(), m->index.size()})
      put_le_u64(record, n);
    h = fnv1a(reinterpret_cast<const unsigned char*>(record.data()), record.size(), h);
    h = hash_array(m->position, h);
    h = hash_array(m->normal, h);
    h = hash_array(m->uv, h);
    h = hash_array(m->tangent, h);
    h = hash_array(m->index, h);
    h = hash_array(m->slot, h);
  }
  for (const InstanceDesc& in : scene.instances) {
    record.clear();
    put_le_u32(record, in.mesh);
    for (int m : in.materials) put_le_u32(record, static_cast<uint32_t>(m));
    const glm::dmat4 world = instance_world(scene, in);
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 3; ++r) put_le_f64(record, world[c][r]);
    h = fnv1a(reinterpret_cast<const unsigned char*>(record.data()), record.size(), h);
  }
  // The model files' punctual lights (not in the scene file: their files bring them).
  for (const PunctualLightDesc& l : scene.punctual_lights) {
    record.clear();
    put_le_u32(record, static_cast<uint32_t>(l.kind));
    put_le_u32(record, static_cast<uint32_t>(l.object));
    for (int a = 0; a < 3; ++a) put_le_f64(record, l.position[a]), put_le_f64(record, l.direction[a]);
    for (int a = 0; a < 3; ++a) put_le_u32(record, std::bit_cast<uint32_t>(l.intensity[a]));
    put_le_f64(record, l.inner_cone);
    put_le_f64(record, l.outer_cone);
    h = fnv1a(reinterpret_cast<const unsigned char*>(record.data()), record.size(), h);
  }
  return h;
}

FilmStateInfo state_info_for(const SceneDesc& scene, const std::string& scene_name, bool hash) {
  FilmStateInfo info;
  info.scene_hash = hash ? scene_content_hash(scene) : 0;
  info.seed = scene.render.seed;
  info.estimator = static_cast<uint32_t>(scene.render.estimator);
  info.sampler = static_cast<uint32_t>(scene.render.sampler);
  info.max_bounces = scene.render.max_bounces;
  info.rr_depth = scene.render.russian_roulette_depth;
  info.scene_name = scene_name;
  return info;
}


std::string resume_problem(const FilmStateInfo& info, const SceneDesc& scene) {
  if (info.mixed_seeds) return "it was merged from renders with different seeds: it can be merged, not resumed";
  if (info.seed != scene.render.seed)
    return "it was rendered with seed " + std::to_string(info.seed) + ", not " + std::to_string(scene.render.seed) +
           " (give --seed " + std::to_string(info.seed) + ")";
  if (info.scene_hash != scene_content_hash(scene)) {
    std::string why = "it was rendered from another scene or other settings";
    if (info.max_bounces != scene.render.max_bounces)
      why += " (max bounces " + std::to_string(info.max_bounces) + ", not " + std::to_string(scene.render.max_bounces) + ")";
    else if (info.estimator != static_cast<uint32_t>(scene.render.estimator) ||
             info.sampler != static_cast<uint32_t>(scene.render.sampler))
      why += " (estimator or sampler)";
    return why + "; the scene, its film size and its render settings must be the same";
  }
  return "";
}

}  // namespace pt
