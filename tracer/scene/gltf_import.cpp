#include "scene/gltf_import.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <set>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "io/image_io.h"
#include "io/safe_file.h"
#include "io/texture_io.h"
#include "scene/mesh_obj.h"
#include "scene/scene.h"
#include "scene/scene_json.h"
#include "scene/studio.h"

// The parser's implementation lives in this translation unit alone. Images (embedded, data URIs or files beside
// the model, all read through read_file_limited: the scene's safety rules) are kept encoded by keep_encoded
// below and decoded where a material uses them.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>

namespace pt {

namespace {

namespace tg = tinygltf;

// Mesh g's triangles placed by `world` among out.triangles (place_triangle, geometry/triangle_mesh.h); those it
// makes degenerate are left out (counted).
void place_mesh_triangles(const GltfMesh& g, const glm::dmat4& world, GltfContents& out) {
  const MeshDesc& me = g.mesh;
  const MeshPlacement place(world);
  for (size_t t = 0; t < me.size(); ++t) {
    const PlacedTriangle p = place_triangle(me, t, place);
    const std::array<DVec3, 3>& tri = p.v;
    TriangleShading shading;
    shading.normal = p.normal;
    shading.uv = p.uv;
    shading.has_uv = !me.uv.empty();
    if (degenerate_triangle(tri[0], tri[1], tri[2])) {
      ++out.degenerate;
      continue;
    }
    out.triangles.push_back(tri);
    out.triangle_material.push_back(g.slot_material[me.slot[t]]);
    if (!out.shading.empty() || shading.any()) {
      out.shading.resize(out.triangles.size() - 1);  // the triangles before the first with either have none
      out.shading.push_back(shading);
    }
  }
}

// The extensions this reader understands; others in extensionsRequired are refused.
const std::set<std::string> kReadExtensions = {"KHR_materials_emissive_strength", "KHR_materials_ior",
                                               "KHR_materials_transmission", "KHR_lights_punctual",
                                               "KHR_texture_transform"};

struct Reader {
  Reader(const std::string& file, const tg::Model& model) : path(file), m(model) {}
  const std::string& path;
  const tg::Model& m;
  GltfContents out;
  std::set<std::string> warned;

  [[noreturn]] void fail(const std::string& where, const std::string& why) const {
    throw SceneError(path + ": " + where + ": " + why);
  }
  void warn(const std::string& line) {
    if (warned.insert(line).second) out.warnings.push_back(line);
  }

  // The bytes of accessor `index` as `count` elements of `element_bytes`, `stride` apart; checked against its
  // buffer view and buffer.
  struct View {
    const unsigned char* data;
    size_t count, stride;
  };
  View accessor_view(int index, const std::string& where, size_t element_bytes) const {
    if (index < 0 || static_cast<size_t>(index) >= m.accessors.size())
      fail(where, "accessor " + std::to_string(index) + " does not exist (the file has " +
                      std::to_string(m.accessors.size()) + ")");
    const tg::Accessor& a = m.accessors[index];
    const std::string at = where + " (accessors[" + std::to_string(index) + "])";
    if (a.sparse.isSparse) fail(at, "sparse accessors are not supported");
    if (a.bufferView < 0 || static_cast<size_t>(a.bufferView) >= m.bufferViews.size())
      fail(at, "bufferView " + std::to_string(a.bufferView) + " does not exist");
    const tg::BufferView& v = m.bufferViews[a.bufferView];
    const std::string vat = "bufferViews[" + std::to_string(a.bufferView) + "]";
    if (v.buffer < 0 || static_cast<size_t>(v.buffer) >= m.buffers.size())
      fail(vat, "buffer " + std::to_string(v.buffer) + " does not exist");
    const size_t buffer_size = m.buffers[v.buffer].data.size();
    if (v.byteOffset > buffer_size || v.byteLength > buffer_size - v.byteOffset)
      fail(vat, "bytes " + std::to_string(v.byteOffset) + " + " + std::to_string(v.byteLength) +
                    " run past the end of buffers[" + std::to_string(v.buffer) + "] (" + std::to_string(buffer_size) +
                    " bytes)");
    const size_t stride = v.byteStride ? v.byteStride : element_bytes;
    if (stride < element_bytes) fail(vat, "byteStride " + std::to_string(stride) + " is shorter than an element");
    if (a.count > 0) {
      const size_t span = a.byteOffset + (a.count - 1) * stride + element_bytes;  // no overflow: count < 2^32 checked
      if (a.count > (size_t{1} << 32) || a.byteOffset > v.byteLength || span > v.byteLength || span < a.byteOffset)
        fail(at, std::to_string(a.count) + " elements from byte " + std::to_string(a.byteOffset) +
                     " run past the end of its buffer view (" + std::to_string(v.byteLength) + " bytes)");
    }
    return {m.buffers[v.buffer].data.data() + v.byteOffset + a.byteOffset, a.count, stride};
  }

  // Appends accessor `index`'s positions (float VEC3, finite) to `out`.
  void append_positions(int index, const std::string& where, std::vector<Vec3>& out) const {
    const tg::Accessor* a = index >= 0 && static_cast<size_t>(index) < m.accessors.size() ? &m.accessors[index] : nullptr;
    if (a && (a->type != TINYGLTF_TYPE_VEC3 || a->componentType != TINYGLTF_COMPONENT_TYPE_FLOAT))
      fail(where, "positions must be float VEC3 (KHR_mesh_quantization is not supported)");
    const View v = accessor_view(index, where, 12);
    const size_t first = out.size();
    out.resize(first + v.count);
    for (size_t i = 0; i < v.count; ++i) {
      Vec3& p = out[first + i];
      std::memcpy(&p[0], v.data + i * v.stride, 12);
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        fail(where, "position " + std::to_string(i) + " is not finite");
    }
  }

