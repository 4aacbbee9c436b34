// Reading a scene file (the format is documented at the top of scenes/README.md). Every mapping
// declares its keys, so a misspelt key is an error naming file:line:col and the key path rather
// than a silently ignored setting; every number is range-checked where it is read, within
// kMaxMagnitude unless its key has a narrower range.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/constants.hpp>
#include <map>
#include <set>

#include "config/config.h"
#include "config/yaml_view.h"
#include "photonbench/error.h"
#include "scene/obj_import.h"
#include "scene/scene.h"
#include "scene/shapes.h"

namespace pb::scene {

namespace fs = std::filesystem;
using config::YamlView;

namespace {

constexpr double kHuge = kMaxMagnitude;
// The smallest length a size, radius or wavelength may have: far above float's resolution at the
// coordinates a scene uses, so no shape collapses to zero-area triangles.
constexpr double kTiny = 1e-6;

float number(const YamlView& v, double lo, double hi) { return float(v.as_number(lo, hi)); }

// A coordinate or offset: [x, y, z] within kMaxMagnitude.
glm::vec3 coordinates(const YamlView& v) { return v.as_vec3(-kHuge, kHuge); }

glm::vec2 positive_vec2(const YamlView& v) { return v.as_vec2(kTiny, kHuge); }

glm::vec3 positive_vec3(const YamlView& v) { return v.as_vec3(kTiny, kHuge); }

glm::vec3 unit_direction(const YamlView& v) {
  glm::vec3 d = coordinates(v);
  if (!(glm::length(d) > 1e-8f)) v.fail("a direction must not be the zero vector");
  return glm::normalize(d);
}

// `n` or `[a, b]` as two integer counts.
glm::uvec2 counts2(const YamlView& v, int64_t lo, int64_t hi, bool second_half) {
  if (v.is_sequence()) {
    if (v.size() != 2) v.fail("expected [a, b] or one integer");
    return {uint32_t(v[size_t(0)].as_int(lo, hi)), uint32_t(v[size_t(1)].as_int(lo, hi))};
  }
  auto n = uint32_t(v.as_int(lo, hi));
  return {n, second_half ? std::max<uint32_t>(uint32_t(lo), n / 2) : n};
}

// {keys: [[t, value], ...], interpolation: step|linear|catmull-rom, loop: bool}
template <class T, class ReadValue>
Keyframes<T> read_keys(const YamlView& track, ReadValue read_value) {
  Keyframes<T> out;
  YamlView keys = track["keys"];
  if (!keys.is_sequence() || keys.size() == 0)
    keys.fail("expected a non-empty list of [time_s, value]");
  for (const auto& key : keys.elements()) {
    if (!key.is_sequence() || key.size() != 2) key.fail("expected a key [time_s, value]");
    YamlView time = key[size_t(0)];
    float t = number(time, -kHuge, kHuge);
    if (!out.times.empty() && !(t > out.times.back()))
      time.fail(fmt::format("key times must be strictly increasing (previous key at {} s)",
                            out.times.back()));
    out.times.push_back(t);
    out.values.push_back(read_value(key[size_t(1)]));
  }
  if (auto interpolation = track.get("interpolation")) {
    std::string name = interpolation->as_enum({"step", "linear", "catmull-rom"});
    out.interpolation = name == "step"     ? Interpolation::step
                        : name == "linear" ? Interpolation::linear
                                           : Interpolation::catmull_rom;
  }
  out.loop = track.bool_or("loop", false);
  if (out.loop && out.times.size() < 2) track["loop"].fail("a loop needs at least two keys");
  return out;
}

bool is_track(const YamlView& v) { return v.is_map(); }

Orbit read_orbit(const YamlView& v) {
  v.allow_keys({"center", "radius", "height", "period", "phase_deg"});
  Orbit o;
  if (auto c = v.get("center")) o.center = coordinates(*c);
  o.radius = float(v.number_or("radius", 1.0, 0.0, kHuge));
  o.height = float(v.number_or("height", 0.0, -kHuge, kHuge));
  YamlView period = v["period"];
  o.period = number(period, -kHuge, kHuge);
  if (std::abs(o.period) < 1e-6f)
    period.fail("the period must not be zero (a negative one turns clockwise)");
  o.phase = glm::radians(float(v.number_or("phase_deg", 0.0, -kHuge, kHuge)));
  return o;
}

// [x, y, z], or {keys: ...}, or {orbit: {...}}
PositionTrack read_position(const YamlView& v) {
  PositionTrack p;
  if (!is_track(v)) {
    p.constant = coordinates(v);
    return p;
  }
  v.allow_keys({"keys", "interpolation", "loop", "orbit"});
  if (auto orbit = v.get("orbit")) {
    for (auto other : {"keys", "interpolation", "loop"})
      if (v.has(other)) v[other].fail("an orbit takes no keyframe settings");
    p.orbit = read_orbit(*orbit);
    return p;
  }
  p.keys = read_keys<glm::vec3>(v, coordinates);
  return p;
}

CameraTrack read_camera(const YamlView& v) {
  v.allow_keys({"position", "target", "up", "fov_deg", "near", "far"});
  CameraTrack c;
  c.where = fmt::format("{}: {}", v.location(), v.key_path());
  c.position = read_position(v["position"]);
  c.target = read_position(v["target"]);
  if (auto up = v.get("up")) c.up = unit_direction(*up);
  YamlView fov = v["fov_deg"];
  if (is_track(fov)) {
    fov.allow_keys({"keys", "interpolation", "loop"});
    c.fov_keys = read_keys<float>(fov, [](const YamlView& x) { return number(x, 1, 179); });
    c.fov_y_deg = c.fov_keys.values.front();
  } else {
    c.fov_y_deg = number(fov, 1, 179);
  }
  c.near_plane = float(v.number_or("near", 0.01, 1e-6, kHuge));
  c.far_plane = float(v.number_or("far", 100.0, 1e-6, kHuge));
  if (!(c.far_plane > c.near_plane))
    (v.has("far") ? v["far"] : v)
        .fail(fmt::format("far ({}) must exceed near ({})", c.far_plane, c.near_plane));
  return c;
}

LightTrack read_light(const YamlView& v, size_t index) {
  if (!v.is_map()) v.fail("expected a light mapping with a 'type'");
  LightTrack track;
  track.where = fmt::format("{}: {}", v.location(), v.key_path());
  Light& light = track.light;
  std::string type = v["type"].as_enum({"point", "spot", "directional", "quad"});
  light.name = v.string_or("name", fmt::format("light{}", index));
  glm::vec3 color = v.has("color") ? v["color"].as_vec3(0, 1e3) : glm::vec3(1.0f);
  // Exactly one of the quantities named in `choices` must be given.
  auto quantity = [&](std::initializer_list<const char*> choices) -> std::pair<std::string, float> {
    std::vector<const char*> given;
    for (auto c : choices)
      if (v.has(c)) given.push_back(c);
    std::string names;
    for (auto c : choices) names += (names.empty() ? "'" : " or '") + std::string(c) + "'";
    if (given.size() != 1) v.fail(fmt::format("a {} light needs exactly one of {}", type, names));
    return {given[0], number(v[given[0]], 0, kHuge)};
  };
  if (type == "point") {
    v.allow_keys({"name", "type", "color", "position", "intensity", "power"});
    light.type = LightType::point;
    track.position = read_position(v["position"]);
    auto [key, value] = quantity({"intensity", "power"});
    // A point light's power is 4 pi I (it radiates I W/sr into every direction).
    light.radiant = color * (key == "power" ? value / (4 * glm::pi<float>()) : value);
  } else if (type == "spot") {
    v.allow_keys({"name", "type", "color", "position", "target", "direction", "intensity",
                  "inner_deg", "outer_deg"});
    light.type = LightType::spot;
    track.position = read_position(v["position"]);
    if (v.has("target") && v.has("direction"))
      v["direction"].fail("give either 'target' or 'direction'");
    if (auto target = v.get("target")) track.target = read_position(*target);
    if (auto direction = v.get("direction")) light.direction = unit_direction(*direction);
    light.radiant = color * quantity({"intensity"}).second;
    float inner = float(v.number_or("inner_deg", 30.0, 0.0, 89.0));
    float outer = float(v.number_or("outer_deg", std::max(40.0f, inner), 0.1, 89.9));
    if (inner > outer)
      v["inner_deg"].fail(fmt::format("inner_deg ({}) exceeds outer_deg ({})", inner, outer));
    light.spot_inner = glm::radians(inner);
    light.spot_outer = glm::radians(outer);
  } else if (type == "directional") {
    v.allow_keys({"name", "type", "color", "direction", "position", "target", "irradiance"});
    light.type = LightType::directional;
    if (v.has("direction") == v.has("target"))
      v.fail("a directional light needs either 'direction' or 'position' and 'target'");
    if (auto direction = v.get("direction")) {
      if (v.has("position"))
        v["position"].fail("'position' only aims a directional light with 'target'");
      light.direction = unit_direction(*direction);
    } else {
      track.position = read_position(v["position"]);
      track.target = read_position(v["target"]);
    }
    light.radiant = color * quantity({"irradiance"}).second;
  } else {  // quad
    v.allow_keys({"name", "type", "color", "position", "edge_u", "edge_v", "radiance", "power"});
    light.type = LightType::quad;
    track.position = read_position(v["position"]);
    light.edge_u = coordinates(v["edge_u"]);
    light.edge_v = coordinates(v["edge_v"]);
    if (!(light.area() > 1e-10f)) v["edge_v"].fail("edge_u and edge_v must span a non-zero area");
    auto [key, value] = quantity({"radiance", "power"});
    // A one-sided Lambertian emitter of radiance L and area A emits pi L A watts.
    light.radiant = color * (key == "power" ? value / (glm::pi<float>() * light.area()) : value);
  }
  track.light.position = track.position.at(0);
  if (track.target) track.light = track.at(0);
  return track;
}

Material read_material(const std::string& name, const YamlView& v) {
  if (!v.is_map()) v.fail("expected a material mapping with a 'type'");
  Material m;
  m.name = name;
  std::string type = v["type"].as_enum(
      {"diffuse", "mirror", "dielectric", "rough_conductor", "rough_dielectric", "emissive"});
  auto albedo = [&] {
    if (auto a = v.get("albedo")) m.albedo = a->as_vec3(0, 1);
  };
  auto specular = [&] {
    if (auto s = v.get("specular")) m.specular = s->as_vec3(0, 1);
  };
  auto ior = [&] { m.ior = float(v.number_or("ior", 1.5, 1.0, 4.0)); };
  auto roughness = [&] { m.roughness = float(v.number_or("roughness", 0.1, 1e-3, 1.0)); };
  if (type == "diffuse") {
    v.allow_keys({"type", "albedo"});
    m.type = MaterialType::diffuse;
    albedo();
  } else if (type == "mirror") {
    v.allow_keys({"type", "specular"});
    m.type = MaterialType::mirror;
    specular();
  } else if (type == "dielectric") {
    v.allow_keys({"type", "ior"});
    m.type = MaterialType::dielectric;
    ior();
  } else if (type == "rough_conductor") {
    v.allow_keys({"type", "specular", "roughness"});
    m.type = MaterialType::rough_conductor;
    specular();
    roughness();
  } else if (type == "rough_dielectric") {
    v.allow_keys({"type", "ior", "roughness"});
    m.type = MaterialType::rough_dielectric;
    ior();
    roughness();
  } else {
    v.allow_keys({"type", "emission", "albedo"});
    m.type = MaterialType::emissive;
    m.emission = v["emission"].as_vec3(0, kHuge);
    albedo();
  }
  return m;
}

std::shared_ptr<const Shape> read_shape(const YamlView& v) {
  if (!v.is_map()) v.fail("expected a shape mapping with a 'type'");
  std::string type =
      v["type"].as_enum({"quad", "box", "sphere", "cylinder", "torus", "height_field", "obj"});
  if (type == "quad") {
    v.allow_keys({"type", "size"});
    return std::make_shared<QuadShape>(v.has("size") ? positive_vec2(v["size"]) : glm::vec2(1.0f));
  }
  if (type == "box") {
    v.allow_keys({"type", "size"});
    return std::make_shared<BoxShape>(v.has("size") ? positive_vec3(v["size"]) : glm::vec3(1.0f));
  }
  if (type == "sphere") {
    v.allow_keys({"type", "radius", "segments"});
    return std::make_shared<SphereShape>(float(v.number_or("radius", 0.5, kTiny, kHuge)),
                                         uint32_t(v.int_or("segments", 32, 3, 1024)));
  }
  if (type == "cylinder") {
    v.allow_keys({"type", "radius", "height", "segments", "caps", "inner_radius"});
    float radius = float(v.number_or("radius", 0.5, kTiny, kHuge));
    float inner = float(v.number_or("inner_radius", 0.0, 0.0, kHuge));
    if (inner >= radius)
      v["inner_radius"].fail(
          fmt::format("inner_radius ({}) must be below radius ({})", inner, radius));
    return std::make_shared<CylinderShape>(radius, float(v.number_or("height", 1.0, kTiny, kHuge)),
                                           uint32_t(v.int_or("segments", 32, 3, 4096)),
                                           v.bool_or("caps", true), inner);
  }
  if (type == "torus") {
    v.allow_keys({"type", "major_radius", "minor_radius", "segments"});
    float major = float(v.number_or("major_radius", 0.5, kTiny, kHuge));
    float minor = float(v.number_or("minor_radius", 0.1, kTiny, kHuge));
    if (minor >= major)
      v["minor_radius"].fail(
          fmt::format("minor_radius ({}) must be below major_radius ({})", minor, major));
    glm::uvec2 segments =
        v.has("segments") ? counts2(v["segments"], 3, 1024, true) : glm::uvec2(48, 24);
    return std::make_shared<TorusShape>(major, minor, segments.x, segments.y);
  }
  if (type == "height_field") {
    v.allow_keys({"type", "size", "resolution", "waves"});
    glm::vec2 size = v.has("size") ? positive_vec2(v["size"]) : glm::vec2(1.0f);
    glm::uvec2 resolution =
        v.has("resolution") ? counts2(v["resolution"], 1, 2048, false) : glm::uvec2(64);
    std::vector<Wave> waves;
    if (auto list = v.get("waves")) {
      if (!list->is_sequence()) list->fail("expected a list of waves");
      for (const auto& w : list->elements()) {
        w.allow_keys({"amplitude", "wavelength", "speed", "direction", "phase_deg"});
        Wave wave;
        wave.amplitude = number(w["amplitude"], 0, kHuge);
        wave.wavelength = number(w["wavelength"], 1e-4, kHuge);
        wave.speed = float(w.number_or("speed", 0.0, -kHuge, kHuge));
        if (auto d = w.get("direction")) {
          glm::vec2 dir = d->as_vec2(-kHuge, kHuge);
          if (!(glm::length(dir) > 1e-8f)) d->fail("a direction must not be the zero vector");
          wave.direction = glm::normalize(dir);
        }
        wave.phase = glm::radians(float(w.number_or("phase_deg", 0.0, -kHuge, kHuge)));
        waves.push_back(wave);
      }
    }
    return std::make_shared<HeightFieldShape>(size, resolution, std::move(waves));
  }
  return nullptr;  // obj: handled by the caller, which splits it into parts
}

TransformTrack read_transform(const YamlView& v) {
  v.allow_keys({"translate", "rotate_deg", "spin_deg_per_s", "scale"});
  TransformTrack t;
  if (auto translate = v.get("translate")) t.translation = read_position(*translate);
  if (auto rotate = v.get("rotate_deg")) {
    if (is_track(*rotate)) {
      rotate->allow_keys({"keys", "interpolation", "loop"});
      t.rotation_keys = read_keys<glm::vec3>(*rotate, coordinates);
    } else {
      t.rotation_deg = coordinates(*rotate);
    }
  }
  if (auto spin = v.get("spin_deg_per_s")) t.spin_deg_per_s = coordinates(*spin);
  if (auto scale = v.get("scale")) {
    if (is_track(*scale)) {
      scale->allow_keys({"keys", "interpolation", "loop"});
      t.scale_keys = read_keys<glm::vec3>(*scale, positive_vec3);
    } else {
      t.scale = positive_vec3(*scale);
    }
  }
  return t;
}

std::vector<std::string> names_of(const std::map<std::string, uint32_t>& index) {
  std::vector<std::string> out;
  for (const auto& [name, i] : index) out.push_back(name);
  return out;
}

uint32_t find_material(const YamlView& where, const std::string& name,
                       const std::map<std::string, uint32_t>& index) {
  auto it = index.find(name);
  if (it != index.end()) return it->second;
  auto names = names_of(index);
  std::string all;
  for (const auto& n : names) all += (all.empty() ? "" : ", ") + n;
  std::string hint = config::closest_name(name, names);
  where.fail(hint.empty() ? fmt::format("unknown material '{}' (defined: {})", name, all)
                          : fmt::format("unknown material '{}'; did you mean '{}'? (defined: {})",
                                        name, hint, all));
}

std::vector<fs::path> scene_dirs(const std::vector<fs::path>& search_dirs) {
  std::vector<fs::path> dirs = search_dirs;
  dirs.push_back(fs::path(PB_SOURCE_DIR) / "scenes");
  return dirs;
}

}  // namespace

Scene load_scene(const fs::path& file) {
  return parse_scene(config::read_text_file(file, config::kMaxYamlBytes, "scene file"), file);
}

Scene parse_scene(const std::string& text, const fs::path& file) {
  YamlView root = YamlView::parse(text, file.string());
  const char* keys = "purpose, fps, frames, camera, lights, materials, objects";
  if (root.node().IsNull() || !root.node().IsDefined())
    root.fail(fmt::format("the file is empty; a scene is a mapping of keys ({})", keys));
  if (!root.is_map())
    root.fail(fmt::format("not a scene file: a scene is a mapping of keys ({})", keys));
  root.allow_keys({"purpose", "fps", "frames", "camera", "lights", "materials", "objects"});
  Scene scene;
  scene.name = file.stem().string();
  scene.file = file;
  scene.purpose = root["purpose"].as_string();
  scene.fps = float(root.number_or("fps", 30.0, 1e-3, 1e4));
  scene.default_frames = uint32_t(root.int_or("frames", 32, 1, config::kMaxMeasuredFrames));
  scene.camera = read_camera(root["camera"]);

  std::map<std::string, uint32_t> material_index;
  if (auto materials = root.get("materials")) {
    for (const auto& [name, spec] : materials->entries()) {
      if (material_index.count(name))
        spec.fail(fmt::format("material '{}' is defined twice", name));
      material_index[name] = uint32_t(scene.materials.size());
      scene.materials.push_back(read_material(name, spec));
    }
  }

  std::set<std::string> light_names;
  if (auto lights = root.get("lights")) {
    if (!lights->is_sequence()) lights->fail("expected a list of lights");
    for (const auto& spec : lights->elements()) {
      scene.lights.push_back(read_light(spec, scene.lights.size()));
      if (!light_names.insert(scene.lights.back().light.name).second)
        spec["name"].fail(
            fmt::format("a light named '{}' already exists", scene.lights.back().light.name));
    }
  }

  YamlView objects = root["objects"];
  if (!objects.is_sequence() || objects.size() == 0)
    objects.fail("expected a non-empty list of objects");
  std::set<std::string> object_names;
  const fs::path directory = file.parent_path();
  size_t triangles = 0;
  for (const auto& spec : objects.elements()) {
    if (!spec.is_map()) spec.fail("expected an object mapping with a 'shape'");
    spec.allow_keys({"name", "shape", "material", "transform"});
    YamlView shape_spec = spec["shape"];
    std::string default_name =
        (shape_spec.is_map() && shape_spec.has("type") ? shape_spec["type"].as_string()
                                                       : "object") +
        std::to_string(scene.objects.size());
    std::string name = spec.string_or("name", default_name);
    TransformTrack transform;
    if (auto t = spec.get("transform")) transform = read_transform(*t);

    auto add = [&](std::string object_name, std::shared_ptr<const Shape> shape, uint32_t material) {
      if (!object_names.insert(object_name).second)
        (spec.has("name") ? spec["name"] : spec)
            .fail(fmt::format("an object named '{}' already exists", object_name));
      Object object;
      object.name = std::move(object_name);
      object.shape = std::move(shape);
      object.mesh = object.shape->tessellate(0);
      if (object.mesh.triangles.empty())
        shape_spec.fail(fmt::format("object '{}' has no triangles", object.name));
      triangles += object.mesh.triangle_count();
      if (triangles > kMaxSceneTriangles)
        shape_spec.fail(
            fmt::format("the scene reaches {} triangles here, more than the {} a scene "
                        "may have (fewer segments or a coarser resolution?)",
                        triangles, kMaxSceneTriangles));
      object.material = material;
      object.transform = transform;
      scene.objects.push_back(std::move(object));
    };

    if (shape_spec.is_map() && shape_spec.has("type") && shape_spec["type"].as_string() == "obj") {
      shape_spec.allow_keys({"type", "file"});
      YamlView file_key = shape_spec["file"];
      fs::path obj_path = directory / file_key.as_string();
      ObjModel model;
      try {
        model = load_obj(obj_path);
      } catch (const InputError& e) {
        file_key.fail(e.what());
      }
      std::optional<uint32_t> override_material;
      if (auto m = spec.get("material"))
        override_material = find_material(*m, m->as_string(), material_index);
      // The OBJ's materials become scene materials "<object>/<mtl name>" unless the scene defines
      // one of that name, which then wins.
      for (const auto& part : model.parts) {
        uint32_t material = 0;
        std::string part_name = name;
        if (part.material >= 0) part_name += "/" + model.materials[part.material].name;
        if (override_material) {
          material = *override_material;
        } else if (part.material < 0) {
          spec.fail(fmt::format(
              "{} has faces without a material (no usemtl); give the object a 'material'",
              obj_path.string()));
        } else {
          Material mapped = model.materials[part.material];
          mapped.name = name + "/" + mapped.name;
          auto [it, added] =
              material_index.try_emplace(mapped.name, uint32_t(scene.materials.size()));
          if (added) scene.materials.push_back(mapped);
          material = it->second;
        }
        if (model.parts.size() == 1) part_name = name;
        add(part_name, std::make_shared<MeshShape>("obj", part.mesh), material);
      }
    } else {
      auto shape = read_shape(shape_spec);
      YamlView material_key = spec["material"];
      add(name, shape, find_material(material_key, material_key.as_string(), material_index));
    }
  }
  check_frames(scene, 0, scene.default_frames - 1);
  return scene;
}

namespace {

// A file that parses as a mapping with the keys every scene has: configs and other YAML files
// beside the scenes are not offered as scene names.
bool looks_like_scene(const fs::path& file) {
  try {
    YamlView root = YamlView::load_file(file);
    return root.is_map() && root.has("camera") && root.has("objects");
  } catch (const InputError&) {
    return false;
  }
}

}  // namespace

std::vector<std::string> list_scenes(const std::vector<fs::path>& search_dirs) {
  std::set<std::string> names;
  for (const auto& dir : scene_dirs(search_dirs)) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      auto ext = entry.path().extension();
      if (entry.is_regular_file(ec) && (ext == ".yaml" || ext == ".yml") &&
          looks_like_scene(entry.path()))
        names.insert(entry.path().stem().string());
    }
  }
  return {names.begin(), names.end()};
}

