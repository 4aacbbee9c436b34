// glTF 2.0 import (Khronos glTF 2.0 specification) through Debian's tinygltf: a .gltf (JSON, with
// external or data-URI buffers) or .glb file becomes scene objects, materials, lights, a camera and
// animation tracks in the harness's own terms.
//
// Mapping (scenes/README.md, "glTF scenes"):
//   mesh primitives (triangles, strips, fans) -> one object each, normals from NORMAL or, where the
//     primitive has none, flat (the specification's rule); a node that never moves has its world
//     matrix baked into the vertices, a moving one keeps its mesh and gets a TransformTrack;
//   materials (metallic-roughness, alpha = roughness^2 as in the specification's BRDF appendix):
//     emissiveFactor x KHR_materials_emissive_strength > 0 -> emissive (radiance), albedo = base
//     KHR_materials_transmission >= 0.5 -> dielectric (alpha < 1e-3) or rough_dielectric, ior
//       from KHR_materials_ior (1.5 without it)
//     metallicFactor >= 0.5 -> mirror (alpha < 1e-3) or rough_conductor, F0 = base colour
//     otherwise -> diffuse, albedo = base colour;
//   KHR_lights_punctual point, spot and directional lights, at their node's position and looking
//     down its -z; photometric quantities (cd, lx) to radiometric ones (W/sr, W/m^2) at 683 lm/W;
//   the first perspective camera (or the one asked for), looking down its node's -z with +y up;
//   node animations (translation, rotation, scale; every animation of the file plays at once)
//     sampled to keyframes of the harness's linear tracks.
// Everything else the file uses (textures, skins, morph targets, other extensions, ...) is listed
// in GltfModel::unsupported, which the scene loader prints as one warning.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace pb::scene {

// A glTF file is at most this large (a .glb with its buffers, or a .gltf and each buffer it names).
inline constexpr size_t kMaxGltfBytes = size_t(256) << 20;
// Animation tracks are sampled at this rate (and at every key) into the harness's linear keyframes,
// so that a rotation's spherical interpolation and a cubic spline are followed closely.
inline constexpr float kGltfSampleRate = 60.f;

struct GltfObject {
  std::string name;  // "<node name or nodes[i]>/<primitive index>"
  Mesh mesh;
  uint32_t material = 0;  // index into GltfModel::materials
  TransformTrack transform;
};

struct GltfModel {
  std::vector<Material> materials;
  std::vector<GltfObject> objects;
  std::vector<LightTrack> lights;
  std::optional<CameraTrack> camera;
  float duration = 0;  // seconds: the last key of any animation channel used
  // One entry per feature of the file the import leaves out or approximates, naming its element.
  std::vector<std::string> unsupported;
};

struct GltfOptions {
  int camera = 0;  // which glTF camera (index into `cameras`) becomes the scene's camera
  bool animate = true;
};

// Reads an external buffer (or image) a .gltf names by URI, relative to the file; nullopt when
// there is no such file.
using GltfSource = std::function<std::optional<std::string>(const std::string& uri)>;

// Throws pb::InputError "<file>: <element>: what is wrong", e.g. "<file>: meshes[3].primitives[0]:
// accessor 7 out of range": JSON or binary-container errors, indices out of range, accessors that
// reach past their buffer, values that are not finite or outside scene::kMaxMagnitude, a file with
// no triangles.
GltfModel parse_gltf(const std::string& bytes, const std::filesystem::path& file,
                     const GltfSource& read_uri, const GltfOptions& options = {});
GltfModel load_gltf(const std::filesystem::path& file, const GltfOptions& options = {});

// True for a path the scene loader reads as glTF (.gltf or .glb, any case).
bool is_gltf_path(const std::filesystem::path& file);

// The one warning about GltfModel::unsupported ("" when it is empty).
std::string unsupported_warning(const std::filesystem::path& file, const GltfModel& model);

}  // namespace pb::scene
