#include "scene/gltf_import.h"

#include <fmt/format.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <limits>
#include <map>
#include <set>

#include "config/yaml_view.h"
#include "photonbench/error.h"

namespace pb::scene {

namespace fs = std::filesystem;

namespace {

// KHR_lights_punctual gives candela (lm/sr) and lux (lm/m^2); the harness's lights are radiometric.
// 683 lm/W is the luminous efficacy at 555 nm, the factor Blender's exporter uses the other way.
constexpr double kLumensPerWatt = 683.0;
// Above this, a node chain is an error rather than a scene (each node has one parent, no cycles).
constexpr size_t kMaxNodes = 1 << 20;
constexpr size_t kMaxSamplesPerTrack = 20000;
// All tracks together: many moving nodes over a long animation would otherwise take minutes.
constexpr size_t kMaxSamplesInAll = size_t(1) << 22;
const std::set<std::string> kHandledExtensions = {"KHR_lights_punctual",
                                                  "KHR_materials_transmission", "KHR_materials_ior",
                                                  "KHR_materials_emissive_strength"};

const char* kPathNames[3] = {"translation", "rotation", "scale"};

// One animation channel: keys and values (three per key for CUBICSPLINE: in-tangent, value,
// out-tangent), in glTF's order (a rotation is x, y, z, w).
struct Channel {
  enum class Mode { step, linear, cubic } mode = Mode::linear;
  bool rotation = false;
  std::vector<float> times;
  std::vector<glm::vec4> values;

  glm::vec4 value(size_t key) const { return values[mode == Mode::cubic ? 3 * key + 1 : key]; }
  glm::vec4 at(float t) const {
    const size_t n = times.size();
    if (n == 1 || t <= times.front()) return value(0);
    if (t >= times.back()) return value(n - 1);
    size_t i = size_t(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1;
    i = std::min(i, n - 2);
    const float dt = times[i + 1] - times[i];
    const float u = std::clamp((t - times[i]) / dt, 0.f, 1.f);
    glm::vec4 out;
    switch (mode) {
      case Mode::step:
        return value(i);
      case Mode::linear:
        if (rotation) {
          glm::quat a(value(i).w, value(i).x, value(i).y, value(i).z);
          glm::quat b(value(i + 1).w, value(i + 1).x, value(i + 1).y, value(i + 1).z);
          glm::quat q = glm::slerp(a, b, u);
          return {q.x, q.y, q.z, q.w};
        }
        out = glm::mix(value(i), value(i + 1), u);
        break;
      case Mode::cubic: {  // the specification's Hermite spline (Appendix C, "Cubic Spline")
        const float u2 = u * u, u3 = u2 * u;
        const glm::vec4 out_tangent = values[3 * i + 2], in_tangent = values[3 * (i + 1)];
        out = (2 * u3 - 3 * u2 + 1) * value(i) + dt * (u3 - 2 * u2 + u) * out_tangent +
              (-2 * u3 + 3 * u2) * value(i + 1) + dt * (u3 - u2) * in_tangent;
        break;
      }
    }
    if (rotation) out = glm::normalize(out);
    return out;
  }
};

// One integer component; a normalised one maps to [0, 1] (unsigned) or [-1, 1] (signed) as the
// specification's "Animations" section writes it: max(c / max, -1).
template <class T>
double component(const unsigned char* p, bool normalized) {
  T x;
  std::memcpy(&x, p, sizeof x);
  if (!normalized) return double(x);
  return std::max(double(x) / double(std::numeric_limits<T>::max()), -1.0);
}

struct LocalTransform {
  bool has_matrix = false;
  glm::mat4 matrix{1.0f};
  glm::vec3 translation{0.0f};
  glm::quat rotation{1, 0, 0, 0};
  glm::vec3 scale{1.0f};
};

class Importer {
 public:
  Importer(const tinygltf::Model& gltf, fs::path file, const GltfOptions& options)
      : m_(gltf), file_(std::move(file)), options_(options) {}

  GltfModel run() {
    check_counts();
    note_extensions();
    read_materials();
    read_nodes();
    read_animations();
    traverse_scene();
    for (size_t i : order_) {
      const tinygltf::Node& node = m_.nodes[i];
      if (node.mesh >= 0) add_mesh(i);
      if (node.skin >= 0)
        note(fmt::format("{}: skin {} (drawn in its bind pose)", node_name(i), node.skin));
      if (!node.weights.empty()) note(fmt::format("{}: morph-target weights", node_name(i)));
    }
    read_camera();
    read_lights();
    if (out_.objects.empty()) {
      std::string left_out;
      for (const auto& n : out_.unsupported) left_out += (left_out.empty() ? "" : "; ") + n;
      fail(
          fmt::format("the file has no triangles in its scene (no mesh primitive with triangle "
                      "faces){}",
                      left_out.empty() ? "" : "; left out: " + left_out));
    }
    return std::move(out_);
  }

 private:
  const tinygltf::Model& m_;
  fs::path file_;
  GltfOptions options_;
  GltfModel out_;
  std::vector<uint32_t> material_of_;  // glTF material -> index into out_.materials
  std::optional<uint32_t> default_material_;
  std::vector<LocalTransform> local_;
  std::vector<int> parent_;
  std::vector<size_t> order_;  // the scene's nodes, parents before children
  std::vector<std::array<std::optional<Channel>, 3>> channels_;  // per node: T, R, S
  std::vector<bool> moves_;
  size_t triangles_ = 0;
  mutable size_t samples_ = 0;
  std::set<std::string> noted_;
  std::set<std::string> object_names_;

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(fmt::format("{}: {}", file_.string(), what));
  }
  void note(const std::string& what) {
    if (noted_.insert(what).second) out_.unsupported.push_back(what);
  }
  std::string node_name(size_t i) const { return fmt::format("nodes[{}]", i); }