  // A per-vertex attribute of N components (NORMAL: float VEC3; TANGENT: float VEC4; TEXCOORD_0: VEC2 of floats,
  // or of normalized unsigned bytes or shorts), one element per vertex.
  template <int N>
  std::vector<glm::vec<N, float>> attribute(int index, const std::string& where, size_t vertex_count) const {
    const tg::Accessor* a = index >= 0 && static_cast<size_t>(index) < m.accessors.size() ? &m.accessors[index] : nullptr;
    size_t bytes = 4;
    if (a) {
      const int type = N == 4 ? TINYGLTF_TYPE_VEC4 : N == 3 ? TINYGLTF_TYPE_VEC3 : TINYGLTF_TYPE_VEC2;
      const bool normalized_int = N == 2 && a->normalized && (a->componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                                              a->componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT);
      if (a->type != type || (a->componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && !normalized_int))
        fail(where, N == 4   ? "must be float VEC4"
                    : N == 3 ? "must be float VEC3"
                             : "must be VEC2 of floats or of normalized unsigned bytes or shorts");
      if (a->componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) bytes = 1;
      if (a->componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) bytes = 2;
    }
    const View v = accessor_view(index, where, N * bytes);
    if (v.count != vertex_count)
      fail(where, std::to_string(v.count) + " elements for " + std::to_string(vertex_count) + " positions");
    std::vector<glm::vec<N, float>> out(v.count);
    for (size_t i = 0; i < v.count; ++i) {
      const unsigned char* p = v.data + i * v.stride;
      for (int c = 0; c < N; ++c) {
        float x;
        if (bytes == 4) std::memcpy(&x, p + 4 * c, 4);
        else if (bytes == 1) x = p[c] / 255.f;
        else { uint16_t u; std::memcpy(&u, p + 2 * c, 2); x = u / 65535.f; }
        if (!std::isfinite(x)) fail(where, "element " + std::to_string(i) + " is not finite");
        out[i][c] = x;
      }
    }
    return out;
  }

  std::vector<uint32_t> indices(int index, const std::string& where, size_t vertex_count) const {
    const tg::Accessor* a = index >= 0 && static_cast<size_t>(index) < m.accessors.size() ? &m.accessors[index] : nullptr;
    size_t bytes = 4;
    if (a) {
      if (a->type != TINYGLTF_TYPE_SCALAR) fail(where, "indices must be SCALAR");
      switch (a->componentType) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: bytes = 1; break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: bytes = 2; break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: bytes = 4; break;
        default: fail(where, "indices must be unsigned bytes, shorts or ints");
      }
    }
    const View v = accessor_view(index, where, bytes);
    std::vector<uint32_t> out(v.count);
    for (size_t i = 0; i < v.count; ++i) {
      const unsigned char* p = v.data + i * v.stride;
      uint32_t x = 0;
      if (bytes == 1) x = p[0];
      else if (bytes == 2) { uint16_t s; std::memcpy(&s, p, 2); x = s; }
      else std::memcpy(&x, p, 4);
      if (x >= vertex_count)
        fail(where, "index " + std::to_string(i) + " is " + std::to_string(x) + ", past the " +
                        std::to_string(vertex_count) + " vertices");
      out[i] = x;
    }
    return out;
  }

  static double number(const tg::Value& ext, const char* key, double fallback) {
    if (!ext.IsObject() || !ext.Has(key) || !ext.Get(key).IsNumber()) return fallback;
    return ext.Get(key).GetNumberAsDouble();
  }
  static const tg::Value* extension(const tg::ExtensionMap& e, const char* name) {
    const auto it = e.find(name);
    return it == e.end() ? nullptr : &it->second;
  }

