#include "scene/obj_import.h"

#include <fmt/format.h>
#include <tiny_obj_loader.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>
#include <regex>
#include <sstream>

#include "config/yaml_view.h"
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

// A statement's arguments as numbers: `count_min`..`count_max` of them, each finite and inside
// [lo, hi]; otherwise an error naming the file and line. tinyobjloader reads "nan" or "1e999" as
// some number without a word, so the values a scene uses are checked here, on the text.
void check_numbers(const std::filesystem::path& file, size_t line,
                   const std::vector<std::string>& t, size_t count_min, size_t count_max, double lo,
                   double hi) {
  if (t.size() - 1 < count_min || t.size() - 1 > count_max)
    fail_at(file, line,
            fmt::format("'{}' takes {} numbers, got {}", t[0],
                        count_min == count_max ? fmt::format("{}", count_min)
                                               : fmt::format("{} to {}", count_min, count_max),
                        t.size() - 1));
  for (size_t k = 1; k < t.size(); ++k) {
    char* end = nullptr;
    errno = 0;
    double value = std::strtod(t[k].c_str(), &end);
    if (end == t[k].c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(value))
      fail_at(file, line,
              fmt::format("'{}': '{}' is not a finite number", t[0], config::quote(t[k])));
    if (value < lo || value > hi)
      fail_at(file, line, fmt::format("'{}': {} is out of range [{}, {}]", t[0], value, lo, hi));
  }
}

// tinyobjloader only reports out-of-range indices at the end of the file (and reads out of bounds
// while triangulating polygons before that), so check them first, naming the face's line; and
// check the coordinates it would read.
void check_obj_text(const std::filesystem::path& file, const std::vector<std::string>& lines) {
  int64_t vertices = 0, normals = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    auto t = tokens(lines[i]);
    if (t.empty()) continue;
    // v x y z [w] or v x y z r g b (vertex colours); vn x y z.
    if (t[0] == "v") ++vertices, check_numbers(file, i + 1, t, 3, 6, -kMaxMagnitude, kMaxMagnitude);
    if (t[0] == "vn") ++normals, check_numbers(file, i + 1, t, 3, 3, -kMaxMagnitude, kMaxMagnitude);
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
        if (slot >= parts.size() || parts[slot].empty()) {
          if (slot == 0) fail_at(file, i + 1, "a face corner needs a vertex index");
          return;
        }
        const std::string& text = parts[slot];
        const bool digits =
            text.find_first_not_of("0123456789", text[0] == '-' ? 1 : 0) == std::string::npos &&
            text.size() > (text[0] == '-' ? 1u : 0u);
        if (!digits || text.size() > 12)
          fail_at(file, i + 1, fmt::format("bad {} index '{}' in face", what, config::quote(text)));
        int64_t index = std::stoll(text);
        if (index == 0 || index > count || -index > count)
          fail_at(file, i + 1,
                  fmt::format("face refers to {} {} but the file has only {}", what, index, count));
      };
      check(0, vertices, "vertex");
      check(2, normals, "normal");
    }
  }
}

// An MTL file's lines, for naming the line of a bad value.
struct MtlText {
  std::filesystem::path file;
  std::vector<std::string> lines;
};

// Checks the statements material_from_mtl reads, in every material of an MTL file.
void check_mtl_text(const MtlText& mtl) {
  for (size_t i = 0; i < mtl.lines.size(); ++i) {
    auto t = tokens(mtl.lines[i]);
    if (t.empty()) continue;
    const size_t line = i + 1;
    if (t[0] == "Kd" || t[0] == "Ks")  // reflectances: more than 1 would create energy
      check_numbers(mtl.file, line, t, 1, 3, 0, 1);
    else if (t[0] == "Ke")
      check_numbers(mtl.file, line, t, 1, 3, 0, kMaxMagnitude);
    else if (t[0] == "Ni")  // <= 1 means "not set" (1.5); above 4 is no real dielectric
      check_numbers(mtl.file, line, t, 1, 1, 0, 4);
    else if (t[0] == "d" || t[0] == "Tr")
      check_numbers(mtl.file, line, t, 1, 1, 0, 1);
    else if (t[0] == "illum")
      check_numbers(mtl.file, line, t, 1, 1, 0, 10);
  }
}

// Reads MTL files through `source`, keeping their text; tinyobjloader's own reader opens any path
// with an ifstream (a directory reads as empty, /dev/zero never ends).
class MtlReader final : public tinyobj::MaterialReader {
 public:
  MtlReader(const std::filesystem::path& obj_file, const MtlSource& source)
      : directory_(obj_file.parent_path()), source_(source) {}
  bool operator()(const std::string& name, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* index, std::string* warn, std::string* err) override {
    std::optional<std::string> text = source_(name);
    if (!text) {
      // The warning tinyobjloader's reader gives; load_obj turns it into an error at `mtllib`.
      *warn += "Material file [ " + name + " ] not found\n";
      return false;
    }
    check_mtl_text({directory_ / name, split_lines(*text)});
    std::istringstream in(*text);
    tinyobj::LoadMtl(index, materials, &in, warn, err);
    return true;
  }

