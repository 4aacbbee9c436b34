// The scene: what a YAML file under scenes/ describes, in physical units, with every shape
// already tessellated to triangles (one mechanism for Embree, the GPU and the reference renderer
// alike), and the animation that turns a frame number into a FrameState. time = frame / fps, so
// any frame is reproducible on its own without playing the frames before it.
//
// Units: lengths in metres (scene units), angles in degrees in files and radians here, light
// quantities in watts (see Light). Right-handed, y up; the camera looks down -z in its own frame.
#pragma once

#include <filesystem>
#include <glm/glm.hpp>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "scene/animation.h"

namespace pb::scene {

// Every number in a scene file (and in an OBJ or MTL file it names) lies in [-kMaxMagnitude,
// kMaxMagnitude] unless its key documents a narrower range (scenes/README.md): coordinates and
// lengths in metres, times in seconds, angles in degrees, light quantities. A scene therefore
// stays far inside what Embree traces (|x| <= 1.8e18, finite) even after its transforms compose.
inline constexpr double kMaxMagnitude = 1e6;
// A scene tessellates to at most this many triangles (the shipped ones stay below 60000).
inline constexpr size_t kMaxSceneTriangles = size_t(1) << 24;
// Scene, config and MTL files are YAML-sized (config::kMaxYamlBytes); an OBJ file is at most this.
inline constexpr size_t kMaxObjBytes = size_t(256) << 20;

enum class MaterialType {
  diffuse,           // Lambertian, `albedo`
  mirror,            // perfect specular reflection, tinted by `specular`
  dielectric,        // smooth glass/water: Fresnel reflection + refraction, `ior`
  rough_conductor,   // GGX microfacet metal, `roughness` (alpha), `specular` as F0 (Schlick)
  rough_dielectric,  // GGX microfacet glass, `roughness`, `ior`
  emissive,          // diffuse emitter: `emission` (radiance, W/m^2/sr) plus a Lambertian `albedo`
};

struct Material {
  std::string name;
  MaterialType type = MaterialType::diffuse;
  glm::vec3 albedo{0.8f};    // diffuse reflectance
  glm::vec3 specular{1.0f};  // mirror tint / conductor F0
  glm::vec3 emission{0.0f};  // radiance, W/(m^2 sr)
  float ior = 1.5f;          // inside / outside
  float roughness = 0.1f;    // GGX alpha
  bool is_specular() const {
    return type == MaterialType::mirror || type == MaterialType::dielectric;
  }
};

enum class LightType { point, spot, directional, quad, disc };

// `radiant` is the light's defining quantity, RGB:
//   point, spot: radiant intensity I in W/sr (power of a point light = 4 pi I);
//   directional: irradiance E in W/m^2 on a plane facing the light;
//   quad, disc: emitted radiance L in W/(m^2 sr) from the side facing `normal()` (power = pi L
//   area; a disc's area is pi radius^2).
struct Light {
  std::string name;
  LightType type = LightType::point;
  glm::vec3 radiant{1.0f};
  glm::vec3 position{0.0f};               // point, spot; quad: one corner; disc: the centre
  glm::vec3 direction{0, -1, 0};          // spot axis, directional propagation direction (unit)
  float spot_inner = glm::radians(30.f);  // full intensity inside this half-angle (radians)
  float spot_outer = glm::radians(40.f);  // zero outside this half-angle, smooth between
  // quad: position + s edge_u + t edge_v, s,t in [0,1]; disc: two orthogonal radii of length
  // `radius`, so the disc is position + rho (cos(phi) edge_u + sin(phi) edge_v), rho in [0, 1].
  glm::vec3 edge_u{1, 0, 0}, edge_v{0, 0, 1};
  glm::vec3 normal() const { return glm::normalize(glm::cross(edge_u, edge_v)); }
  float area() const;
  // quad, disc: the point at emission-domain coordinates uv in [0,1]^2, equal-area (uniform uv is
  // uniform on the surface; photons.h, EmissionDensity), and its derivatives in u and v if asked.
  // The disc's mapping is polar: rho = sqrt(u), phi = 2 pi v.
  glm::vec3 surface_point(glm::vec2 uv, glm::vec3* dp_du = nullptr,
                          glm::vec3* dp_dv = nullptr) const;
};

// A light and how it moves: its position (point, spot; a quad's corner or a disc's centre, moving
// its whole surface), for spot and directional lights an optional aim point that sets `direction`
// each frame, and optionally its power over time.
struct LightTrack {
  Light light;
  PositionTrack position;
  std::optional<PositionTrack> target;
  // The light's quantity over time, keyframed in the file (`power: {keys: ...}`, or intensity,
  // irradiance, radiance) and kept in Light::radiant's unit before `color`: radiant at time t is
  // color x power.at(t), never below 0 (a Catmull-Rom curve may overshoot its keys). Empty: the
  // constant light.radiant. Its area never changes, so watts and radiance keep one ratio.
  Keyframes<float> power;
  glm::vec3 color{1.0f};
  std::string where;  // "file:line:col: lights[i]", for errors about the light at some frame
  Light at(float time) const;
};

struct Camera {
  glm::vec3 position{0, 1, 3};
  glm::vec3 target{0, 1, 0};
  glm::vec3 up{0, 1, 0};
  float fov_y = glm::radians(45.f);  // vertical field of view
  float near_plane = 0.01f, far_plane = 100.f;
  glm::mat4 view() const;
  glm::mat4 projection(float aspect) const;  // Vulkan clip space: y down, depth [0, 1]
};

// Triangles in object space. Normals are per vertex (smooth shading); flat shapes repeat vertices.
struct Mesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;
  std::vector<glm::uvec3> triangles;
  size_t triangle_count() const { return triangles.size(); }
};