  MaterialDesc material(size_t index) {
    const tg::Material& g = m.materials[index];
    const std::string where = "materials[" + std::to_string(index) + "]";
    const auto& pbr = g.pbrMetallicRoughness;
    Rgb base(1.f);
    if (pbr.baseColorFactor.size() >= 3) base = Rgb(pbr.baseColorFactor[0], pbr.baseColorFactor[1], pbr.baseColorFactor[2]);
    const double metallic = pbr.metallicFactor, roughness = pbr.roughnessFactor;
    if (!std::isfinite(base.x) || !std::isfinite(base.y) || !std::isfinite(base.z) || !std::isfinite(metallic) ||
        !std::isfinite(roughness))
      fail(where, "a factor is not finite");
    MaterialDesc d;
    d.name = g.name.empty() ? "material " + std::to_string(index) : g.name;
    d.albedo = glm::clamp(base, Rgb(0.f), Rgb(1.f));
    d.roughness = static_cast<float>(std::clamp(roughness, 0.0, 1.0));
    const tg::Value* transmission = extension(g.extensions, "KHR_materials_transmission");
    if (const tg::Value* ior = extension(g.extensions, "KHR_materials_ior")) {
      const double eta = number(*ior, "ior", 1.5);
      // The extension allows 0 for "infinite" (a perfect reflector's F0 = 1) and any index ≥ 1; the materials
      // here take [1, 4] (validate_material).
      if (eta >= 1.0 && eta <= 4.0) d.ior = static_cast<float>(eta);
      else warn(where + ".extensions.KHR_materials_ior.ior: " + std::to_string(eta) + " is outside [1, 4]: 1.5 is used");
    }
    if (transmission && number(*transmission, "transmissionFactor", 0.0) > 0.0) {
      d.type = MaterialType::Dielectric;  // clear (or frosted, by roughness) glass of the extension's index
      if (number(*transmission, "transmissionFactor", 0.0) < 1.0)
        warn("transmission factors between 0 and 1 are read as 1 (the project's dielectric transmits fully)");
    } else {
      d.type = MaterialType::MetallicRoughness;  // the specification's BRDF (materials/metallic_roughness.h)
      d.metallic = static_cast<float>(std::clamp(metallic, 0.0, 1.0));
    }
    Rgb emissive(0.f);
    if (g.emissiveFactor.size() >= 3) emissive = Rgb(g.emissiveFactor[0], g.emissiveFactor[1], g.emissiveFactor[2]);
    const tg::Value* strength = extension(g.extensions, "KHR_materials_emissive_strength");
    emissive *= static_cast<float>(strength ? number(*strength, "emissiveStrength", 1.0) : 1.0);
    if (!std::isfinite(emissive.x) || !std::isfinite(emissive.y) || !std::isfinite(emissive.z)) fail(where, "emission is not finite");
    d.emission = glm::max(emissive, Rgb(0.f));
    d.two_sided = g.doubleSided;
    if (pbr.baseColorTexture.index >= 0 && takes(d.type, MaterialParam::Albedo)) {
      // The base colour is the factor times the texture (the specification's rule): albedo holds the factor.
      const ModelTexture t = model_texture(pbr.baseColorTexture, where + ".pbrMetallicRoughness.baseColorTexture", Texels::Colour);
      d.albedo_map = t.texture;
      d.albedo_uv_transform = t.uv_transform;
    }
    if (pbr.metallicRoughnessTexture.index >= 0 && d.type == MaterialType::MetallicRoughness)
      d.metallic_roughness_map =
          model_texture(pbr.metallicRoughnessTexture, where + ".pbrMetallicRoughness.metallicRoughnessTexture",
                        Texels::Data);
    if (g.normalTexture.index >= 0) {
      d.normal_map = model_texture(g.normalTexture, where + ".normalTexture", Texels::Data);
      d.normal_scale = static_cast<float>(g.normalTexture.scale);
      if (!std::isfinite(d.normal_scale)) fail(where + ".normalTexture.scale", "is not finite");
    }
    if (g.emissiveTexture.index >= 0 && !is_black(d.emission))  // the emission is the factor times the image
      d.emission_map = model_texture(g.emissiveTexture, where + ".emissiveTexture", Texels::Colour);
    if (g.occlusionTexture.index >= 0) warn("occlusion textures are not read (a path tracer finds occlusion itself)");
    if (g.alphaMode == "MASK" || g.alphaMode == "BLEND") {
      // Cut-outs: opaque where baseColorFactor's alpha × the base colour texture's alpha ≥ alphaCutoff.
      auto mask = std::make_shared<AlphaMask>();
      mask->factor = pbr.baseColorFactor.size() >= 4 ? static_cast<float>(pbr.baseColorFactor[3]) : 1.f;
      mask->cutoff = static_cast<float>(g.alphaCutoff);
      if (!std::isfinite(mask->factor) || !std::isfinite(mask->cutoff)) fail(where, "alpha factor or cutoff is not finite");
      if (pbr.baseColorTexture.index >= 0) {
        const ModelTexture t =
            model_texture(pbr.baseColorTexture, where + ".pbrMetallicRoughness.baseColorTexture", Texels::Alpha);
        mask->alpha = t.texture;
        mask->uv_transform = t.uv_transform;
      }
      // BLEND: partial transparency, the surface there with probability alpha (stochastic transparency).
      mask->blend = g.alphaMode == "BLEND";
      d.cutout = std::move(mask);
    }
    return d;
  }

  // How an image's texels are read: colour (sRGB-decoded), data (as stored), or its alpha channel.
  enum class Texels { Colour, Data, Alpha };

  // A material's texture reference (baseColorTexture and the others: index, texCoord, extensions) as the image
  // and its KHR_texture_transform.
  template <class Info>
  ModelTexture model_texture(const Info& info, const std::string& where, Texels kind) {
    ModelTexture t;
    t.texture = texture(info.index, where, kind);
    if (info.texCoord != 0) warn("only TEXCOORD_0 is read: textures naming another set use TEXCOORD_0");
    if (const tg::Value* tt = extension(info.extensions, "KHR_texture_transform"))
      t.uv_transform = texture_transform(*tt, where + ".extensions.KHR_texture_transform");
    return t;
  }