fs::path find_scene(const std::string& name_or_path, const std::vector<fs::path>& search_dirs) {
  if (name_or_path.empty() || name_or_path.find('\0') != std::string::npos)
    throw InputError(fmt::format("'{}' is not a scene name or path", config::quote(name_or_path)));
  fs::path given(name_or_path);
  bool is_path = name_or_path.find('/') != std::string::npos || given.extension() == ".yaml" ||
                 given.extension() == ".yml";
  if (is_path) {
    std::error_code ec;
    auto status = fs::status(given, ec);
    if (fs::is_regular_file(status)) return given;
    if (fs::is_directory(status))
      throw InputError(
          fmt::format("{}: is a directory, not a scene file", config::quote(name_or_path, 200)));
    if (fs::exists(status))
      throw InputError(
          fmt::format("{}: is not a regular file (a device or a pipe), not a scene file",
                      config::quote(name_or_path, 200)));
    throw InputError(fmt::format("{}: scene file not found", config::quote(name_or_path, 200)));
  }
  auto dirs = scene_dirs(search_dirs);
  for (const auto& dir : dirs)
    for (const char* ext : {".yaml", ".yml"}) {
      fs::path candidate = dir / (name_or_path + ext);
      if (fs::is_regular_file(candidate)) return candidate;
    }
  auto names = list_scenes(search_dirs);
  std::string all, searched;
  constexpr size_t kListed = 30;  // a folder of a thousand scenes makes no useful message
  for (size_t i = 0; i < std::min(names.size(), kListed); ++i)
    all += (all.empty() ? "" : ", ") + names[i];
  if (names.size() > kListed) all += fmt::format(" and {} more", names.size() - kListed);
  for (const auto& d : dirs) searched += (searched.empty() ? "" : ", ") + d.string();
  std::string hint = config::closest_name(name_or_path, names);
  throw InputError(fmt::format("unknown scene '{}'{} (searched {}; available: {})",
                               config::quote(name_or_path),
                               hint.empty() ? "" : fmt::format("; did you mean '{}'?", hint),
                               searched, all.empty() ? "none" : all));
}

}  // namespace pb::scene