  // Finite and within kMaxMagnitude (or [lo, hi]).
  double number(double v, const std::string& where, double lo = -kMaxMagnitude,
                double hi = kMaxMagnitude) const {
    if (!std::isfinite(v)) fail(fmt::format("{}: {} is not a finite number", where, v));
    if (v < lo || v > hi) fail(fmt::format("{}: {} is outside [{}, {}]", where, v, lo, hi));
    return v;
  }
  glm::vec3 vec3_of(const std::vector<double>& v, const std::string& where, double lo, double hi,
                    glm::vec3 fallback) const {
    if (v.empty()) return fallback;
    if (v.size() != 3) fail(fmt::format("{}: expected 3 numbers, got {}", where, v.size()));
    glm::vec3 out;
    for (int k = 0; k < 3; ++k)
      out[k] = float(number(v[k], fmt::format("{}[{}]", where, k), lo, hi));
    return out;
  }

  void check_counts() {
    if (m_.nodes.size() > kMaxNodes)
      fail(fmt::format("nodes: {} nodes, more than the {} a scene may have", m_.nodes.size(),
                       kMaxNodes));
  }

  void note_extensions() {
    std::set<std::string> used(m_.extensionsUsed.begin(), m_.extensionsUsed.end());
    used.insert(m_.extensionsRequired.begin(), m_.extensionsRequired.end());
    for (const auto& name : used)
      if (!kHandledExtensions.count(name)) note(fmt::format("extension {}", name));
    if (m_.scenes.size() > 1)
      note(fmt::format("scenes: {} scenes, only the default one is loaded", m_.scenes.size()));
    if (!m_.skins.empty()) note(fmt::format("skins: {} (not skinned)", m_.skins.size()));
  }

  // ---- accessors ----

  // An accessor's elements as numbers, `components` per element (normalised integers mapped to
  // [0, 1] or [-1, 1] as the specification says); every check names `where` and the accessor.
  std::vector<double> accessor(int index, const std::string& where, int type,
                               std::initializer_list<int> component_types) const {
    if (index < 0 || size_t(index) >= m_.accessors.size())
      fail(fmt::format("{}: accessor {} out of range (the file has {})", where, index,
                       m_.accessors.size()));
    const tinygltf::Accessor& a = m_.accessors[index];
    const std::string at = fmt::format("{}: accessor {}", where, index);
    if (a.type != type) fail(fmt::format("{}: type {} where {} is needed", at, a.type, type));
    if (std::find(component_types.begin(), component_types.end(), a.componentType) ==
        component_types.end())
      fail(fmt::format("{}: componentType {} is not allowed here", at, a.componentType));
    if (a.sparse.isSparse) fail(fmt::format("{}: sparse accessors are not supported", at));
    if (a.bufferView < 0 || size_t(a.bufferView) >= m_.bufferViews.size())
      fail(fmt::format("{}: bufferView {} out of range (the file has {})", at, a.bufferView,
                       m_.bufferViews.size()));
    const tinygltf::BufferView& view = m_.bufferViews[a.bufferView];
    if (view.buffer < 0 || size_t(view.buffer) >= m_.buffers.size())
      fail(fmt::format("{}: bufferViews[{}]: buffer {} out of range (the file has {})", at,
                       a.bufferView, view.buffer, m_.buffers.size()));
    const std::vector<unsigned char>& data = m_.buffers[view.buffer].data;
    if (view.byteLength > data.size() || view.byteOffset > data.size() - view.byteLength)
      fail(fmt::format("{}: bufferViews[{}] (bytes {} + {}) reaches past buffer {} ({} bytes)", at,
                       a.bufferView, view.byteOffset, view.byteLength, view.buffer, data.size()));
    const int components = tinygltf::GetNumComponentsInType(uint32_t(type));
    const int size = tinygltf::GetComponentSizeInBytes(uint32_t(a.componentType));
    const size_t element = size_t(components) * size_t(size);
    const size_t stride = view.byteStride ? view.byteStride : element;
    if (stride < element || stride % size_t(size) != 0)
      fail(fmt::format("{}: byteStride {} does not hold a {}-byte element", at, stride, element));
    if (a.count == 0) fail(fmt::format("{}: count is 0", at));
    if (a.byteOffset > view.byteLength || element > view.byteLength - a.byteOffset ||
        (a.count - 1) > (view.byteLength - a.byteOffset - element) / stride)
      fail(fmt::format("{}: {} elements from byte {} reach past bufferViews[{}] ({} bytes)", at,
                       a.count, a.byteOffset, a.bufferView, view.byteLength));
    const unsigned char* base = data.data() + view.byteOffset + a.byteOffset;
    std::vector<double> out(a.count * size_t(components));
    for (size_t e = 0; e < a.count; ++e)
      for (int c = 0; c < components; ++c) {
        const unsigned char* p = base + e * stride + size_t(c) * size_t(size);
        double v = 0;
        switch (a.componentType) {
          case TINYGLTF_COMPONENT_TYPE_BYTE:
            v = component<int8_t>(p, a.normalized);
            break;
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            v = component<uint8_t>(p, a.normalized);
            break;
          case TINYGLTF_COMPONENT_TYPE_SHORT:
            v = component<int16_t>(p, a.normalized);
            break;
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
            v = component<uint16_t>(p, a.normalized);
            break;
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
            v = component<uint32_t>(p, false);
            break;
          default: {  // float
            float x;
            std::memcpy(&x, p, 4);
            if (!std::isfinite(x) || std::abs(x) > kMaxMagnitude)
              fail(
                  fmt::format("{}: element {} component {} = {} is not a finite number within "
                              "[-{}, {}]",
                              at, e, c, x, kMaxMagnitude, kMaxMagnitude));
            v = x;
          }
        }
        out[e * size_t(components) + size_t(c)] = v;
      }
    return out;
  }

  // ---- materials ----

  const tinygltf::Value* extension(const tinygltf::ExtensionMap& map, const std::string& name,
                                   const std::string& key) const {
    auto it = map.find(name);
    if (it == map.end() || !it->second.IsObject() || !it->second.Has(key)) return nullptr;
    return &it->second.Get(key);
  }
  double extension_number(const tinygltf::ExtensionMap& map, const std::string& name,
                          const std::string& key, double fallback, const std::string& where,
                          double lo, double hi) const {
    const tinygltf::Value* v = extension(map, name, key);
    if (!v) return fallback;
    const std::string at = fmt::format("{}: {}.{}", where, name, key);
    if (!v->IsNumber()) fail(fmt::format("{}: expected a number", at));
    return number(v->GetNumberAsDouble(), at, lo, hi);
  }

