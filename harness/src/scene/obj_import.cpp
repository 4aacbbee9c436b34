#include "scene/obj_import.h"

#include <fmt/format.h>
#include <tiny_obj_loader.h>

#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "photonbench/error.h"

namespace pb::scene {

namespace {

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  return lines;
}

std::vector<std::string> tokens(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream in(line);
  for (std::string t; in >> t;) out.push_back(t);
  return out;
}

// The 1-based line of the first statement `keyword [argument]`, or 0.
size_t find_statement(const std::vector<std::string>& lines, const std::string& keyword,
                      const std::string& argument = "") {
  for (size_t i = 0; i < lines.size(); ++i) {
    auto t = tokens(lines[i]);
    if (t.empty() || t[0] != keyword) continue;
    if (argument.empty() || (t.size() > 1 && t[1] == argument)) return i + 1;
  }
  return 0;
}

[[noreturn]] void fail_at(const std::filesystem::path& file, size_t line,
                          const std::string& message) {
  if (line > 0) throw InputError(fmt::format("{}:{}: {}", file.string(), line, message));
  throw InputError(fmt::format("{}: {}", file.string(), message));
}

// tinyobjloader only reports out-of-range indices at the end of the file (and reads out of bounds
// while triangulating polygons before that), so check them first, naming the face's line.
void check_face_indices(const std::filesystem::path& file, const std::vector<std::string>& lines) {
  int64_t vertices = 0, normals = 0;
  for (const auto& line : lines) {
    auto t = tokens(line);
    if (t.empty()) continue;
    if (t[0] == "v") ++vertices;
    if (t[0] == "vn") ++normals;
  }
  for (size_t i = 0; i < lines.size(); ++i) {
    auto t = tokens(lines[i]);
    if (t.empty() || t[0] != "f") continue;
    if (t.size() < 4) fail_at(file, i + 1, "a face needs at least three vertices");
    for (size_t k = 1; k < t.size(); ++k) {
      std::vector<std::string> parts;
      std::stringstream corner(t[k]);
      for (std::string p; std::getline(corner, p, '/');) parts.push_back(p);
      auto check = [&](size_t slot, int64_t count, const char* what) {
        if (slot >= parts.size() || parts[slot].empty()) return;
        int64_t index = 0;
        try {
          index = std::stoll(parts[slot]);
        } catch (const std::exception&) {
          fail_at(file, i + 1, fmt::format("bad {} index '{}' in face", what, parts[slot]));
        }
        if (index == 0 || index > count || -index > count)
          fail_at(file, i + 1,
                  fmt::format("face refers to {} {} but the file has only {}", what, index, count));
      };
      check(0, vertices, "vertex");
      check(2, normals, "normal");
    }
  }
}

}  // namespace

Material material_from_mtl(const MtlValues& mtl) {
  Material m;
  m.name = mtl.name;
  m.albedo = mtl.kd;
  if (glm::any(glm::greaterThan(mtl.ke, glm::vec3(0.0f)))) {
    m.type = MaterialType::emissive;
    m.emission = mtl.ke;
  } else if (mtl.dissolve < 1.0f || mtl.illum == 4 || mtl.illum == 6 || mtl.illum == 7) {
    // Illumination models 4, 6 and 7 are the MTL spec's glass / refraction models; a dissolve below
    // 1 is how most exporters mark transparency.
    m.type = MaterialType::dielectric;
    m.ior = mtl.ni > 1.0f ? mtl.ni : 1.5f;
  } else if ((mtl.illum == 3 || mtl.illum == 5) &&
             glm::any(glm::greaterThan(mtl.ks, glm::vec3(0.0f)))) {
    m.type = MaterialType::mirror;
    m.specular = mtl.ks;
  } else {
    m.type = MaterialType::diffuse;
  }
  return m;
}

