#include "scene/mesh_obj.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <new>
#include <set>
#include <stdexcept>
#include <utility>

#include "io/image_io.h"
#include "io/texture_io.h"
#include "io/safe_file.h"
#include "materials/texture.h"
#include "scene/mtl_material.h"
#include "scene/scene.h"
#include "scene/scene_json.h"

namespace pt {

namespace {

// tinyobjloader's number parser reads a malformed coordinate ("nan", "abc", "1e999") as 0 or clamps it without a
// word, which would silently move a vertex. So every vertex line is checked first: its first three fields must be
// numbers (the whole field) that are finite in float.
void check_vertex_lines(const std::string& path, const std::string& text) {
  size_t line_no = 0;
  for (size_t pos = 0; pos < text.size();) {
    const size_t end = std::min(text.find('\n', pos), text.size());
    ++line_no;
    size_t i = text.find_first_not_of(" \t", pos);
    if (i < end && text[i] == 'v' && i + 1 < end && (text[i + 1] == ' ' || text[i + 1] == '\t')) {
      i += 1;
      for (int field = 0; field < 3; ++field) {
        i = text.find_first_not_of(" \t\r", i);
        const size_t stop = i < end ? std::min(text.find_first_of(" \t\r", i), end) : end;
        const std::string token = i < end ? text.substr(i, stop - i) : std::string();
        char* tail = nullptr;
        const double value = token.empty() ? 0.0 : std::strtod(token.c_str(), &tail);
        if (token.empty() || *tail != '\0' || !std::isfinite(value) || std::abs(value) > 3.4e38)
          throw std::runtime_error(path + ": line " + std::to_string(line_no) + ": vertex coordinate " +
                                   std::to_string(field + 1) + (token.empty() ? " is missing" : " '" + token + "' is not a finite number"));
        i = stop;
      }
    }
    pos = end + 1;
  }
}

// The text of the material libraries named by `mtllib` lines, read from the OBJ's folder under the scene's
// safety rules; a library that cannot be read is a warning (the geometry stands without it).
std::string material_libraries(const std::string& path, const std::string& text, std::vector<std::string>& warnings) {
  std::string out;
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  for (size_t pos = 0; pos < text.size();) {
    const size_t end = std::min(text.find('\n', pos), text.size());
    const size_t i = text.find_first_not_of(" \t", pos);
    if (i < end && text.compare(i, 7, "mtllib ") == 0) {
      std::string names = text.substr(i + 7, end - i - 7);
      while (!names.empty() && (names.back() == '\r' || names.back() == ' ' || names.back() == '\t')) names.pop_back();
      for (size_t a = names.find_first_not_of(" \t"); a < names.size();) {
        const size_t b = std::min(names.find_first_of(" \t", a), names.size());
        const std::string lib = (dir / names.substr(a, b - a)).string();
        try {
          out += read_file_limited(lib, kMaxSceneFileBytes) + "\n";
        } catch (const FileError& e) {
          warnings.push_back(std::string("material library not read (its faces take the default material): ") + e.what());
        }
        a = names.find_first_not_of(" \t", b);
      }
    }
    pos = end + 1;
  }
  return out;
}

MtlParams mtl_params(const tinyobj::material_t& m) {
  MtlParams p;
  p.name = m.name;
  p.kd = Rgb(m.diffuse[0], m.diffuse[1], m.diffuse[2]);
  p.ks = Rgb(m.specular[0], m.specular[1], m.specular[2]);
  p.ke = Rgb(m.emission[0], m.emission[1], m.emission[2]);
  p.ns = m.shininess;
  p.ni = m.ior;
  p.dissolve = m.dissolve;
  p.illum = m.illum;
  const std::pair<const char*, const std::string*> maps[] = {
      {"map_Ks", &m.specular_texname}, {"map_Ns", &m.specular_highlight_texname},
      {"bump", &m.bump_texname},       {"disp", &m.displacement_texname},
      {"map_Ke", &m.emissive_texname}};
  for (const auto& [keyword, name] : maps)
    if (!name->empty()) p.textures.push_back(keyword);
  for (float* c : {&p.kd.x, &p.kd.y, &p.kd.z, &p.ks.x, &p.ks.y, &p.ks.z, &p.ke.x, &p.ke.y, &p.ke.z, &p.ns, &p.ni})
    if (!std::isfinite(*c)) *c = 0.f;
  return p;
}

// A file an .mtl names, relative to the OBJ's folder.
std::string beside(const std::string& obj_path, const std::string& name) {
  return (std::filesystem::path(obj_path).parent_path() / name).string();
}

// map_Kd: the image (relative to the OBJ's folder) whose colour times Kd is the material's albedo, as the .mtl
// format defines it; for the material just added to out.materials. One that cannot be read is a warning (the
// material keeps Kd alone).
void add_diffuse_map(const std::string& obj_path, const std::string& name, MeshTriangles& out) {
  MaterialDesc& d = out.materials.back();
  if (!takes(d.type, MaterialParam::Albedo) || d.type == MaterialType::Subsurface) {
    out.warnings.push_back("material " + d.name + ": map_Kd is not used by its " + to_string(d.type) + " mapping");
    return;
  }
  const std::string file = beside(obj_path, name);
  try {
    d.albedo_map = load_texture_file(file, true);
    d.albedo_texture = d.resolved_albedo_texture = file;
  } catch (const ImageError& e) {
    out.warnings.push_back("material " + d.name + ": map_Kd not read (its Kd colour stands alone): " + e.what());
  }
}

// norm: a tangent-space normal map (materials/normal_map.h; linear, the image's up is +y as in glTF), for the
// material just added to out.materials. One that cannot be read is a warning (the surface stays smooth).
void add_normal_map(const std::string& obj_path, const std::string& name, MeshTriangles& out) {
  MaterialDesc& d = out.materials.back();
  const std::string file = beside(obj_path, name);
  try {
    d.normal_map.texture = load_texture_file(file, false);
  } catch (const ImageError& e) {
    out.warnings.push_back("material " + d.name + ": norm not read (no normal map): " + e.what());
  }
}

// map_d: the dissolve image as a cut-out (geometry/alpha_mask.h): opaque where its value (its alpha channel,
// or its grey level for an image without one) is at least ½, for the material just added to out.materials; for
// a material with d < 1 (partial transparency, mtl_material.h), there with probability d × its value.
// One that cannot be read is a warning (the surface stays as d makes it).
void add_cutout(const std::string& obj_path, const std::string& name, MeshTriangles& out) {
  MaterialDesc& d = out.materials.back();
  const std::string file = beside(obj_path, name);
  try {
    auto mask = d.cutout ? std::make_shared<AlphaMask>(*d.cutout) : std::make_shared<AlphaMask>();
    mask->alpha = make_texture(alpha_as_image(decode_alpha(read_file_limited(file, kMaxTextureFileBytes), file, true)),
                               TextureWrap::Repeat, TextureWrap::Repeat,
                               std::filesystem::path(file).filename().string() + " (map_d)");
    d.cutout = std::move(mask);
  } catch (const std::bad_alloc&) {
    throw;  // out of memory is not a broken file (exit status 3, docs/reliability.md)
  } catch (const std::exception& e) {
    out.warnings.push_back("material " + d.name + ": map_d not read (the surface stays opaque): " + e.what());
  }
}

}  // namespace

MeshTriangles load_obj_mesh(const std::string& path, const ObjectTransform& t) {
  const std::string text = read_file_limited(path, kMaxSceneFileBytes);  // FileError names the path
  check_vertex_lines(path, text);
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  MeshTriangles out;
  // From memory, with the material libraries read above (tinyobjloader opens no file itself).
  if (!reader.ParseFromString(text, material_libraries(path, text, out.warnings), config)) {
    std::string why = reader.Error();
    while (!why.empty() && (why.back() == '\n' || why.back() == '\r')) why.pop_back();
    throw std::runtime_error(path + ": not a readable OBJ file" + (why.empty() ? "" : " (" + why + ")"));
  }
  const std::vector<tinyobj::real_t>& v = reader.GetAttrib().vertices;
  const std::vector<tinyobj::real_t>& vn = reader.GetAttrib().normals;
  const std::vector<tinyobj::real_t>& vt = reader.GetAttrib().texcoords;
  const size_t vertex_count = v.size() / 3;
  // A corner's normal (unit, zero when it names none or one of zero length) and texture coordinates.
  const auto corner_normal = [&](int ni) {
    if (ni < 0 || static_cast<size_t>(ni) >= vn.size() / 3) return Vec3(0.f);
    const Vec3 n(vn[3 * ni], vn[3 * ni + 1], vn[3 * ni + 2]);
    if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z))
      throw std::runtime_error(path + ": vertex normal " + std::to_string(ni + 1) + " is not finite");
    const float len = glm::length(n);
    return len > 0.f ? n / len : Vec3(0.f);
  };
  // OBJ's v grows upwards from the image's bottom; the tracer's from its top (materials/texture.h).
  const auto corner_uv = [&](int ti) {
    if (ti < 0 || static_cast<size_t>(ti) >= vt.size() / 2) return Vec2(0.f);
    return Vec2(vt[2 * ti], 1.f - vt[2 * ti + 1]);
  };

  bool has_shading = false;
  // The materials that some face uses (tinyobjloader adds an unnamed one of its own when a library is
  // missing), in the order of the libraries; `index_of` maps its material ids to out.materials.
  const auto& materials = reader.GetMaterials();
  std::vector<int> index_of(materials.size(), -1);
  for (const tinyobj::shape_t& shape : reader.GetShapes())
    for (int id : shape.mesh.material_ids)
      if (id >= 0 && static_cast<size_t>(id) < materials.size()) index_of[id] = 0;
  for (size_t i = 0; i < materials.size(); ++i)
    if (index_of[i] == 0) {
      index_of[i] = static_cast<int>(out.materials.size());
      out.materials.push_back(mtl_material(mtl_params(materials[i]), out.warnings));
      if (!materials[i].diffuse_texname.empty()) add_diffuse_map(path, materials[i].diffuse_texname, out);
      if (!materials[i].normal_texname.empty()) add_normal_map(path, materials[i].normal_texname, out);
      if (!materials[i].alpha_texname.empty()) add_cutout(path, materials[i].alpha_texname, out);
    }
  // The parser's own remarks (a usemtl name no library defines, …), a few lines at most.
  {
    std::string w = reader.Warning();
    int lines = 0;
    for (size_t a = 0; a < w.size() && lines < 5;) {
      const size_t b = std::min(w.find('\n', a), w.size());
      if (b > a) out.warnings.push_back(w.substr(a, b - a)), ++lines;
      a = b + 1;
    }
  }
  std::set<std::string> names;  // made unique: a library may repeat a name, or name one "default"
  names.insert("default");
  for (MaterialDesc& d : out.materials) {
    const std::string base = d.name;
    for (int k = 2; !names.insert(d.name).second; ++k) d.name = base + " (" + std::to_string(k) + ")";
  }
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    const auto& idx = shape.mesh.indices;
    if (idx.size() % 3 != 0) throw std::runtime_error(path + ": a face was not triangulated");
    for (size_t f = 0; f + 2 < idx.size(); f += 3) {
      const size_t face = f / 3;
      const int mat = face < shape.mesh.material_ids.size() ? shape.mesh.material_ids[face] : -1;
      std::array<DVec3, 3> tri;
      TriangleShading shading;
      for (int j = 0; j < 3; ++j) {
        shading.normal[j] = corner_normal(idx[f + j].normal_index);
        shading.uv[j] = corner_uv(idx[f + j].texcoord_index);
        if (idx[f + j].texcoord_index >= 0) shading.has_uv = true;
        const int vi = idx[f + j].vertex_index;
        if (vi < 0 || static_cast<size_t>(vi) >= vertex_count)
          throw std::runtime_error(path + ": a face refers to a vertex the file does not have (it has " +
                                   std::to_string(vertex_count) + ")");
        const DVec3 p(v[3 * vi], v[3 * vi + 1], v[3 * vi + 2]);
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
          throw std::runtime_error(path + ": vertex " + std::to_string(vi + 1) + " is not finite");
        tri[j] = to_world(t, p);
      }
      if (mirrors(t)) std::swap(tri[1], tri[2]);
      if (degenerate_triangle(tri[0], tri[1], tri[2])) {
        ++out.degenerate;
        continue;
      }
      if (out.triangles.size() >= kMaxMeshTriangles)
        throw std::runtime_error(path + ": more than " + std::to_string(kMaxMeshTriangles) + " triangles");
      out.triangles.push_back(tri);
      if (!out.materials.empty())
        out.triangle_material.push_back(mat >= 0 && static_cast<size_t>(mat) < index_of.size() ? index_of[mat] : -1);
      if (shading.normal[0] == Vec3(0.f) || shading.normal[1] == Vec3(0.f) || shading.normal[2] == Vec3(0.f))
        shading.normal = {};  // a corner without a normal: the face stays flat
      out.shading.push_back(shading);
      has_shading = has_shading || shading.any();
    }
  }
  if (!has_shading) out.shading.clear();
  if (out.triangles.empty()) throw std::runtime_error(path + ": the mesh has no triangle of non-zero area");
  return out;
}

}  // namespace pt