  Material material(const tinygltf::Material& g, const std::string& where) {
    Material out;
    out.name = g.name.empty() ? where : g.name;
    const auto& pbr = g.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() != 4)
      fail(fmt::format("{}: baseColorFactor has {} numbers, expected 4", where,
                       pbr.baseColorFactor.size()));
    glm::vec3 base;
    for (int k = 0; k < 3; ++k)
      base[k] = float(
          number(pbr.baseColorFactor[k], fmt::format("{}: baseColorFactor[{}]", where, k), 0, 1));
    number(pbr.baseColorFactor[3], where + ": baseColorFactor[3]", 0, 1);
    const double metallic = number(pbr.metallicFactor, where + ": metallicFactor", 0, 1);
    const double roughness = number(pbr.roughnessFactor, where + ": roughnessFactor", 0, 1);
    glm::vec3 emissive = vec3_of(g.emissiveFactor, where + ": emissiveFactor", 0, 1, glm::vec3(0));
    const double strength = extension_number(g.extensions, "KHR_materials_emissive_strength",
                                             "emissiveStrength", 1, where, 0, kMaxMagnitude);
    const double transmission = extension_number(g.extensions, "KHR_materials_transmission",
                                                 "transmissionFactor", 0, where, 0, 1);
    double ior = extension_number(g.extensions, "KHR_materials_ior", "ior", 1.5, where, 0, 1e3);
    // The specification's BRDF appendix squares the perceptual roughness into the GGX alpha.
    const float alpha = float(roughness * roughness);

    auto textured = [&](int texture, const char* what) {
      if (texture >= 0)
        note(fmt::format("{}: {} (not sampled; its factor is used alone)", where, what));
    };
    textured(pbr.baseColorTexture.index, "baseColorTexture");
    textured(pbr.metallicRoughnessTexture.index, "metallicRoughnessTexture");
    textured(g.emissiveTexture.index, "emissiveTexture");
    textured(g.normalTexture.index, "normalTexture");
    textured(g.occlusionTexture.index, "occlusionTexture");
    if (extension(g.extensions, "KHR_materials_transmission", "transmissionTexture"))
      textured(0, "transmissionTexture");
    if (g.alphaMode != "OPAQUE" && !g.alphaMode.empty())
      note(fmt::format("{}: alphaMode {} (drawn opaque)", where, g.alphaMode));
    for (const auto& [name, value] : g.extensions)
      if (!kHandledExtensions.count(name)) note(fmt::format("{}: extension {}", where, name));

    out.albedo = base;
    if (glm::any(glm::greaterThan(emissive * float(strength), glm::vec3(0)))) {
      out.type = MaterialType::emissive;
      out.emission = emissive * float(strength);
    } else if (transmission >= 0.5) {
      if (transmission < 1)
        note(fmt::format("{}: transmissionFactor {} taken as 1", where, transmission));
      if (ior < 1 || ior > 4) {
        note(fmt::format("{}: ior {} clamped to [1, 4]", where, ior));
        ior = std::clamp(ior, 1.0, 4.0);
      }
      out.ior = float(ior);
      out.type = alpha < 1e-3f ? MaterialType::dielectric : MaterialType::rough_dielectric;
      out.roughness = std::clamp(alpha, 1e-3f, 1.f);
    } else if (metallic >= 0.5) {
      if (metallic < 1) note(fmt::format("{}: metallicFactor {} taken as 1", where, metallic));
      out.specular = base;
      out.type = alpha < 1e-3f ? MaterialType::mirror : MaterialType::rough_conductor;
      out.roughness = std::clamp(alpha, 1e-3f, 1.f);
    } else {
      if (metallic > 0) note(fmt::format("{}: metallicFactor {} taken as 0", where, metallic));
      if (transmission > 0)
        note(fmt::format("{}: transmissionFactor {} taken as 0", where, transmission));
      out.type = MaterialType::diffuse;
    }
    return out;
  }

  void read_materials() {
    for (size_t i = 0; i < m_.materials.size(); ++i) {
      material_of_.push_back(uint32_t(out_.materials.size()));
      out_.materials.push_back(material(m_.materials[i], fmt::format("materials[{}]", i)));
    }
  }

  uint32_t material_for(int index, const std::string& where) {
    if (index >= 0) {
      if (size_t(index) >= material_of_.size())
        fail(fmt::format("{}: material {} out of range (the file has {})", where, index,
                         material_of_.size()));
      return material_of_[index];
    }
    if (!default_material_) {  // the specification's default material
      default_material_ = uint32_t(out_.materials.size());
      tinygltf::Material plain;
      out_.materials.push_back(material(plain, "default"));
      out_.materials.back().name = "default";
    }
    return *default_material_;
  }

  // ---- nodes ----

  void read_nodes() {
    local_.resize(m_.nodes.size());
    for (size_t i = 0; i < m_.nodes.size(); ++i) {
      const tinygltf::Node& n = m_.nodes[i];
      const std::string where = node_name(i);
      LocalTransform& l = local_[i];
      if (!n.matrix.empty()) {
        if (n.matrix.size() != 16)
          fail(fmt::format("{}: matrix has {} numbers, expected 16", where, n.matrix.size()));
        l.has_matrix = true;
        for (int k = 0; k < 16; ++k)
          l.matrix[k / 4][k % 4] =
              float(number(n.matrix[k], fmt::format("{}: matrix[{}]", where, k)));
      }
      l.translation = vec3_of(n.translation, where + ": translation", -kMaxMagnitude, kMaxMagnitude,
                              glm::vec3(0));
      l.scale = vec3_of(n.scale, where + ": scale", -kMaxMagnitude, kMaxMagnitude, glm::vec3(1));
      if (!n.rotation.empty()) {
        if (n.rotation.size() != 4)
          fail(fmt::format("{}: rotation has {} numbers, expected 4", where, n.rotation.size()));
        glm::vec4 q;
        for (int k = 0; k < 4; ++k)
          q[k] = float(number(n.rotation[k], fmt::format("{}: rotation[{}]", where, k), -2, 2));
        if (!(glm::length(q) > 1e-6f)) fail(where + ": rotation is not a unit quaternion");
        q = glm::normalize(q);
        l.rotation = glm::quat(q.w, q.x, q.y, q.z);
      }
    }
  }