// A shape knows how to tessellate itself, and may change over time (the pool's water surface):
// then `animated()` is true and `tessellate(t)` gives the surface at time t. Rigid motion is the
// object's transform track instead, so a moving rigid object is never re-tessellated.
class Shape {
 public:
  virtual ~Shape() = default;
  virtual Mesh tessellate(float time) const = 0;
  virtual bool animated() const { return false; }
  virtual std::string kind() const = 0;  // "sphere", "obj", ...
};

struct Object {
  std::string name;
  std::shared_ptr<const Shape> shape;
  Mesh mesh;                 // shape->tessellate(0)
  uint32_t material = 0;     // index into Scene::materials
  TransformTrack transform;  // object -> world over time
  bool moves() const { return transform.animated() || shape->animated(); }
};

// Everything that changes with time, resolved for one frame.
struct FrameState {
  uint32_t frame = 0;
  float time = 0;  // seconds = frame / fps
  Camera camera;
  std::vector<Light> lights;
  std::vector<glm::mat4> object_to_world;  // one per Scene::objects
  std::vector<uint32_t>
      deformed_objects;  // indices of objects whose mesh changed shape at this time
};

struct Scene {
  std::string name;            // file stem, e.g. "cornell-box"
  std::filesystem::path file;  // where it was loaded from
  std::string purpose;         // what the experiment needs it for (the file's `purpose` key)
  float fps = 30.f;
  uint32_t default_frames = 32;  // the length of its default animation
  CameraTrack camera;
  std::vector<LightTrack> lights;
  std::vector<Material> materials;
  std::vector<Object> objects;

  FrameState at(uint32_t frame) const;
  // The mesh of object `i` at `time`: the stored mesh unless the shape is animated.
  Mesh mesh_at(size_t i, float time) const;
  // Axis-aligned bounds of the whole scene at time 0 in world space (directional lights cover it).
  std::pair<glm::vec3, glm::vec3> bounds() const;
};

// Loads a scene file; every error is a pb::InputError naming file:line:col and key. The camera and
// the lights are checked at every frame of the default animation (check_frames).
Scene load_scene(const std::filesystem::path& file);
// The same from the text of `file` (OBJ files are found relative to its folder).
Scene parse_scene(const std::string& text, const std::filesystem::path& file);

// Throws pb::InputError "<file:line:col>: camera: at frame N (t = T s): ..." when the camera or a
// light cannot be rendered at a frame: the camera on its target or looking along `up`, a spot or
// directional light aimed at its own position. Such a frame has no view (NaN rays: Embree aborts
// on them, the rasteriser draws nothing). Checks frames first..last (inclusive), evaluating only
// the camera's and the lights' tracks.
void check_frames(const Scene& scene, uint32_t first, uint32_t last);
// The same for one resolved frame, and every value in it finite: the check the ray tracer makes
// before it traces a frame (trace::EmbreeScene), whoever built the state.
void check_frame_state(const Scene& scene, const FrameState& state);

// Finds a scene by name (searching scenes/ of the source tree and `search_dirs`) or by path.
std::filesystem::path find_scene(const std::string& name_or_path,
                                 const std::vector<std::filesystem::path>& search_dirs);

// The names find_scene resolves: the stems of *.yaml / *.yml in `search_dirs` and the source tree's
// scenes/, sorted, each once.
std::vector<std::string> list_scenes(const std::vector<std::filesystem::path>& search_dirs);

}  // namespace pb::scene