  // textures[index] as a pyramid (materials/texture.h), shared by every material that names it: its image's
  // decoded texels (sRGB-decoded for colour, as stored for data, or the alpha channel in every channel) and its
  // sampler's wrap modes.
  std::map<std::pair<int, Texels>, std::shared_ptr<const Texture>> textures;
  std::shared_ptr<const Texture> texture(int index, const std::string& where, Texels kind) {
    if (const auto it = textures.find({index, kind}); it != textures.end()) return it->second;
    if (index < 0 || static_cast<size_t>(index) >= m.textures.size())
      fail(where + ".index", "texture " + std::to_string(index) + " does not exist");
    const tg::Texture& t = m.textures[index];
    const std::string tat = "textures[" + std::to_string(index) + "]";
    if (t.source < 0 || static_cast<size_t>(t.source) >= m.images.size())
      fail(tat + ".source", "image " + std::to_string(t.source) + " does not exist");
    const tg::Image& img = m.images[t.source];
    const std::string iat = "images[" + std::to_string(t.source) + "]";
    if (img.image.empty()) fail(iat, (img.uri.empty() ? std::string("its data") : "'" + img.uri + "'") + " could not be read");
    TextureWrap wrap_u = TextureWrap::Repeat, wrap_v = TextureWrap::Repeat;
    if (t.sampler >= 0) {
      if (static_cast<size_t>(t.sampler) >= m.samplers.size())
        fail(tat + ".sampler", "sampler " + std::to_string(t.sampler) + " does not exist");
      const auto mode = [](int w) {
        return w == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE     ? TextureWrap::Clamp
               : w == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT ? TextureWrap::Mirror
                                                             : TextureWrap::Repeat;
      };
      wrap_u = mode(m.samplers[t.sampler].wrapS);
      wrap_v = mode(m.samplers[t.sampler].wrapT);
    }
    Image linear;
    try {
      const std::string bytes(img.image.begin(), img.image.end());
      if (kind == Texels::Alpha) {
        linear = alpha_as_image(decode_alpha(bytes, iat));
      } else {
        linear = decode_image(bytes, kind == Texels::Colour, iat);
      }
    } catch (const ImageError& e) {
      throw SceneError(path + ": " + e.what());
    }
    const std::string name = std::filesystem::path(path).filename().string() + " " + iat +
                             (img.uri.empty() || img.uri.rfind("data:", 0) == 0 ? "" : " (" + img.uri + ")");
    auto tex = make_texture(linear, wrap_u, wrap_v, name + (kind == Texels::Alpha ? " alpha" : ""));
    textures[{index, kind}] = tex;
    return tex;
  }

  // KHR_texture_transform: uv' = T·R·S·(u, v, 1) (offset, rotation in radians, scale); texCoord overrides are
  // warned about (TEXCOORD_0 only). The rotation turns (u, v) by u' = u cos r + v sin r, v' = −u sin r + v cos r:
  // the direction Khronos' TextureTransformTest sample model checks (its green marker; three.js and Blender's
  // importer turn this way), the transpose of the matrix the extension's README prints in its GLSL sketch,
  // which that model marks red.
  glm::mat3 texture_transform(const tg::Value& ext, const std::string& where) {
    const auto pair = [&](const char* key, double fallback) {
      glm::dvec2 v(fallback);
      if (ext.Has(key)) {
        const tg::Value& a = ext.Get(key);
        if (!a.IsArray() || a.ArrayLen() != 2 || !a.Get(0).IsNumber() || !a.Get(1).IsNumber())
          fail(where + "." + key, "must be two numbers");
        v = glm::dvec2(a.Get(0).GetNumberAsDouble(), a.Get(1).GetNumberAsDouble());
      }
      return v;
    };
    const glm::dvec2 offset = pair("offset", 0.0), scale = pair("scale", 1.0);
    const double r = number(ext, "rotation", 0.0);
    if (!std::isfinite(offset.x + offset.y + scale.x + scale.y + r)) fail(where, "a value is not finite");
    if (ext.Has("texCoord")) warn("KHR_texture_transform's texCoord is passed over: TEXCOORD_0 is used");
    const glm::dmat3 t(1, 0, 0, 0, 1, 0, offset.x, offset.y, 1);  // column-major, as the specification's GLSL
    const glm::dmat3 rot(std::cos(r), -std::sin(r), 0, std::sin(r), std::cos(r), 0, 0, 0, 1);  // columns
    const glm::dmat3 s(scale.x, 0, 0, 0, scale.y, 0, 0, 0, 1);
    return glm::mat3(t * rot * s);
  }