  glm::mat4 local_at(size_t i, float t) const {
    const LocalTransform& l = local_[i];
    if (l.has_matrix) return l.matrix;
    glm::vec3 translation = l.translation, scale = l.scale;
    glm::quat rotation = l.rotation;
    if (options_.animate && i < channels_.size()) {
      const auto& c = channels_[i];
      if (c[0]) translation = glm::vec3(c[0]->at(t));
      if (c[1]) {
        glm::vec4 q = c[1]->at(t);
        rotation = glm::quat(q.w, q.x, q.y, q.z);
      }
      if (c[2]) scale = glm::vec3(c[2]->at(t));
    }
    return glm::translate(glm::mat4(1.0f), translation) * glm::mat4_cast(rotation) *
           glm::scale(glm::mat4(1.0f), scale);
  }

  glm::mat4 world_at(size_t i, float t) const {
    glm::mat4 w = local_at(i, t);
    for (int p = parent_[i]; p >= 0; p = parent_[p]) w = local_at(size_t(p), t) * w;
    return w;
  }

  void traverse_scene() {
    parent_.assign(m_.nodes.size(), -1);
    std::vector<int> roots;
    if (m_.scenes.empty()) {
      std::vector<bool> is_child(m_.nodes.size(), false);
      for (const auto& n : m_.nodes)
        for (int c : n.children)
          if (c >= 0 && size_t(c) < m_.nodes.size()) is_child[c] = true;
      for (size_t i = 0; i < m_.nodes.size(); ++i)
        if (!is_child[i]) roots.push_back(int(i));
    } else {
      const int scene = m_.defaultScene >= 0 ? m_.defaultScene : 0;
      if (size_t(scene) >= m_.scenes.size())
        fail(fmt::format("scene: {} out of range (the file has {})", scene, m_.scenes.size()));
      roots = m_.scenes[scene].nodes;
      for (int r : roots)
        if (r < 0 || size_t(r) >= m_.nodes.size())
          fail(fmt::format("scenes[{}]: node {} out of range (the file has {})", scene, r,
                           m_.nodes.size()));
    }
    std::vector<bool> seen(m_.nodes.size(), false);
    std::vector<size_t> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back(size_t(*it));
    for (int r : roots) {
      if (seen[r]) fail(fmt::format("{}: is in the scene twice", node_name(r)));
      seen[r] = true;
    }
    while (!stack.empty()) {
      size_t i = stack.back();
      stack.pop_back();
      order_.push_back(i);
      const auto& children = m_.nodes[i].children;
      for (auto it = children.rbegin(); it != children.rend(); ++it) {
        int c = *it;
        if (c < 0 || size_t(c) >= m_.nodes.size())
          fail(fmt::format("{}: child {} out of range (the file has {})", node_name(i), c,
                           m_.nodes.size()));
        if (seen[c])
          fail(fmt::format("{}: child {} has another parent or closes a cycle", node_name(i), c));
        seen[c] = true;
        parent_[c] = int(i);
        stack.push_back(size_t(c));
      }
    }
    moves_.assign(m_.nodes.size(), false);
    for (size_t i : order_) {  // parents first
      bool own = false;
      if (options_.animate)
        for (const auto& c : channels_[i]) own = own || c.has_value();
      moves_[i] = own || (parent_[i] >= 0 && moves_[parent_[i]]);
    }
  }

  // ---- animations ----

  Channel channel(size_t a, const tinygltf::AnimationChannel& ch, size_t c, int path) {
    const tinygltf::Animation& anim = m_.animations[a];
    const std::string where = fmt::format("animations[{}].channels[{}]", a, c);
    if (ch.sampler < 0 || size_t(ch.sampler) >= anim.samplers.size())
      fail(fmt::format("{}: sampler {} out of range (the animation has {})", where, ch.sampler,
                       anim.samplers.size()));
    const tinygltf::AnimationSampler& s = anim.samplers[ch.sampler];
    const std::string at = fmt::format("animations[{}].samplers[{}]", a, ch.sampler);
    Channel out;
    out.rotation = path == 1;
    out.mode = s.interpolation == "STEP"          ? Channel::Mode::step
               : s.interpolation == "CUBICSPLINE" ? Channel::Mode::cubic
               : s.interpolation == "LINEAR"
                   ? Channel::Mode::linear
                   : (fail(fmt::format("{}: interpolation '{}' is not LINEAR, STEP or CUBICSPLINE",
                                       at, config::quote(s.interpolation))),
                      Channel::Mode::linear);
    std::vector<double> times =
        accessor(s.input, at + ": input", TINYGLTF_TYPE_SCALAR, {TINYGLTF_COMPONENT_TYPE_FLOAT});
    for (size_t k = 0; k < times.size(); ++k) {
      number(times[k], fmt::format("{}: input key {}", at, k), 0, kMaxMagnitude);
      if (k > 0 && !(float(times[k]) > out.times.back()))
        fail(fmt::format("{}: input key {} ({} s) is not after the previous key", at, k, times[k]));
      out.times.push_back(float(times[k]));
    }
    const int type = out.rotation ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3;
    std::vector<double> values =
        out.rotation
            ? accessor(s.output, at + ": output", type,
                       {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                        TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                        TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT})
            : accessor(s.output, at + ": output", type, {TINYGLTF_COMPONENT_TYPE_FLOAT});
    const size_t width = out.rotation ? 4 : 3;
    const size_t expected = times.size() * (out.mode == Channel::Mode::cubic ? 3 : 1);
    if (values.size() != expected * width)
      fail(fmt::format("{}: output has {} values for {} keys, expected {}", at,
                       values.size() / width, times.size(), expected));
    for (size_t k = 0; k < expected; ++k) {
      glm::vec4 v(0.0f);
      for (size_t j = 0; j < width; ++j) v[int(j)] = float(values[k * width + j]);
      if (out.rotation && (out.mode != Channel::Mode::cubic || k % 3 == 1)) {
        if (!(glm::length(v) > 1e-6f))
          fail(fmt::format("{}: output key {} is not a unit quaternion", at, k));
        v = glm::normalize(v);
      }
      out.values.push_back(v);
    }
    return out;
  }