 private:
  std::filesystem::path directory_;
  const MtlSource& source_;
};

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
  const std::filesystem::path directory = file.parent_path();
  return parse_obj(config::read_text_file(file, kMaxObjBytes, "OBJ file"), file,
                   [&](const std::string& name) -> std::optional<std::string> {
                     std::error_code ec;
                     if (!std::filesystem::exists(directory / name, ec)) return std::nullopt;
                     return config::read_text_file(directory / name, config::kMaxYamlBytes,
                                                   "MTL file");
                   });
}

ObjModel parse_obj(const std::string& obj_text, const std::filesystem::path& file,
                   const MtlSource& read_mtl) {
  const auto lines = split_lines(obj_text);
  check_obj_text(file, lines);

  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> mtl;
  std::string warn, err;
  MtlReader reader(file, read_mtl);
  std::istringstream stream(obj_text);
  bool ok = tinyobj::LoadObj(&attrib, &shapes, &mtl, &warn, &err, &stream, &reader, true, false);
  if (!ok || !err.empty()) {
    std::smatch m;
    size_t line = 0;
    static const std::regex line_number(R"(line:? (\d{1,9})\b)");
    if (std::regex_search(err, m, line_number)) line = std::stoul(m[1]);
    std::string message = err.empty() ? "cannot parse OBJ file" : err;
    while (!message.empty() && (message.back() == '\n' || message.back() == ' '))
      message.pop_back();
    fail_at(file, line, message);
  }
  // tinyobjloader treats a missing MTL file and an unknown material as warnings and silently uses
  // no material; a benchmark scene must not change its look silently, so both are errors here.
  static const std::regex missing_mtl(R"(Material file \[ (.*?) \] not found)");
  static const std::regex unknown_material(R"(material \[ '?(.*?)'? \] not found in \.mtl)");
  std::smatch m;
  if (std::regex_search(warn, m, missing_mtl))
    fail_at(file, find_statement(lines, "mtllib"),
            fmt::format("MTL file '{}' not found next to the OBJ file", m[1].str()));
  if (std::regex_search(warn, m, unknown_material))
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
    // check_mtl_text read the statements; this catches what tinyobjloader made of them otherwise.
    auto in_range = [](const glm::vec3& x, float hi) {
      return glm::all(glm::greaterThanEqual(x, glm::vec3(0))) &&
             glm::all(glm::lessThanEqual(x, glm::vec3(hi)));
    };
    if (!in_range(v.kd, 1) || !in_range(v.ks, 1) || !in_range(v.ke, float(kMaxMagnitude)) ||
        !(v.ni >= 0 && v.ni <= 4) || !(v.dissolve >= 0 && v.dissolve <= 1))
      fail_at(file, 0,
              fmt::format("material '{}': a value is out of range (Kd and Ks in [0, 1], Ke in "
                          "[0, {}], Ni in [0, 4], d in [0, 1])",
                          config::quote(t.name), kMaxMagnitude));
    model.materials.push_back(material_from_mtl(v));
  }

  // One part per material, vertices shared within a part where position and normal indices agree.
  std::map<int, size_t> part_of_material;
  std::vector<std::map<std::pair<int, int>, uint32_t>> shared;
  // check_obj_text checked the indices on the text; these checks hold whatever tinyobjloader read.
  const size_t vertex_count = attrib.vertices.size() / 3, normal_count = attrib.normals.size() / 3;
  auto position = [&](int i) {
    if (i < 0 || size_t(i) >= vertex_count)
      fail_at(file, 0, "a face's vertex index is out of range");
    return glm::vec3(float(attrib.vertices[3 * i]), float(attrib.vertices[3 * i + 1]),
                     float(attrib.vertices[3 * i + 2]));
  };
  size_t faces = 0;
  for (const auto& shape : shapes) {
    size_t offset = 0;
    for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      size_t count = shape.mesh.num_face_vertices[f];
      if (offset + count > shape.mesh.indices.size()) fail_at(file, 0, "a face is cut short");
      const tinyobj::index_t* idx = &shape.mesh.indices[offset];
      offset += count;
      ++faces;
      if (count != 3) continue;  // triangulation left a degenerate polygon
      glm::vec3 p[3] = {position(idx[0].vertex_index), position(idx[1].vertex_index),
                        position(idx[2].vertex_index)};
      glm::vec3 face = glm::cross(p[1] - p[0], p[2] - p[0]);
      float area2 = glm::length(face);
      if (!(area2 > 0)) continue;  // zero-area triangles add nothing and have no normal
      face /= area2;
      int material = f < shape.mesh.material_ids.size() ? shape.mesh.material_ids[f] : -1;
      if (material >= int(model.materials.size())) material = -1;
      auto [it, added] = part_of_material.try_emplace(material, model.parts.size());
      if (added) {
        model.parts.push_back(ObjPart{material, {}});
        shared.emplace_back();
      }
      Mesh& mesh = model.parts[it->second].mesh;
      auto& cache = shared[it->second];
      glm::uvec3 tri;
      for (int k = 0; k < 3; ++k) {
        int ni = idx[k].normal_index;
        glm::vec3 n(0.0f);
        if (ni >= 0 && size_t(ni) < normal_count)
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
  if (faces == 0) fail_at(file, 0, "the OBJ file has no faces");
  if (model.parts.empty())
    fail_at(file, 0,
            fmt::format("all {} faces of the OBJ file have zero area: there is nothing to render",
                        faces));
  return model;
}

}  // namespace pb::scene