  static glm::dmat4 local_transform(const tg::Node& n) {
    if (n.matrix.size() == 16) {
      glm::dmat4 mat;
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) mat[c][r] = n.matrix[4 * c + r];  // column-major, as glTF stores it
      return mat;
    }
    glm::dmat4 t(1.0), r(1.0), s(1.0);
    if (n.translation.size() == 3) t = glm::translate(glm::dmat4(1.0), DVec3(n.translation[0], n.translation[1], n.translation[2]));
    if (n.rotation.size() == 4) {
      const glm::dquat q(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]);  // glTF: x, y, z, w
      r = glm::mat4_cast(glm::normalize(q));
    }
    if (n.scale.size() == 3) s = glm::scale(glm::dmat4(1.0), DVec3(n.scale[0], n.scale[1], n.scale[2]));
    return t * r * s;
  }

  // Every mesh is read once into an indexed mesh in its own coordinates (GltfMesh). A mesh whose materials do
  // not emit is placed by instances, one per node showing it; an emitting one's triangles are placed in the
  // file's world as shapes, which light sampling knows (instanced triangles are not lights).
  std::vector<int> read_mesh;  // per file mesh, its index in out.meshes, −1 while not read
  size_t stored_triangles = 0;  // triangles held: the meshes' own and the placed ones
  size_t stored_vertices = 0;   // the meshes' vertices

  bool mesh_emits(const tg::Mesh& me) const {
    for (const tg::Primitive& p : me.primitives) {
      if (p.material < 0 || static_cast<size_t>(p.material) >= m.materials.size()) continue;
      const std::vector<double>& e = m.materials[p.material].emissiveFactor;
      if (std::any_of(e.begin(), e.end(), [](double c) { return c != 0.0; })) return true;
    }
    return false;
  }

  void add_mesh(int mesh, const glm::dmat4& world, const std::string& node_where) {
    if (mesh < 0 || static_cast<size_t>(mesh) >= m.meshes.size())
      fail(node_where + ".mesh", "mesh " + std::to_string(mesh) + " does not exist");
    const int k = mesh_index(mesh);
    if (k < 0) return;  // nothing to show
    const GltfMesh& g = out.meshes[k];
    // A node that flattens its mesh (a zero scale) shows nothing, as its triangles placed one by one would be
    // degenerate and left out.
    const double det = glm::determinant(glm::dmat3(world));
    if (!(std::abs(det) > 0.0 && std::isfinite(1.0 / det))) {
      out.degenerate += g.mesh.size();
      return;
    }
    if (mesh_emits(m.meshes[mesh])) {
      const size_t before = out.triangles.size();
      place_mesh_triangles(g, world, out);
      stored_triangles += out.triangles.size() - before;
      if (stored_triangles > kMaxMeshTriangles)
        fail(node_where, "more than " + std::to_string(kMaxMeshTriangles) + " triangles in the file");
    } else {
      out.instances.push_back({static_cast<uint32_t>(k), world});
    }
  }

  // Drops the meshes no instance places (the emitting ones, placed as shapes), renumbering the instances'.
  void keep_placed_meshes() {
    std::vector<int> kept(out.meshes.size(), -1);
    std::vector<GltfMesh> meshes;
    for (GltfInstance& in : out.instances) {
      if (kept[in.mesh] < 0) {
        kept[in.mesh] = static_cast<int>(meshes.size());
        meshes.push_back(std::move(out.meshes[in.mesh]));
      }
      in.mesh = static_cast<uint32_t>(kept[in.mesh]);
    }
    out.meshes = std::move(meshes);
  }

  void count_triangle(const std::string& where) {
    if (++stored_triangles > kMaxMeshTriangles)
      fail(where, "more than " + std::to_string(kMaxMeshTriangles) + " triangles in the file");
  }

  // The index in out.meshes of file mesh `mesh`, read on first use; −1 when it has no triangle to show.
  int mesh_index(int mesh) {
    if (read_mesh[mesh] == -2) return -1;
    if (read_mesh[mesh] >= 0) return read_mesh[mesh];
    GltfMesh g = read_triangles(mesh);
    if (g.mesh.index.empty()) {
      read_mesh[mesh] = -2;
      return -1;
    }
    read_mesh[mesh] = static_cast<int>(out.meshes.size());
    out.meshes.push_back(std::move(g));
    return read_mesh[mesh];
  }

  // File mesh `mesh` as an indexed mesh: its primitives' vertices one after the other (normals made unit, zero
  // where the file's cannot be; zero for a primitive without them, whose faces stay flat as the specification
  // asks), their triangles with a material slot each; zero-area triangles left out.
  GltfMesh read_triangles(int mesh) {
    GltfMesh g;
    MeshDesc& out_mesh = g.mesh;
    std::map<int, uint32_t> slot_of;  // file material → slot
    const tg::Mesh& me = m.meshes[mesh];
    bool normals = false, uv = false, tangents = false;
    for (const tg::Primitive& p : me.primitives) {
      normals = normals || p.attributes.count("NORMAL");
      uv = uv || p.attributes.count("TEXCOORD_0");
      tangents = tangents || p.attributes.count("TANGENT");
    }
    for (size_t pi = 0; pi < me.primitives.size(); ++pi) {
      const tg::Primitive& p = me.primitives[pi];
      const std::string where = "meshes[" + std::to_string(mesh) + "].primitives[" + std::to_string(pi) + "]";
      if (p.mode != TINYGLTF_MODE_TRIANGLES && p.mode != -1)
        fail(where + ".mode", "mode " + std::to_string(p.mode) + " is not supported (only triangles, mode 4)");
      const auto pos = p.attributes.find("POSITION");
      if (pos == p.attributes.end()) fail(where + ".attributes", "no POSITION");
      const size_t first = out_mesh.position.size();
      append_positions(pos->second, where + ".attributes.POSITION", out_mesh.position);
      const size_t count = out_mesh.position.size() - first;
      // Vertices beyond three per triangle the file may hold serve nothing; the bound also keeps a mesh's
      // indices within 32 bits.
      stored_vertices += count;
      if (stored_vertices > 3 * kMaxMeshTriangles)
        fail(where + ".attributes.POSITION", "more than " + std::to_string(3 * kMaxMeshTriangles) + " vertices in the file");
      if (const auto it = p.attributes.find("NORMAL"); it != p.attributes.end()) {
        for (const Vec3& n : attribute<3>(it->second, where + ".attributes.NORMAL", count)) {
          const float len = glm::length(n);
          out_mesh.normal.push_back(len > 0.f && std::isfinite(len) ? n / len : Vec3(0.f));
        }
      } else if (normals) {
        out_mesh.normal.resize(out_mesh.position.size(), Vec3(0.f));
      }
      if (const auto it = p.attributes.find("TEXCOORD_0"); it != p.attributes.end()) {
        const std::vector<Vec2> t = attribute<2>(it->second, where + ".attributes.TEXCOORD_0", count);
        out_mesh.uv.insert(out_mesh.uv.end(), t.begin(), t.end());
      } else if (uv) {
        out_mesh.uv.resize(out_mesh.position.size(), Vec2(0.f));
      }
      // TANGENT: xyz made unit, w its sign (±1, the bitangent's handedness); zero where unusable, and for a
      // primitive without it (normal maps there take their frame from the uv mapping).
      if (const auto it = p.attributes.find("TANGENT"); it != p.attributes.end()) {
        for (const Vec4& t : attribute<4>(it->second, where + ".attributes.TANGENT", count)) {
          const float len = glm::length(Vec3(t));
          out_mesh.tangent.push_back(len > 0.f && std::isfinite(len) ? Vec4(Vec3(t) / len, t.w < 0.f ? -1.f : 1.f)
                                                                      : Vec4(0.f));
        }
      } else if (tangents) {
        out_mesh.tangent.resize(out_mesh.position.size(), Vec4(0.f));
      }
      if (!p.targets.empty()) warn("morph targets are not read: meshes keep their base shape");
      std::vector<uint32_t> idx;
      if (p.indices >= 0) {
        idx = indices(p.indices, where + ".indices", count);
      } else {
        idx.resize(count);
        for (size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<uint32_t>(i);
      }
      if (idx.size() % 3 != 0)
        fail(where, std::to_string(idx.size()) + " vertex indices do not make whole triangles");
      int material;
      if (p.material >= 0) {
        if (static_cast<size_t>(p.material) >= m.materials.size())
          fail(where + ".material", "material " + std::to_string(p.material) + " does not exist");
        material = p.material;
      } else {
        material = default_material();
      }
      const auto [slot, added] = slot_of.emplace(material, static_cast<uint32_t>(g.slot_material.size()));
      if (added) g.slot_material.push_back(material);
      const std::vector<Vec3>& v = out_mesh.position;
      for (size_t t = 0; t + 2 < idx.size(); t += 3) {
        const std::array<uint32_t, 3> tri{static_cast<uint32_t>(first + idx[t]), static_cast<uint32_t>(first + idx[t + 1]),
                                          static_cast<uint32_t>(first + idx[t + 2])};
        if (degenerate_triangle(DVec3(v[tri[0]]), DVec3(v[tri[1]]), DVec3(v[tri[2]]))) {
          ++out.degenerate;
          continue;
        }
        count_triangle(where);
        out_mesh.index.push_back(tri);
        out_mesh.slot.push_back(slot->second);
      }
    }
    out_mesh.slots = static_cast<uint32_t>(g.slot_material.size());
    out_mesh.fit_box();
    return g;
  }

  int default_index = -1;
  int default_material() {
    if (default_index < 0) {
      MaterialDesc d;  // the specification's default material: white, metallic 1, roughness 1
      d.name = "glTF default";
      d.type = MaterialType::MetallicRoughness;
      d.albedo = Rgb(1.f);
      d.metallic = 1.f;
      d.roughness = 1.f;
      default_index = static_cast<int>(m.materials.size());
      extra_materials.push_back(d);
    }
    return default_index;
  }
  std::vector<MaterialDesc> extra_materials;

  void add_camera(int index, const glm::dmat4& world, const std::string& node_where) {
    if (index < 0 || static_cast<size_t>(index) >= m.cameras.size())
      fail(node_where + ".camera", "camera " + std::to_string(index) + " does not exist");
    if (out.camera) return;  // the first one
    const tg::Camera& c = m.cameras[index];
    if (c.type != "perspective") {
      warn("orthographic cameras are not supported: camera " + std::to_string(index) + " is passed over");
      return;
    }
    const double yfov = c.perspective.yfov;
    if (!(yfov > 0.0 && yfov < glm::pi<double>()))
      fail("cameras[" + std::to_string(index) + "].perspective.yfov", "must lie in (0, π)");
    CameraDesc cam;
    cam.position = DVec3(world * glm::dvec4(0, 0, 0, 1));
    const DVec3 forward = DVec3(world * glm::dvec4(0, 0, -1, 0)), up = DVec3(world * glm::dvec4(0, 1, 0, 0));
    if (!(glm::length(forward) > 0.0) || !(glm::length(up) > 0.0) || !std::isfinite(cam.position.x + cam.position.y + cam.position.z))
      fail(node_where, "the camera's transform is degenerate or not finite");
    cam.look_at = cam.position + glm::normalize(forward);
    cam.up = glm::normalize(up);
    cam.fov_deg = glm::degrees(yfov);
    cam.fov_axis = FovAxis::Vertical;
    out.camera = cam;
    if (c.perspective.aspectRatio > 0.0 && std::isfinite(c.perspective.aspectRatio))
      out.aspect_ratio = c.perspective.aspectRatio;
  }

  // The node's KHR_lights_punctual light: at the node's origin, shining along its −z axis.
  void add_light(const tg::Value& ext, const glm::dmat4& world, const std::string& node_where) {
    const std::string where = node_where + ".extensions.KHR_lights_punctual.light";
    if (!ext.IsObject() || !ext.Has("light") || !ext.Get("light").IsNumber()) fail(where, "missing or not a number");
    const int index = static_cast<int>(ext.Get("light").GetNumberAsDouble());
    if (index < 0 || static_cast<size_t>(index) >= m.lights.size())
      fail(where, "light " + std::to_string(index) + " does not exist (the file has " + std::to_string(m.lights.size()) + ")");
    const tg::Light& g = m.lights[index];
    const std::string lat = "extensions.KHR_lights_punctual.lights[" + std::to_string(index) + "]";
    PunctualLightDesc l;
    l.name = g.name.empty() ? "light " + std::to_string(index) : g.name;
    if (g.type == "point") l.kind = PunctualKind::Point;
    else if (g.type == "spot") l.kind = PunctualKind::Spot;
    else if (g.type == "directional") l.kind = PunctualKind::Directional;
    else fail(lat + ".type", "'" + g.type + "' is not point, spot or directional");
    Rgb colour(1.f);
    if (g.color.size() >= 3) colour = Rgb(g.color[0], g.color[1], g.color[2]);
    l.intensity = colour * static_cast<float>(g.intensity);
    if (!std::isfinite(l.intensity.x + l.intensity.y + l.intensity.z) || glm::any(glm::lessThan(l.intensity, Rgb(0.f))))
      fail(lat, "colour × intensity must be finite and not negative");
    l.position = DVec3(world * glm::dvec4(0, 0, 0, 1));
    l.direction = DVec3(world * glm::dvec4(0, 0, -1, 0));
    if (!(glm::length(l.direction) > 0.0)) fail(node_where, "the light's transform is degenerate");
    l.direction = glm::normalize(l.direction);
    if (l.kind == PunctualKind::Spot) {
      l.inner_cone = g.spot.innerConeAngle;
      l.outer_cone = g.spot.outerConeAngle;
      if (!(l.inner_cone >= 0.0 && l.inner_cone < l.outer_cone && l.outer_cone <= 0.5 * glm::pi<double>()))
        fail(lat + ".spot", "cone angles must satisfy 0 <= innerConeAngle < outerConeAngle <= pi/2");
    }
    if (g.range > 0.0) warn("light ranges are passed over: lights follow the inverse-square law everywhere");
    out.lights.push_back(l);
  }

  // Depth first; `on_path` holds the nodes above, so a cycle is found where it closes.
  void visit(int node, const glm::dmat4& parent, std::vector<bool>& on_path, int depth) {
    const std::string where = "nodes[" + std::to_string(node) + "]";
    if (node < 0 || static_cast<size_t>(node) >= m.nodes.size()) fail(where, "the node does not exist");
    if (on_path[node]) fail(where, "the node graph has a cycle through this node");
    if (depth > 1024) fail(where, "the node hierarchy is deeper than 1024");
    const tg::Node& n = m.nodes[node];
    if ((!n.matrix.empty() && n.matrix.size() != 16) || (!n.translation.empty() && n.translation.size() != 3) ||
        (!n.rotation.empty() && n.rotation.size() != 4) || (!n.scale.empty() && n.scale.size() != 3))
      fail(where, "a transform property has the wrong number of values");
    const glm::dmat4 world = parent * local_transform(n);
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 4; ++r)
        if (!std::isfinite(world[c][r])) fail(where, "its transform is not finite");
    if (n.skin >= 0) warn("skins are not read: skinned meshes keep their bind pose");
    if (n.mesh >= 0) add_mesh(n.mesh, world, where);
    if (n.camera >= 0) add_camera(n.camera, world, where);
    if (const tg::Value* ext = extension(n.extensions, "KHR_lights_punctual")) add_light(*ext, world, where);
    on_path[node] = true;
    for (int child : n.children) visit(child, world, on_path, depth + 1);
    on_path[node] = false;
  }

  void read() {
    for (const std::string& e : m.extensionsRequired)
      if (!kReadExtensions.count(e)) fail("extensionsRequired", "the extension " + e + " is required but not supported");
    for (const std::string& e : m.extensionsUsed)
      if (!kReadExtensions.count(e)) warn("the extension " + e + " is not read: what it adds is left out");
    std::vector<int> roots;
    if (!m.scenes.empty()) {
      const int s = m.defaultScene >= 0 ? m.defaultScene : 0;
      if (static_cast<size_t>(s) >= m.scenes.size()) fail("scene", "scene " + std::to_string(s) + " does not exist");
      roots = m.scenes[s].nodes;
    } else {  // no scene: every node that is no other node's child
      std::vector<bool> child(m.nodes.size(), false);
      for (const tg::Node& n : m.nodes)
        for (int c : n.children)
          if (c >= 0 && static_cast<size_t>(c) < child.size()) child[c] = true;
      for (size_t i = 0; i < m.nodes.size(); ++i)
        if (!child[i]) roots.push_back(static_cast<int>(i));
    }
    std::vector<bool> on_path(m.nodes.size(), false);
    read_mesh.assign(m.meshes.size(), -1);
    for (int r : roots) visit(r, glm::dmat4(1.0), on_path, 0);
    keep_placed_meshes();
    if (out.triangles.empty() && out.instances.empty()) throw SceneError(path + ": no triangles to show");
    // The materials: the file's, names made unique, then the default if a primitive used it.
    std::set<std::string> names;
    for (size_t i = 0; i < m.materials.size(); ++i) out.materials.push_back(material(i));
    for (MaterialDesc& d : extra_materials) out.materials.push_back(d);
    for (MaterialDesc& d : out.materials) {
      const std::string base = d.name;
      for (int k = 2; !names.insert(d.name).second; ++k) d.name = base + " (" + std::to_string(k) + ")";
    }
    for (int mat : out.triangle_material)
      if (!is_black(out.materials[mat].emission)) out.emits = true;
  }
};