  void read_animations() {
    channels_.resize(m_.nodes.size());
    if (!options_.animate) {
      if (!m_.animations.empty()) note("animations: not played (animate: false)");
      return;
    }
    for (size_t a = 0; a < m_.animations.size(); ++a) {
      const auto& anim = m_.animations[a];
      for (size_t c = 0; c < anim.channels.size(); ++c) {
        const auto& ch = anim.channels[c];
        const std::string where = fmt::format("animations[{}].channels[{}]", a, c);
        int path = -1;
        for (int p = 0; p < 3; ++p)
          if (ch.target_path == kPathNames[p]) path = p;
        if (ch.target_node < 0) {
          note(where + ": a channel without a target node");
          continue;
        }
        if (size_t(ch.target_node) >= m_.nodes.size())
          fail(fmt::format("{}: target node {} out of range (the file has {})", where,
                           ch.target_node, m_.nodes.size()));
        if (path < 0) {
          if (ch.target_path == "weights") {
            note(where + ": morph-target weights");
            continue;
          }
          fail(fmt::format("{}: target path '{}' is not translation, rotation, scale or weights",
                           where, config::quote(ch.target_path)));
        }
        if (local_[ch.target_node].has_matrix) {
          note(fmt::format("{}: animates {}, which has a matrix (held still)", where,
                           node_name(ch.target_node)));
          continue;
        }
        auto& slot = channels_[ch.target_node][path];
        if (slot) {
          note(fmt::format("{}: a second channel for {}.{} (the first is played)", where,
                           node_name(ch.target_node), kPathNames[path]));
          continue;
        }
        slot = channel(a, ch, c, path);
        out_.duration = std::max(out_.duration, slot->times.back());
      }
    }
  }

  // The times at which a moving node's tracks are sampled: every key of the channels on its chain
  // and kGltfSampleRate between, over [0, last key].
  std::vector<float> sample_times(size_t node) const {
    std::vector<float> times = {0.f};
    float end = 0;
    for (int n = int(node); n >= 0; n = parent_[n])
      for (const auto& c : channels_[n])
        if (c) {
          times.insert(times.end(), c->times.begin(), c->times.end());
          end = std::max(end, c->times.back());
        }
    const double rate =
        std::min<double>(kGltfSampleRate, kMaxSamplesPerTrack / std::max(end, 1e-3f));
    for (size_t k = 1; double(k) / rate < end; ++k) times.push_back(float(double(k) / rate));
    times.push_back(end);
    std::sort(times.begin(), times.end());
    std::vector<float> out;
    for (float t : times)
      if (out.empty() || t > out.back() + 1e-5f) out.push_back(t);
    if (out.size() > 2 * kMaxSamplesPerTrack + 1)  // keys alone can be many
      out.resize(2 * kMaxSamplesPerTrack + 1);
    samples_ += out.size();
    if (samples_ > kMaxSamplesInAll)
      fail(
          fmt::format("animations: {} node(s) moving over {} s need more than {} sampled keys in "
                      "all",
                      std::count(moves_.begin(), moves_.end(), true), end, kMaxSamplesInAll));
    return out;
  }

  // W = T R S with R = Rz Ry Rx (TransformTrack's order), Euler angles near `previous`; false when
  // W shears (a non-uniform scale under a rotation) and has no such form.
  static bool decompose(const glm::mat4& w, glm::vec3& translation, glm::vec3& euler_deg,
                        glm::vec3& scale, const glm::vec3* previous) {
    translation = glm::vec3(w[3]);
    glm::mat3 r(w);
    for (int k = 0; k < 3; ++k) scale[k] = glm::length(r[k]);
    if (!(scale.x > 0 && scale.y > 0 && scale.z > 0)) return false;
    if (glm::determinant(r) < 0) scale.x = -scale.x;
    for (int k = 0; k < 3; ++k) r[k] /= scale[k];
    // R[row 2][col 0] = -sin(y); glm is column-major (r[col][row]).
    const float sy = std::clamp(-r[0][2], -1.f, 1.f);
    float x, y = std::asin(sy), z;
    if (std::abs(sy) < 0.99999f) {
      x = std::atan2(r[1][2], r[2][2]);
      z = std::atan2(r[0][1], r[0][0]);
    } else {  // gimbal lock: only x - z (or x + z) is defined; keep x at 0
      x = 0;
      z = std::atan2(-r[1][0], r[1][1]);
    }
    glm::vec3 e = glm::degrees(glm::vec3(x, y, z));
    if (previous) {
      auto unwrap = [&](glm::vec3 v) {
        for (int k = 0; k < 3; ++k) v[k] += 360.f * std::round(((*previous)[k] - v[k]) / 360.f);
        return v;
      };
      glm::vec3 a = unwrap(e), b = unwrap(glm::vec3(e.x + 180, 180 - e.y, e.z + 180));
      e = glm::length(a - *previous) <= glm::length(b - *previous) ? a : b;
    }
    euler_deg = e;
    TransformTrack check;
    check.translation.constant = translation;
    check.rotation_deg = e;
    check.scale = scale;
    const glm::mat4 rebuilt = check.at(0);
    float error = 0, size = 1e-6f;
    for (int c = 0; c < 4; ++c) {
      error = std::max(error, glm::length(rebuilt[c] - w[c]));
      size = std::max(size, glm::length(w[c]));
    }
    return error <= 1e-3f * size;
  }

  // A moving node's world transform as a TransformTrack of sampled keys; nullopt when it shears.
  std::optional<TransformTrack> transform_track(size_t node) const {
    TransformTrack track;
    track.translation.keys.interpolation = Interpolation::linear;
    const glm::vec3* previous = nullptr;
    glm::vec3 last_euler;
    for (float t : sample_times(node)) {
      glm::vec3 translation, euler, scale;
      if (!decompose(world_at(node, t), translation, euler, scale, previous)) return std::nullopt;
      track.translation.keys.times.push_back(t);
      track.translation.keys.values.push_back(translation);
      track.rotation_keys.times.push_back(t);
      track.rotation_keys.values.push_back(euler);
      track.scale_keys.times.push_back(t);
      track.scale_keys.values.push_back(scale);
      last_euler = euler;
      previous = &last_euler;
    }
    return track;
  }