ObjModel load_obj(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) fail_at(file, 0, "cannot open OBJ file");
  std::stringstream text;
  text << in.rdbuf();
  const auto lines = split_lines(text.str());
  check_face_indices(file, lines);

  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> mtl;
  std::string warn, err;
  // (Built in one expression: GCC 12's -Wrestrict misfires on assigning a literal to a string
  // here.)
  const std::string base =
      (file.has_parent_path() ? file.parent_path() : std::filesystem::path(".")).string() + "/";
  tinyobj::MaterialFileReader reader(base);
  std::istringstream stream(text.str());
  bool ok = tinyobj::LoadObj(&attrib, &shapes, &mtl, &warn, &err, &stream, &reader, true, false);
  if (!ok || !err.empty()) {
    std::smatch m;
    size_t line = 0;
    if (std::regex_search(err, m, std::regex(R"(line:? (\d+))"))) line = std::stoul(m[1]);
    std::string message = err.empty() ? "cannot parse OBJ file" : err;
    while (!message.empty() && (message.back() == '\n' || message.back() == ' '))
      message.pop_back();
    fail_at(file, line, message);
  }
  // tinyobjloader treats a missing MTL file and an unknown material as warnings and silently uses
  // no material; a benchmark scene must not change its look silently, so both are errors here.
  std::smatch m;
  if (std::regex_search(warn, m, std::regex(R"(Material file \[ (.*?) \] not found)")))
    fail_at(file, find_statement(lines, "mtllib"),
            fmt::format("MTL file '{}' not found next to the OBJ file", m[1].str()));
  if (std::regex_search(warn, m, std::regex(R"(material \[ '?(.*?)'? \] not found in \.mtl)")))
    fail_at(file, find_statement(lines, "usemtl", m[1].str()),
            fmt::format("usemtl '{}': no such material in the MTL file", m[1].str()));

  ObjModel model;
  for (const auto& t : mtl) {
    MtlValues v;
    v.name = t.name;
    v.kd = {float(t.diffuse[0]), float(t.diffuse[1]), float(t.diffuse[2])};
    v.ks = {float(t.specular[0]), float(t.specular[1]), float(t.specular[2])};
    v.ke = {float(t.emission[0]), float(t.emission[1]), float(t.emission[2])};
    v.ni = float(t.ior);
    v.dissolve = float(t.dissolve);
    v.illum = t.illum;
    for (int c = 0; c < 3; ++c)
      if (v.kd[c] < 0 || v.kd[c] > 1)
        fail_at(file, 0,
                fmt::format("material '{}': Kd {} is outside [0, 1] (it would create energy)",
                            t.name, v.kd[c]));
    model.materials.push_back(material_from_mtl(v));
  }

  // One part per material, vertices shared within a part where position and normal indices agree.
  std::map<int, size_t> part_of_material;
  std::vector<std::map<std::pair<int, int>, uint32_t>> shared;
  auto position = [&](int i) {
    return glm::vec3(float(attrib.vertices[3 * i]), float(attrib.vertices[3 * i + 1]),
                     float(attrib.vertices[3 * i + 2]));
  };
  for (const auto& shape : shapes) {
    size_t offset = 0;
    for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      size_t count = shape.mesh.num_face_vertices[f];
      const tinyobj::index_t* idx = &shape.mesh.indices[offset];
      offset += count;
      if (count != 3) continue;  // triangulation left a degenerate polygon
      int material = f < shape.mesh.material_ids.size() ? shape.mesh.material_ids[f] : -1;
      auto [it, added] = part_of_material.try_emplace(material, model.parts.size());
      if (added) {
        model.parts.push_back(ObjPart{material, {}});
        shared.emplace_back();
      }
      Mesh& mesh = model.parts[it->second].mesh;
      auto& cache = shared[it->second];
      glm::vec3 p[3] = {position(idx[0].vertex_index), position(idx[1].vertex_index),
                        position(idx[2].vertex_index)};
      glm::vec3 face = glm::cross(p[1] - p[0], p[2] - p[0]);
      float area2 = glm::length(face);
      if (!(area2 > 0)) continue;  // zero-area triangles add nothing and have no normal
      face /= area2;
      glm::uvec3 tri;
      for (int k = 0; k < 3; ++k) {
        int ni = idx[k].normal_index;
        glm::vec3 n(0.0f);
        if (ni >= 0)
          n = {float(attrib.normals[3 * ni]), float(attrib.normals[3 * ni + 1]),
               float(attrib.normals[3 * ni + 2])};
        bool smooth = glm::length(n) > 0;
        if (smooth) {
          auto [slot, fresh] =
              cache.try_emplace({idx[k].vertex_index, ni}, uint32_t(mesh.positions.size()));
          if (fresh) {
            mesh.positions.push_back(p[k]);
            mesh.normals.push_back(glm::normalize(n));
          }
          tri[k] = slot->second;
        } else {  // no usable normal: flat shading, a vertex of its own
          tri[k] = uint32_t(mesh.positions.size());
          mesh.positions.push_back(p[k]);
          mesh.normals.push_back(face);
        }
      }
      mesh.triangles.push_back(tri);
    }
  }
  if (model.parts.empty()) fail_at(file, 0, "the OBJ file has no faces");
  return model;
}

}  // namespace pb::scene