// Files through the scene's safety rules (regular files, at most kMaxSceneFileBytes); nothing is written.
bool read_whole_file(std::vector<unsigned char>* out, std::string* err, const std::string& path, void*) {
  try {
    const std::string bytes = read_file_limited(path, kMaxSceneFileBytes);
    out->assign(bytes.begin(), bytes.end());
    return true;
  } catch (const FileError& e) {
    if (err) *err += e.what();
    return false;
  }
}
bool file_exists(const std::string& path, void*) {
  std::error_code ec;
  return std::filesystem::is_regular_file(path, ec);
}
std::string expand_path(const std::string& path, void*) { return path; }  // no ~ or $VAR expansion
bool write_nothing(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "writing is not allowed";
  return false;
}
// tinygltf's image callback: keeps images[index]'s encoded bytes as they are (component 0 marks them so); the
// reader decodes an image where a material uses it (io/texture_io.h: decode_image), as colour or as data.
bool keep_encoded(tg::Image* image, const int, std::string*, std::string*, int, int, const unsigned char* bytes,
                  int size, void*) {
  image->width = image->height = 0;
  image->component = 0;
  image->image.assign(bytes, bytes + size);
  return true;
}

}  // namespace

void flatten_gltf(GltfContents& g) {
  for (const GltfInstance& in : g.instances) place_mesh_triangles(g.meshes[in.mesh], in.transform, g);
  g.instances.clear();
  g.meshes.clear();
}