  // ---- meshes ----

  std::string unique_name(std::string name) {
    std::string candidate = name;
    for (int k = 2; !object_names_.insert(candidate).second; ++k)
      candidate = fmt::format("{}#{}", name, k);
    return candidate;
  }

  void add_mesh(size_t node) {
    const int mesh_index = m_.nodes[node].mesh;
    if (size_t(mesh_index) >= m_.meshes.size())
      fail(fmt::format("{}: mesh {} out of range (the file has {})", node_name(node), mesh_index,
                       m_.meshes.size()));
    const tinygltf::Mesh& mesh = m_.meshes[mesh_index];
    std::optional<TransformTrack> track;
    bool bake = !moves_[node];
    if (!bake) {
      track = transform_track(node);
      if (!track) {
        note(fmt::format("{}: its animated transform shears (held at time 0)", node_name(node)));
        bake = true;
      }
    }
    const glm::mat4 world = world_at(node, 0);
    const std::string base = m_.nodes[node].name.empty()
                                 ? (mesh.name.empty() ? node_name(node) : mesh.name)
                                 : m_.nodes[node].name;
    for (size_t p = 0; p < mesh.primitives.size(); ++p) {
      const std::string where = fmt::format("meshes[{}].primitives[{}]", mesh_index, p);
      std::optional<Mesh> triangles = primitive(mesh.primitives[p], where);
      if (!triangles) continue;
      if (bake) bake_transform(*triangles, world, node_name(node));
      GltfObject object;
      object.name = unique_name(mesh.primitives.size() > 1 ? fmt::format("{}/{}", base, p) : base);
      object.mesh = std::move(*triangles);
      object.material = material_for(mesh.primitives[p].material, where);
      if (!bake) object.transform = *track;
      out_.objects.push_back(std::move(object));
    }
  }

  void bake_transform(Mesh& mesh, const glm::mat4& world, const std::string& where) const {
    const glm::mat3 normal_matrix = glm::transpose(glm::inverse(glm::mat3(world)));
    for (auto& p : mesh.positions) {
      p = glm::vec3(world * glm::vec4(p, 1));
      if (!(glm::all(glm::lessThanEqual(glm::abs(p), glm::vec3(float(kMaxMagnitude))))))
        fail(fmt::format("{}: its world transform takes a vertex beyond {} (or to NaN)", where,
                         kMaxMagnitude));
    }
    for (auto& n : mesh.normals) {
      glm::vec3 t = normal_matrix * n;
      n = glm::length(t) > 0 && std::isfinite(glm::length(t)) ? glm::normalize(t) : n;
    }
    // A mirroring transform reverses the winding (the specification's rule for det < 0).
    if (glm::determinant(glm::mat3(world)) < 0)
      for (auto& t : mesh.triangles) std::swap(t.y, t.z);
  }

  std::optional<Mesh> primitive(const tinygltf::Primitive& prim, const std::string& where) {
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN) {
      if (mode >= 0 && mode <= 3) {
        note(fmt::format("{}: mode {} (points or lines, skipped)", where, mode));
        return std::nullopt;
      }
      fail(fmt::format("{}: mode {} is not a glTF primitive mode (0 to 6)", where, mode));
    }
    if (!prim.targets.empty()) note(where + ": morph targets (the base shape is drawn)");
    if (prim.attributes.count("COLOR_0")) note(where + ": vertex colours");
    auto position_it = prim.attributes.find("POSITION");
    if (position_it == prim.attributes.end()) fail(where + ": no POSITION attribute");
    const std::vector<double> positions =
        accessor(position_it->second, where + ": POSITION", TINYGLTF_TYPE_VEC3,
                 {TINYGLTF_COMPONENT_TYPE_FLOAT});
    const size_t vertices = positions.size() / 3;
    std::vector<double> normals;
    if (auto it = prim.attributes.find("NORMAL"); it != prim.attributes.end()) {
      normals = accessor(it->second, where + ": NORMAL", TINYGLTF_TYPE_VEC3,
                         {TINYGLTF_COMPONENT_TYPE_FLOAT});
      if (normals.size() != positions.size())
        fail(fmt::format("{}: NORMAL has {} elements, POSITION {}", where, normals.size() / 3,
                         vertices));
    }
    std::vector<uint32_t> indices;
    if (prim.indices >= 0) {
      const std::vector<double> raw =
          accessor(prim.indices, where + ": indices", TINYGLTF_TYPE_SCALAR,
                   {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                    TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
      indices.reserve(raw.size());
      for (size_t k = 0; k < raw.size(); ++k) {
        if (raw[k] >= double(vertices))
          fail(fmt::format("{}: indices[{}] = {} out of range (POSITION has {} vertices)", where, k,
                           raw[k], vertices));
        indices.push_back(uint32_t(raw[k]));
      }
    } else {
      indices.resize(vertices);
      for (size_t k = 0; k < vertices; ++k) indices[k] = uint32_t(k);
    }
    // Corners of the triangle list.
    std::vector<glm::uvec3> corners;
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      for (size_t k = 0; k + 2 < indices.size(); k += 3)
        corners.push_back({indices[k], indices[k + 1], indices[k + 2]});
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (size_t k = 0; k + 2 < indices.size(); ++k)
        corners.push_back(k % 2 == 0 ? glm::uvec3(indices[k], indices[k + 1], indices[k + 2])
                                     : glm::uvec3(indices[k + 1], indices[k], indices[k + 2]));
    } else {
      for (size_t k = 1; k + 1 < indices.size(); ++k)
        corners.push_back({indices[0], indices[k], indices[k + 1]});
    }
    auto position = [&](uint32_t v) {
      return glm::vec3(float(positions[3 * v]), float(positions[3 * v + 1]),
                       float(positions[3 * v + 2]));
    };
    Mesh mesh;
    if (normals.empty()) {
      // No normals: flat shading, as the specification asks of a client ("3.7.2.1").
      for (const auto& c : corners) {
        glm::vec3 p[3] = {position(c.x), position(c.y), position(c.z)};
        glm::vec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
        if (!(glm::length(n) > 0)) continue;
        n = glm::normalize(n);
        const uint32_t first = uint32_t(mesh.positions.size());
        for (auto& q : p) mesh.positions.push_back(q), mesh.normals.push_back(n);
        mesh.triangles.push_back({first, first + 1, first + 2});
      }
    } else {
      // The given normals; a zero one takes the area-weighted normal of its faces instead.
      std::vector<glm::vec3> face_sum(vertices, glm::vec3(0));
      for (const auto& c : corners) {
        glm::vec3 n = glm::cross(position(c.y) - position(c.x), position(c.z) - position(c.x));
        if (!(glm::length(n) > 0)) continue;
        for (uint32_t v : {c.x, c.y, c.z}) face_sum[v] += n;
        mesh.triangles.push_back(c);
      }
      mesh.positions.reserve(vertices);
      for (uint32_t v = 0; v < vertices; ++v) {
        mesh.positions.push_back(position(v));
        glm::vec3 n{float(normals[3 * v]), float(normals[3 * v + 1]), float(normals[3 * v + 2])};
        if (!(glm::length(n) > 1e-12f)) n = face_sum[v];
        mesh.normals.push_back(glm::length(n) > 0 ? glm::normalize(n) : glm::vec3(0, 1, 0));
      }
    }
    if (mesh.triangles.empty()) {
      note(where + ": no triangle with a non-zero area (skipped)");
      return std::nullopt;
    }
    triangles_ += mesh.triangles.size();
    if (triangles_ > kMaxSceneTriangles)
      fail(fmt::format("{}: the scene reaches {} triangles here, more than the {} a scene may have",
                       where, triangles_, kMaxSceneTriangles));
    return mesh;
  }

