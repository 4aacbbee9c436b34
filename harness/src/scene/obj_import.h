// Wavefront OBJ + MTL import through tinyobjloader, split into one triangle mesh per material so
// that each part is an ordinary scene object with one material.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace pb::scene {

struct ObjPart {
  int material = -1;  // index into ObjModel::materials; -1: faces with no `usemtl`
  Mesh mesh;
};

struct ObjModel {
  std::vector<Material> materials;  // named as in the MTL file, mapped by material_from_mtl's rules
  std::vector<ObjPart> parts;       // in order of the materials' first use in the file
};

// Throws pb::InputError "<obj file>:<line>: what is wrong" (the line when it is known): a missing
// or unreadable file, a malformed face, a face index out of range, a coordinate that is not a
// finite number within scene::kMaxMagnitude, a missing MTL file, an unknown `usemtl`, an MTL value
// out of its range ("<mtl file>:<line>"), a file whose faces all have zero area.
ObjModel load_obj(const std::filesystem::path& file);

// The same from an OBJ file's text; `read_mtl(name)` gives the text of the file an `mtllib` names,
// or nullopt when there is no such file.
using MtlSource = std::function<std::optional<std::string>(const std::string& name)>;
ObjModel parse_obj(const std::string& text, const std::filesystem::path& file,
                   const MtlSource& read_mtl);

// MTL -> Material (the MTL spec's illumination models, Wavefront "MTL material format" / Ramsey
// 1995):
//   Ke > 0                            -> emissive, emission = Ke (radiance), albedo = Kd
//   d < 1, or illum 4, 6 or 7         -> dielectric, ior = Ni (1.5 when Ni is absent or <= 1)
//   illum 3 or 5 with Ks > 0          -> mirror, specular = Ks
//   otherwise                         -> diffuse, albedo = Kd
struct MtlValues {
  std::string name;
  glm::vec3 kd{0.8f}, ks{0.0f}, ke{0.0f};
  float ni = 1.0f, dissolve = 1.0f;
  int illum = 2;
};
Material material_from_mtl(const MtlValues& mtl);

}  // namespace pb::scene