bool is_gltf_file(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".gltf" || ext == ".glb";
}

GltfContents load_gltf(const std::string& path) {
  std::string bytes;
  try {
    bytes = read_file_limited(path, kMaxSceneFileBytes);
  } catch (const FileError& e) {
    throw SceneError(e.what());
  }
  tg::TinyGLTF parser;
  parser.SetFsCallbacks({&file_exists, &expand_path, &read_whole_file, &write_nothing, nullptr});
  parser.SetImageLoader(&keep_encoded, nullptr);
  tg::Model model;
  std::string err, warn;
  const std::string base_dir = std::filesystem::path(path).parent_path().string();
  const bool binary = bytes.size() >= 4 && bytes.compare(0, 4, "glTF") == 0;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const bool ok = binary ? parser.LoadBinaryFromMemory(&model, &err, &warn, data, static_cast<unsigned>(bytes.size()), base_dir)
                         : parser.LoadASCIIFromString(&model, &err, &warn, bytes.data(), static_cast<unsigned>(bytes.size()), base_dir);
  std::string().swap(bytes);  // the parser keeps its own copy of the buffers
  if (!ok || !err.empty()) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    throw SceneError(path + ": not a valid glTF 2.0 file: " + (err.empty() ? std::string("the parser refused it") : err));
  }
  Reader r(path, model);
  r.read();
  return std::move(r.out);
}