  // ---- camera and lights ----

  // The first node of the scene that carries camera `index` / light `index`.
  std::vector<size_t> nodes_with(auto predicate) const {
    std::vector<size_t> out;
    for (size_t i : order_)
      if (predicate(m_.nodes[i])) out.push_back(i);
    return out;
  }

  struct Pose {
    PositionTrack position, target;
    glm::vec3 forward, up;
  };
  // A node's position, a point one unit down its -z, and its +y at time 0; keyframed when it moves.
  Pose pose(size_t node) const {
    Pose out;
    auto at = [&](float t, glm::vec3& p, glm::vec3& forward, glm::vec3& up) {
      const glm::mat4 w = world_at(node, t);
      p = glm::vec3(w[3]);
      forward = glm::mat3(w) * glm::vec3(0, 0, -1);
      up = glm::mat3(w) * glm::vec3(0, 1, 0);
      if (!(glm::length(forward) > 1e-12f) || !(glm::length(up) > 1e-12f) ||
          !std::isfinite(glm::length(forward) + glm::length(up) + glm::length(p)))
        fail(fmt::format("{}: its world transform collapses the view direction", node_name(node)));
      forward = glm::normalize(forward);
      up = glm::normalize(up);
    };
    glm::vec3 p;
    at(0, p, out.forward, out.up);
    out.position.constant = p;
    out.target.constant = p + out.forward;
    if (!moves_[node]) return out;
    for (float t : sample_times(node)) {
      glm::vec3 forward, up;
      at(t, p, forward, up);
      out.position.keys.times.push_back(t);
      out.position.keys.values.push_back(p);
      out.target.keys.times.push_back(t);
      out.target.keys.values.push_back(p + forward);
    }
    return out;
  }

  void read_camera() {
    if (m_.cameras.empty()) return;
    const int index = options_.camera;
    if (index < 0 || size_t(index) >= m_.cameras.size())
      fail(fmt::format("camera {} out of range (the file has {})", index, m_.cameras.size()));
    const tinygltf::Camera& cam = m_.cameras[index];
    const std::string where = fmt::format("cameras[{}]", index);
    if (cam.type != "perspective") {
      note(fmt::format("{}: {} camera (only perspective ones are read)", where, cam.type));
      return;
    }
    auto carriers = nodes_with([&](const tinygltf::Node& n) { return n.camera == index; });
    if (carriers.empty()) {
      note(where + ": on no node of the scene (not used)");
      return;
    }
    const auto& pc = cam.perspective;
    CameraTrack c;
    c.where = fmt::format("{}: {}", file_.string(), where);
    c.fov_y_deg = float(glm::degrees(
        number(pc.yfov, where + ": yfov (radians)", glm::radians(1.0), glm::radians(179.0))));
    c.near_plane = float(number(pc.znear, where + ": znear", 1e-6, kMaxMagnitude));
    c.far_plane = pc.zfar > 0 ? float(number(pc.zfar, where + ": zfar", 1e-6, kMaxMagnitude))
                              : std::max(1000.f, 1e4f * c.near_plane);
    if (!(c.far_plane > c.near_plane))
      fail(fmt::format("{}: zfar ({}) must exceed znear ({})", where, pc.zfar, pc.znear));
    if (pc.aspectRatio > 0) note(where + ": aspectRatio (the config's resolution sets the aspect)");
    Pose p = pose(carriers[0]);
    c.position = p.position;
    c.target = p.target;
    c.up = p.up;
    if (moves_[carriers[0]]) {
      // The harness's camera keeps one up vector: a camera that rolls is flagged.
      for (float t : sample_times(carriers[0])) {
        const glm::mat4 w = world_at(carriers[0], t);
        const glm::vec3 up = glm::normalize(glm::mat3(w) * glm::vec3(0, 1, 0));
        const glm::vec3 forward = glm::normalize(glm::mat3(w) * glm::vec3(0, 0, -1));
        const glm::vec3 right = glm::cross(forward, c.up);
        if (glm::length(right) < 1e-3f ||
            std::abs(glm::dot(glm::normalize(right), up)) > std::sin(glm::radians(1.f))) {
          note(fmt::format("{}: the camera rolls (its up at time 0 is kept)",
                           node_name(carriers[0])));
          break;
        }
      }
    }
    out_.camera = std::move(c);
  }