SceneDesc gltf_scene(const std::string& path) {
  GltfContents g = load_gltf(path);
  for (const std::string& w : g.warnings) std::fprintf(stderr, "warning: %s: %s\n", path.c_str(), w.c_str());
  SceneDesc s;
  s.width = 640;
  s.height = g.aspect_ratio > 0.0 ? std::clamp(static_cast<int>(std::lround(640.0 / g.aspect_ratio)), 1, 16384) : 480;
  s.render.max_bounces = 16;
  // The model is one object (kind gltf, named after the file's stem), its materials named "STEM/NAME" as a scene
  // file's gltf shape names them: saved from the viewer, the scene refers to the file (its normals, textures and
  // all) instead of writing its triangles out, and edited materials come back as overrides.
  const std::string stem = std::filesystem::path(path).stem().string();
  s.materials = std::move(g.materials);
  for (MaterialDesc& m : s.materials) m.name = stem + "/" + m.name;
  ObjectDesc object;
  object.kind = ObjectKind::Gltf;
  object.name = stem;
  object.file = object.resolved_file = path;
  object.shape_count = g.triangles.size();
  s.objects.push_back(object);
  s.shapes.reserve(g.triangles.size());
  DVec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < g.triangles.size(); ++i) {
    ShapeDesc tri;
    tri.type = ShapeType::Triangle;
    tri.vertices = {g.triangles[i][0], g.triangles[i][1], g.triangles[i][2], DVec3(0.0)};
    tri.material = g.triangle_material[i];
    if (!g.shading.empty() && g.shading[i].any()) tri.shading = static_cast<uint32_t>(i);  // the table moves as it is
    s.shapes.push_back(tri);
    for (int k = 0; k < 3; ++k) lo = glm::min(lo, g.triangles[i][k]), hi = glm::max(hi, g.triangles[i][k]);
  }
  if (!g.shading.empty()) s.shading = std::make_shared<const std::vector<TriangleShading>>(std::move(g.shading));
  // The meshes (all but the emitting ones): stored once, placed by instances of the model's object.
  for (GltfMesh& m : g.meshes) s.meshes.push_back(std::make_shared<const MeshDesc>(std::move(m.mesh)));
  for (const GltfInstance& gi : g.instances) {
    InstanceDesc in;
    in.mesh = gi.mesh;
    in.transform = gi.transform;
    in.object = 0;
    in.materials = g.meshes[gi.mesh].slot_material;  // the scene's materials are the file's, in order
    s.instances.push_back(std::move(in));
  }
  // The framing camera frames the vertices as placed (a rotated mesh's box would frame it loosely), unless that
  // means more than kExactFramingVertices transforms; then the placed boxes.
  constexpr size_t kExactFramingVertices = size_t{1} << 22;
  size_t placed_vertices = 0;
  for (const InstanceDesc& in : s.instances) placed_vertices += s.meshes[in.mesh]->position.size();
  for (const InstanceDesc& in : s.instances) {
    if (placed_vertices <= kExactFramingVertices) {
      for (const Vec3& p : s.meshes[in.mesh]->position) {
        const DVec3 w(in.transform * glm::dvec4(DVec3(p), 1.0));
        lo = glm::min(lo, w), hi = glm::max(hi, w);
      }
    } else {
      const auto [ilo, ihi] = placed_box(s, in);
      lo = glm::min(lo, ilo), hi = glm::max(hi, ihi);
    }
  }
  s.camera = g.camera ? *g.camera : framing_camera(lo, hi);
  s.punctual_lights = std::move(g.lights);
  for (PunctualLightDesc& l : s.punctual_lights) l.object = 0;  // placed by the model's object
  if (g.emits || !s.punctual_lights.empty()) {
    s.environment.type = EnvironmentType::Constant;
    s.environment.radiance = Rgb(0.f);
  } else {
    s.environment = daylight_environment();
  }
  if (std::string err = validate_scene(s); !err.empty()) throw SceneError(path + ": " + err);
  return s;
}

}  // namespace pt