  void read_lights() {
    std::set<std::string> names;
    for (size_t i : order_) {
      const tinygltf::Node& node = m_.nodes[i];
      auto ext = node.extensions.find("KHR_lights_punctual");
      if (ext == node.extensions.end()) continue;
      const std::string where = node_name(i) + ": KHR_lights_punctual";
      if (!ext->second.IsObject() || !ext->second.Has("light") || !ext->second.Get("light").IsInt())
        fail(where + ": expected {\"light\": <index>}");
      const int index = ext->second.Get("light").GetNumberAsInt();
      if (index < 0 || size_t(index) >= m_.lights.size())
        fail(fmt::format("{}: light {} out of range (the file has {})", where, index,
                         m_.lights.size()));
      const tinygltf::Light& g = m_.lights[index];
      const std::string at = fmt::format("lights[{}]", index);
      LightTrack track;
      Light& light = track.light;
      std::string name = g.name.empty() ? at : g.name;
      for (int k = 2; !names.insert(name).second; ++k)
        name = fmt::format("{}#{}", g.name.empty() ? at : g.name, k);
      light.name = name;
      track.where = fmt::format("{}: {} ({})", file_.string(), at, node_name(i));
      const glm::vec3 color = vec3_of(g.color, at + ": color", 0, 1e3, glm::vec3(1));
      const double intensity = number(g.intensity, at + ": intensity", 0, kMaxMagnitude);
      light.radiant = color * float(intensity / kLumensPerWatt);
      if (g.range > 0) note(at + ": range (lights fall off with the inverse square alone)");
      Pose p = pose(i);
      track.position = p.position;
      light.position = p.position.constant;
      light.direction = p.forward;
      if (g.type == "point") {
        light.type = LightType::point;
      } else if (g.type == "spot" || g.type == "directional") {
        light.type = g.type == "spot" ? LightType::spot : LightType::directional;
        if (moves_[i]) track.target = p.target;
        if (g.type == "spot") {
          const double inner = number(g.spot.innerConeAngle, at + ": spot.innerConeAngle", 0,
                                      glm::half_pi<double>());
          const double outer = number(g.spot.outerConeAngle, at + ": spot.outerConeAngle", 0,
                                      glm::half_pi<double>());
          if (!(inner < outer))
            fail(fmt::format("{}: spot.innerConeAngle ({}) must be below outerConeAngle ({})", at,
                             inner, outer));
          // The harness's spot cone stops short of a hemisphere (scenes/README.md, spot).
          light.spot_outer = std::clamp(float(outer), glm::radians(0.1f), glm::radians(89.9f));
          light.spot_inner = std::min(float(inner), std::min(glm::radians(89.f), light.spot_outer));
          if (outer > glm::radians(89.9))
            note(fmt::format("{}: spot.outerConeAngle {} rad narrowed to 89.9 degrees", at, outer));
        }
      } else {
        fail(fmt::format("{}: type '{}' is not point, spot or directional", at,
                         config::quote(g.type)));
      }
      out_.lights.push_back(std::move(track));
    }
  }
};

// tinygltf's file access goes through these, so that a buffer a .gltf names is read with the
// harness's size limit (and the fuzz target reads none).
struct FileAccess {
  const GltfSource* source;
};
bool file_exists(const std::string& path, void* user) {
  return (*static_cast<FileAccess*>(user)->source)(path).has_value();
}
std::string expand_path(const std::string& path, void*) { return path; }
bool read_whole_file(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                     void* user) {
  std::optional<std::string> bytes = (*static_cast<FileAccess*>(user)->source)(path);
  if (!bytes) {
    if (err) *err += fmt::format("file '{}' not found\n", path);
    return false;
  }
  out->assign(bytes->begin(), bytes->end());
  return true;
}
bool write_whole_file(std::string* err, const std::string&, const std::vector<unsigned char>&,
                      void*) {
  if (err) *err += "writing is not supported\n";
  return false;
}
// Images are not decoded: the harness's materials have no textures (their use is noted instead),
// and no decoder sees bytes it does not need.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                const unsigned char*, int, void*) {
  return true;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (auto& c : s)
    if (c == '\n') c = ';';
  return s;
}

}  // namespace

bool is_gltf_path(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == ".gltf" || ext == ".glb";
}

GltfModel parse_gltf(const std::string& bytes, const fs::path& file, const GltfSource& read_uri,
                     const GltfOptions& options) {
  tinygltf::TinyGLTF loader;
  FileAccess access{&read_uri};
  loader.SetFsCallbacks({&file_exists, &expand_path, &read_whole_file, &write_whole_file, &access});
  loader.SetImageLoader(&skip_image, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  bool ok = false;
  const bool binary = bytes.size() >= 4 && bytes.compare(0, 4, "glTF") == 0;
  try {
    ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn,
                                              reinterpret_cast<const unsigned char*>(bytes.data()),
                                              unsigned(bytes.size()), "")
                : loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(),
                                             unsigned(bytes.size()), "");
  } catch (const std::exception& e) {  // nlohmann::json's type errors on a malformed document
    throw InputError(fmt::format("{}: not a glTF file: {}", file.string(), e.what()));
  }
  if (!ok || !err.empty())
    throw InputError(fmt::format("{}: {}", file.string(),
                                 err.empty() ? "cannot read the glTF file" : trimmed(err)));
  return Importer(model, file, options).run();
}

GltfModel load_gltf(const fs::path& file, const GltfOptions& options) {
  const fs::path directory = file.parent_path();
  // A .glb is binary: read_text_file reads bytes as they are (it only checks the size and kind).
  const std::string bytes = config::read_text_file(file, kMaxGltfBytes, "glTF file");
  return parse_gltf(
      bytes, file,
      [&](const std::string& uri) -> std::optional<std::string> {
        std::error_code ec;
        const fs::path path = directory / uri;
        if (!fs::is_regular_file(path, ec)) return std::nullopt;
        return config::read_text_file(path, kMaxGltfBytes, "glTF buffer");
      },
      options);
}

std::string unsupported_warning(const fs::path& file, const GltfModel& model) {
  if (model.unsupported.empty()) return "";
  constexpr size_t kListed = 24;
  std::string list;
  for (size_t i = 0; i < std::min(model.unsupported.size(), kListed); ++i)
    list += (list.empty() ? "" : "; ") + model.unsupported[i];
  if (model.unsupported.size() > kListed)
    list += fmt::format("; and {} more", model.unsupported.size() - kListed);
  return fmt::format("warning: {}: glTF features left out or approximated: {}", file.string(),
                     list);
}

}  // namespace pb::scene
