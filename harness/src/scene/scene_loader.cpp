// Reading a scene file (the format is documented at the top of scenes/README.md). Every mapping
// declares its keys, so a misspelt key is an error naming file:line:col and the key path rather
// than a silently ignored setting; every number is range-checked where it is read, within
// kMaxMagnitude unless its key has a narrower range.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/constants.hpp>
#include <map>
#include <mutex>
#include <set>
#include <tuple>

#include "config/config.h"
#include "config/key_table.h"
#include "config/yaml_view.h"
#include "photonbench/error.h"
#include "scene/gltf_import.h"
#include "scene/obj_import.h"
#include "scene/scene.h"
#include "scene/shapes.h"

namespace pb::scene {

namespace fs = std::filesystem;
using config::Key;
using config::KeyTable;
using config::ValueType;
using config::YamlView;
using nlohmann::json;

namespace {

constexpr double kHuge = kMaxMagnitude;
// The smallest length a size, radius or wavelength may have: far above float's resolution at the
// coordinates a scene uses, so no shape collapses to zero-area triangles.
constexpr double kTiny = 1e-6;

// The scene format, one table per mapping (config/key_table.h): the readers below take every key
// name, range and default from these rows, and `photonbench schema scene` prints them. Lights,
// materials and shapes are tagged by `type`, one table per variant.
const ValueType kAnyNumber = config::number_type(-kHuge, kHuge);
const ValueType kCoordinates = config::vec3_type(-kHuge, kHuge);  // a point, offset or direction
const ValueType kPositiveVec2 = config::vec2_type(kTiny, kHuge);
const ValueType kPositiveVec3 = config::vec3_type(kTiny, kHuge);
const ValueType kFov = config::number_type(1, 179);
const ValueType kInterpolation = config::choice_type({"step", "linear", "catmull-rom"});

// {keys: [[t, value], ...], interpolation, loop}: a value animated by keyframes.
KeyTable keyframes_table(std::string name, const ValueType& value) {
  return {std::move(name),
          "A value keyframed over time.",
          {{"keys", config::list_type(config::tuple_type({kAnyNumber, value}), 1, false), true,
            nullptr, "[time_s, value] pairs, times strictly increasing"},
           {"interpolation", kInterpolation, false, "linear", "between keys"},
           {"loop", config::boolean_type(), false, false, "repeat the keys (needs two or more)"}}};
}

const KeyTable kPositionKeys = keyframes_table("scene.position_keys", kCoordinates);
const KeyTable kRotationKeys = keyframes_table("scene.rotation_keys", kCoordinates);
const KeyTable kScaleKeys = keyframes_table("scene.scale_keys", kPositiveVec3);
const KeyTable kFovKeys = keyframes_table("scene.fov_keys", kFov);

const KeyTable kOrbitTable{
    "scene.orbit",
    "A circle in the plane at center.y + height, counter-clockwise seen from above.",
    {{"center", kCoordinates, false, 0, ""},
     {"radius", config::number_type(0, kHuge), false, 1, ""},
     {"height", kAnyNumber, false, 0, "above the center"},
     {"period", kAnyNumber, true, nullptr,
      "seconds per turn, not zero (a negative one turns clockwise)"},
     {"phase_deg", kAnyNumber, false, 0, "where it starts (0: the +x axis)"}}};
const KeyTable kOrbitingTable{"scene.orbiting",
                              "A position on an orbit.",
                              {{"orbit", config::table_type(kOrbitTable), true}}};

// [x, y, z], or keyframes, or an orbit.
const ValueType kPosition = config::any_of_type(
    {kCoordinates, config::table_type(kPositionKeys), config::table_type(kOrbitingTable)});

const KeyTable kCameraTable{
    "scene.camera",
    "The camera, looking from position at target.",
    {{"position", kPosition, true},
     {"target", kPosition, true},
     {"up", kCoordinates, false, json::array({0, 1, 0}), "not the zero vector"},
     {"fov_deg", config::any_of_type({kFov, config::table_type(kFovKeys)}), true, nullptr,
      "vertical field of view"},
     {"near", config::number_type(1e-6, kHuge), false, 0.01, ""},
     {"far", config::number_type(1e-6, kHuge), false, 100, "beyond near"}}};

// One variant of a tagged mapping ("scene.light.spot"): its `type` tag, then its own keys.
KeyTable variant_table(const std::string& family, const std::string& type, std::string doc,
                       std::vector<Key> own) {
  own.insert(own.begin(), Key{"type", config::choice_type({type}), true});
  return {fmt::format("scene.{}.{}", family, type), std::move(doc), std::move(own)};
}

// The keys every light has, then its own.
KeyTable light_table(const std::string& type, std::string doc, std::vector<Key> own) {
  std::vector<Key> keys = {
      {"name", config::string_type(), false, nullptr, "unique (default: light<index>)"},
      {"color", config::vec3_type(0, 1e3), false, 1, "multiplies the light's quantity"}};
  keys.insert(keys.end(), own.begin(), own.end());
  return variant_table("light", type, std::move(doc), std::move(keys));
}

const ValueType kRadiant = config::number_type(0, kHuge);
// A light's quantity (power, intensity, irradiance or radiance): a number, or keyframes of it, its
// power over time (LightTrack::power).
const KeyTable kQuantityKeys = keyframes_table("scene.light_quantity_keys", kRadiant);
const ValueType kQuantity = config::any_of_type({kRadiant, config::table_type(kQuantityKeys)});
const std::vector<KeyTable> kLightTables = {
    light_table("point", "A point light.",
                {{"position", kPosition, true},
                 {"intensity", kQuantity, false, nullptr, "W/sr, or power"},
                 {"power", kQuantity, false, nullptr, "W (4 pi intensity), or intensity"}}),
    light_table("spot", "A spot light, aimed at target or along direction.",
                {{"position", kPosition, true},
                 {"target", kPosition, false, nullptr, "or direction"},
                 {"direction", kCoordinates, false, nullptr, "or target"},
                 {"intensity", kQuantity, true, nullptr, "W/sr"},
                 {"inner_deg", config::number_type(0, 89), false, 30,
                  "full intensity inside this half-angle"},
                 {"outer_deg", config::number_type(0.1, 89.9), false, nullptr,
                  "zero outside this half-angle (default: max(40, inner_deg))"}}),
    light_table("directional", "A directional light: direction, or position and target.",
                {{"direction", kCoordinates, false, nullptr, "or position and target"},
                 {"position", kPosition, false, nullptr, ""},
                 {"target", kPosition, false, nullptr, ""},
                 {"irradiance", kQuantity, true, nullptr, "W/m^2"}}),
    light_table("quad", "A one-sided parallelogram emitter at position spanned by edge_u, edge_v.",
                {{"position", kPosition, true},
                 {"edge_u", kCoordinates, true},
                 {"edge_v", kCoordinates, true},
                 {"radiance", kQuantity, false, nullptr, "W/(m^2 sr), or power"},
                 {"power", kQuantity, false, nullptr, "W (pi radiance area), or radiance"}}),
    light_table("disc", "A one-sided circular emitter at position (its centre) facing normal.",
                {{"position", kPosition, true, nullptr, "the centre"},
                 {"normal", kCoordinates, true, nullptr, "the emitting side, not the zero vector"},
                 {"radius", config::number_type(1e-4, 1e4), true, nullptr, "m"},
                 {"radiance", kQuantity, false, nullptr, "W/(m^2 sr), or power"},
                 {"power", kQuantity, false, nullptr, "W (pi radiance area), or radiance"}})};

const ValueType kAlbedo = config::vec3_type(0, 1);
const ValueType kIor = config::number_type(1, 4);
const ValueType kRoughness = config::number_type(1e-3, 1);
const std::vector<KeyTable> kMaterialTables = {
    variant_table("material", "diffuse", "Lambertian.", {{"albedo", kAlbedo, false, 0.8, ""}}),
    variant_table("material", "mirror", "A perfect mirror.",
                  {{"specular", kAlbedo, false, 1, "tint"}}),
    variant_table("material", "dielectric", "Smooth glass.",
                  {{"ior", kIor, false, 1.5, "inside / outside"}}),
    variant_table("material", "rough_conductor", "GGX microfacet metal.",
                  {{"specular", kAlbedo, false, 1, "F0"},
                   {"roughness", kRoughness, false, 0.1, "GGX alpha"}}),
    variant_table("material", "rough_dielectric", "GGX microfacet glass.",
                  {{"ior", kIor, false, 1.5, "inside / outside"},
                   {"roughness", kRoughness, false, 0.1, "GGX alpha"}}),
    variant_table("material", "emissive", "A diffuse emitter with a Lambertian albedo.",
                  {{"emission", config::vec3_type(0, kHuge), true, nullptr, "W/(m^2 sr)"},
                   {"albedo", kAlbedo, false, 0.8, ""}})};

const KeyTable kWaveTable{"scene.wave",
                          "One travelling sine wave of a height field.",
                          {{"amplitude", config::number_type(0, kHuge), true},
                           {"wavelength", config::number_type(1e-4, kHuge), true},
                           {"speed", kAnyNumber, false, 0, "units per second"},
                           {"direction", config::vec2_type(-kHuge, kHuge), false,
                            json::array({1, 0}), "[x, z], not the zero vector"},
                           {"phase_deg", kAnyNumber, false, 0, ""}}};

const ValueType kRadius = config::number_type(kTiny, kHuge);
const std::vector<KeyTable> kShapeTables = {
    variant_table("shape", "quad", "A unit quad in the xz plane, facing +y.",
                  {{"size", kPositiveVec2, false, 1, ""}}),
    variant_table("shape", "box", "A box centred on the origin.",
                  {{"size", kPositiveVec3, false, 1, ""}}),
    variant_table("shape", "sphere", "A UV sphere.",
                  {{"radius", kRadius, false, 0.5, ""},
                   {"segments", config::integer_type(3, 1024), false, 32, ""}}),
    variant_table("shape", "cylinder", "A cylinder along y, optionally a tube.",
                  {{"radius", kRadius, false, 0.5, ""},
                   {"height", kRadius, false, 1, ""},
                   {"segments", config::integer_type(3, 4096), false, 32, ""},
                   {"caps", config::boolean_type(), false, true, ""},
                   {"inner_radius", config::number_type(0, kHuge), false, 0,
                    "below radius; above 0 makes a tube"}}),
    variant_table("shape", "torus", "A torus around y.",
                  {{"major_radius", kRadius, false, 0.5, ""},
                   {"minor_radius", kRadius, false, 0.1, "below major_radius"},
                   {"segments", config::counts2_type(3, 1024), false, json::array({48, 24}),
                    "[around, across], or one n for [n, n/2]"}}),
    variant_table("shape", "height_field", "A grid over the xz rectangle displaced by waves.",
                  {{"size", kPositiveVec2, false, 1, ""},
                   {"resolution", config::counts2_type(1, 2048), false, 64, "cells"},
                   {"waves", config::list_type(config::table_type(kWaveTable), 0, false), false,
                    nullptr, ""}}),
    variant_table("shape", "obj", "A Wavefront OBJ file (its MTL materials come with it).",
                  {{"file", config::string_type(), true, nullptr, "relative to the scene"},
                   {"smooth_normals", config::boolean_type(), false, false,
                    "replace its normals by area-weighted averages over the faces meeting at "
                    "each position (for a file without vn)"}})};

std::vector<const KeyTable*> pointers(const std::vector<KeyTable>& tables) {
  std::vector<const KeyTable*> out;
  for (const auto& t : tables) out.push_back(&t);
  return out;
}
const std::vector<const KeyTable*> kLights = pointers(kLightTables);
const std::vector<const KeyTable*> kMaterials = pointers(kMaterialTables);
const std::vector<const KeyTable*> kShapes = pointers(kShapeTables);

const KeyTable kTransformTable{
    "scene.transform",
    "Scale, then rotate (XYZ Euler), then translate.",
    {{"translate", kPosition, false, nullptr, ""},
     {"rotate_deg", config::any_of_type({kCoordinates, config::table_type(kRotationKeys)}), false,
      0, "XYZ Euler degrees"},
     {"spin_deg_per_s", kCoordinates, false, 0, "added to the rotation"},
     {"scale", config::any_of_type({kPositiveVec3, config::table_type(kScaleKeys)}), false, 1,
      ""}}};

const KeyTable kObjectTable{
    "scene.object",
    "A shape with a material and a transform.",
    {{"name", config::string_type(), false, nullptr, "unique (default: <shape type><index>)"},
     {"shape", config::variants_type(kShapes), true},
     {"material", config::string_type(), false, nullptr,
      "a name under materials; required unless the shape is an obj with its own"},
     {"transform", config::table_type(kTransformTable), false}}};

const KeyTable kGltfTable{
    "scene.gltf",
    "A glTF 2.0 file whose meshes, materials, lights, camera and animations the scene takes.",
    {{"file", config::string_type(), true, nullptr, "a .gltf or .glb file, relative to the scene"},
     {"camera", config::integer_type(0, 1 << 20), false, 0,
      "which of its cameras, when the scene has no 'camera'"},
     {"animate", config::boolean_type(), false, true, "play its animations"},
     {"transforms", config::map_of_type(config::table_type(kTransformTable)), false, nullptr,
      "by object name: replaces the object's motion (a still object's mesh is in world space)"}}};

const KeyTable kSceneTable{
    "scene",
    "A photonbench scene file (scenes/README.md).",
    {{"purpose", config::string_type(), true, nullptr, "what the scene tests"},
     {"fps", config::number_type(1e-3, 1e4), false, 30, "time = frame / fps"},
     {"frames", config::integer_type(1, config::kMaxMeasuredFrames), false, 32,
      "the length of its default animation"},
     {"gltf", config::table_type(kGltfTable), false, nullptr,
      "objects, materials, lights and camera from a glTF file, before the scene's own"},
     {"camera", config::table_type(kCameraTable), false, nullptr,
      "required unless gltf gives one; replaces the glTF camera"},
     {"lights", config::list_type(config::variants_type(kLights), 0, false), false, nullptr,
      "a light named as a glTF light replaces it"},
     {"materials", config::map_of_type(config::variants_type(kMaterials)), false, nullptr,
      "by name; one named as a glTF material replaces it"},
     {"objects", config::list_type(config::table_type(kObjectTable), 1, false), false, nullptr,
      "required unless gltf gives some"}}};

float number(const YamlView& v, const ValueType& type) { return float(type.number(v)); }

glm::vec3 coordinates(const YamlView& v) { return kCoordinates.vec3(v); }

glm::vec3 unit_direction(const YamlView& v) {
  glm::vec3 d = coordinates(v);
  if (!(glm::length(d) > 1e-8f)) v.fail("a direction must not be the zero vector");
  return glm::normalize(d);
}

// {keys: [[t, value], ...], interpolation: step|linear|catmull-rom, loop: bool}
template <class T, class ReadValue>
Keyframes<T> read_keys(const KeyTable& table, const YamlView& track, ReadValue read_value) {
  Keyframes<T> out;
  YamlView keys = track["keys"];
  if (!keys.is_sequence() || keys.size() == 0)
    keys.fail("expected a non-empty list of [time_s, value]");
  for (const auto& key : keys.elements()) {
    if (!key.is_sequence() || key.size() != 2) key.fail("expected a key [time_s, value]");
    YamlView time = key[size_t(0)];
    float t = number(time, kAnyNumber);
    if (!out.times.empty() && !(t > out.times.back()))
      time.fail(fmt::format("key times must be strictly increasing (previous key at {} s)",
                            out.times.back()));
    out.times.push_back(t);
    out.values.push_back(read_value(key[size_t(1)]));
  }
  std::string name = table.string(track, "interpolation");
  out.interpolation = name == "step"     ? Interpolation::step
                      : name == "linear" ? Interpolation::linear
                                         : Interpolation::catmull_rom;
  out.loop = table.boolean(track, "loop");
  if (out.loop && out.times.size() < 2) track["loop"].fail("a loop needs at least two keys");
  return out;
}

bool is_track(const YamlView& v) { return v.is_map(); }

Orbit read_orbit(const YamlView& v) {
  const KeyTable& table = kOrbitTable;
  table.allow(v);
  Orbit o;
  o.center = table.vec3(v, "center");
  o.radius = float(table.number(v, "radius"));
  o.height = float(table.number(v, "height"));
  o.period = float(table.number(v, "period"));
  if (std::abs(o.period) < 1e-6f)
    v["period"].fail("the period must not be zero (a negative one turns clockwise)");
  o.phase = glm::radians(float(table.number(v, "phase_deg")));
  return o;
}

// [x, y, z], or {keys: ...}, or {orbit: {...}}
PositionTrack read_position(const YamlView& v) {
  PositionTrack p;
  if (!is_track(v)) {
    p.constant = coordinates(v);
    return p;
  }
  // One mapping of either table's keys, so a misspelt key suggests from both.
  std::vector<std::string> keys = kPositionKeys.names();
  keys.push_back("orbit");
  v.allow_keys(keys);
  if (auto orbit = v.get("orbit")) {
    for (auto other : {"keys", "interpolation", "loop"})
      if (v.has(other)) v[other].fail("an orbit takes no keyframe settings");
    p.orbit = read_orbit(*orbit);
    return p;
  }
  p.keys = read_keys<glm::vec3>(kPositionKeys, v, coordinates);
  return p;
}

CameraTrack read_camera(const YamlView& v) {
  const KeyTable& table = kCameraTable;
  table.allow(v);
  CameraTrack c;
  c.where = fmt::format("{}: {}", v.location(), v.key_path());
  c.position = read_position(v["position"]);
  c.target = read_position(v["target"]);
  c.up = v.has("up") ? unit_direction(v["up"]) : table.vec3(v, "up");
  YamlView fov = v["fov_deg"];
  if (is_track(fov)) {
    kFovKeys.allow(fov);
    c.fov_keys = read_keys<float>(kFovKeys, fov, [](const YamlView& x) { return number(x, kFov); });
    c.fov_y_deg = c.fov_keys.values.front();
  } else {
    c.fov_y_deg = number(fov, kFov);
  }
  c.near_plane = float(table.number(v, "near"));
  c.far_plane = float(table.number(v, "far"));
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
  const KeyTable& table = config::select_variant(v, kLights);
  const std::string type = table.tag();
  light.name = v.has("name") ? table.string(v, "name") : fmt::format("light{}", index);
  glm::vec3 color = table.vec3(v, "color");
  // Exactly one of the quantities named in `choices` must be given.
  auto quantity = [&](std::initializer_list<const char*> choices) -> std::string {
    std::vector<const char*> given;
    for (auto c : choices)
      if (v.has(c)) given.push_back(c);
    std::string names;
    for (auto c : choices) names += (names.empty() ? "'" : " or '") + std::string(c) + "'";
    if (given.size() != 1) v.fail(fmt::format("a {} light needs exactly one of {}", type, names));
    return given[0];
  };
  // The quantity `key` as Light::radiant, a number or keyframes (then its power over time,
  // LightTrack::power), each value converted to radiant's unit by `to_radiant`.
  auto set_radiant = [&](const std::string& key, auto to_radiant) {
    const YamlView value = v[key];
    if (!is_track(value)) {
      light.radiant = color * to_radiant(number(value, kRadiant));
      return;
    }
    kQuantityKeys.allow(value);
    track.power = read_keys<float>(
        kQuantityKeys, value, [&](const YamlView& x) { return to_radiant(number(x, kRadiant)); });
    track.color = color;
  };
  auto as_is = [](float value) { return value; };
  if (type == "point") {
    light.type = LightType::point;
    track.position = read_position(v["position"]);
    std::string key = quantity({"intensity", "power"});
    // A point light's power is 4 pi I (it radiates I W/sr into every direction).
    if (key == "power")
      set_radiant(key, [](float power) { return power / (4 * glm::pi<float>()); });
    else
      set_radiant(key, as_is);
  } else if (type == "spot") {
    light.type = LightType::spot;
    track.position = read_position(v["position"]);
    if (v.has("target") && v.has("direction"))
      v["direction"].fail("give either 'target' or 'direction'");
    if (auto target = v.get("target")) track.target = read_position(*target);
    if (auto direction = v.get("direction")) light.direction = unit_direction(*direction);
    set_radiant(quantity({"intensity"}), as_is);
    float inner = float(table.number(v, "inner_deg"));
    float outer = float(table.number_or(v, "outer_deg", std::max(40.0f, inner)));
    if (inner > outer)
      v["inner_deg"].fail(fmt::format("inner_deg ({}) exceeds outer_deg ({})", inner, outer));
    light.spot_inner = glm::radians(inner);
    light.spot_outer = glm::radians(outer);
  } else if (type == "directional") {
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
    set_radiant(quantity({"irradiance"}), as_is);
  } else {  // quad, disc
    track.position = read_position(v["position"]);
    if (type == "quad") {
      light.type = LightType::quad;
      light.edge_u = table.vec3(v, "edge_u");
      light.edge_v = table.vec3(v, "edge_v");
      if (!(light.area() > 1e-10f)) v["edge_v"].fail("edge_u and edge_v must span a non-zero area");
    } else {
      light.type = LightType::disc;
      glm::vec3 n = unit_direction(v["normal"]);
      float radius = float(table.number(v, "radius"));
      // Two radii with cross(edge_u, edge_v) along n (Duff et al. 2017's orthonormal basis).
      float sign = std::copysign(1.f, n.z), a = -1.f / (sign + n.z), b = n.x * n.y * a;
      light.edge_u = radius * glm::vec3(1.f + sign * n.x * n.x * a, sign * b, -sign * n.x);
      light.edge_v = radius * glm::vec3(b, sign + n.y * n.y * a, -n.y);
    }
    std::string key = quantity({"radiance", "power"});
    // A one-sided Lambertian emitter of radiance L and area A emits pi L A watts.
    const float area = light.area();
    if (key == "power")
      set_radiant(key, [area](float power) { return power / (glm::pi<float>() * area); });
    else
      set_radiant(key, as_is);
  }
  track.light.position = track.position.at(0);
  if (track.target || !track.power.empty()) track.light = track.at(0);
  return track;
}

Material read_material(const std::string& name, const YamlView& v) {
  if (!v.is_map()) v.fail("expected a material mapping with a 'type'");
  Material m;
  m.name = name;
  const KeyTable& table = config::select_variant(v, kMaterials);
  const std::string type = table.tag();
  // The variant's own keys, with the table's defaults; one it lacks keeps Material's value.
  const std::vector<std::string> keys = table.names();
  auto has = [&](const char* key) {
    return std::find(keys.begin(), keys.end(), key) != keys.end();
  };
  if (has("albedo")) m.albedo = table.vec3(v, "albedo");
  if (has("specular")) m.specular = table.vec3(v, "specular");
  if (has("emission")) m.emission = table.vec3(v, "emission");
  if (has("ior")) m.ior = float(table.number(v, "ior"));
  if (has("roughness")) m.roughness = float(table.number(v, "roughness"));
  m.type = type == "diffuse"            ? MaterialType::diffuse
           : type == "mirror"           ? MaterialType::mirror
           : type == "dielectric"       ? MaterialType::dielectric
           : type == "rough_conductor"  ? MaterialType::rough_conductor
           : type == "rough_dielectric" ? MaterialType::rough_dielectric
                                        : MaterialType::emissive;
  return m;
}

std::shared_ptr<const Shape> read_shape(const YamlView& v) {
  if (!v.is_map()) v.fail("expected a shape mapping with a 'type'");
  const KeyTable& table = config::select_variant(v, kShapes);
  const std::string type = table.tag();
  if (type == "quad") return std::make_shared<QuadShape>(table.vec2(v, "size"));
  if (type == "box") return std::make_shared<BoxShape>(table.vec3(v, "size"));
  if (type == "sphere")
    return std::make_shared<SphereShape>(float(table.number(v, "radius")),
                                         uint32_t(table.integer(v, "segments")));
  if (type == "cylinder") {
    float radius = float(table.number(v, "radius"));
    float inner = float(table.number(v, "inner_radius"));
    if (inner >= radius)
      v["inner_radius"].fail(
          fmt::format("inner_radius ({}) must be below radius ({})", inner, radius));
    return std::make_shared<CylinderShape>(radius, float(table.number(v, "height")),
                                           uint32_t(table.integer(v, "segments")),
                                           table.boolean(v, "caps"), inner);
  }
  if (type == "torus") {
    float major = float(table.number(v, "major_radius"));
    float minor = float(table.number(v, "minor_radius"));
    if (minor >= major)
      v["minor_radius"].fail(
          fmt::format("minor_radius ({}) must be below major_radius ({})", minor, major));
    const Key& segments_key = table.key("segments");
    glm::uvec2 segments = glm::uvec2(segments_key.default_value[0].get<uint32_t>(),
                                     segments_key.default_value[1].get<uint32_t>());
    if (auto given = v.get("segments")) {
      segments = segments_key.type.counts2(*given);
      // One count n means n around and n / 2 across (a torus is twice as long around).
      if (!given->is_sequence())
        segments.y = std::max(uint32_t(segments_key.type.min), segments.x / 2);
    }
    return std::make_shared<TorusShape>(major, minor, segments.x, segments.y);
  }
  if (type == "height_field") {
    glm::vec2 size = table.vec2(v, "size");
    const Key& resolution_key = table.key("resolution");
    glm::uvec2 resolution = glm::uvec2(resolution_key.default_value.get<uint32_t>());
    if (auto given = v.get("resolution")) resolution = resolution_key.type.counts2(*given);
    std::vector<Wave> waves;
    if (auto list = v.get("waves")) {
      if (!list->is_sequence()) list->fail("expected a list of waves");
      for (const auto& w : list->elements()) {
        const KeyTable& wave_table = kWaveTable;
        wave_table.allow(w);
        Wave wave;
        wave.amplitude = float(wave_table.number(w, "amplitude"));
        wave.wavelength = float(wave_table.number(w, "wavelength"));
        wave.speed = float(wave_table.number(w, "speed"));
        glm::vec2 dir = wave_table.vec2(w, "direction");
        if (!(glm::length(dir) > 1e-8f))
          w["direction"].fail("a direction must not be the zero vector");
        wave.direction = glm::normalize(dir);
        wave.phase = glm::radians(float(wave_table.number(w, "phase_deg")));
        waves.push_back(wave);
      }
    }
    return std::make_shared<HeightFieldShape>(size, resolution, std::move(waves));
  }
  return nullptr;  // obj: handled by the caller, which splits it into parts
}

TransformTrack read_transform(const YamlView& v) {
  const KeyTable& table = kTransformTable;
  table.allow(v);
  TransformTrack t;
  if (auto translate = v.get("translate")) t.translation = read_position(*translate);
  // A constant or keyframes: the table row's alternatives, in that order.
  auto constant_or_keys = [&](const char* key, glm::vec3& constant, Keyframes<glm::vec3>& keys) {
    const ValueType& type = table.key(key).type;
    const YamlView value = v[key];
    if (is_track(value)) {
      const KeyTable& keys_table = *type.parts[1].table;
      keys_table.allow(value);
      keys = read_keys<glm::vec3>(keys_table, value,
                                  [&](const YamlView& x) { return type.parts[0].vec3(x); });
    } else {
      constant = type.parts[0].vec3(value);
    }
  };
  if (v.has("rotate_deg")) constant_or_keys("rotate_deg", t.rotation_deg, t.rotation_keys);
  t.spin_deg_per_s = table.vec3(v, "spin_deg_per_s");
  if (v.has("scale")) constant_or_keys("scale", t.scale, t.scale_keys);
  return t;
}

// Smooth shading for a mesh whose file gave no normals: the vertices at one position become one,
// with the area-weighted average of the normals of the faces around it (the cross products'
// lengths are twice the faces' areas, so summing them weights by area).
Mesh smooth_normals(const Mesh& mesh) {
  auto less = [](const glm::vec3& a, const glm::vec3& b) {
    return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
  };
  std::map<glm::vec3, uint32_t, decltype(less)> welded(less);
  Mesh out;
  std::vector<uint32_t> remap(mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    auto [it, added] = welded.try_emplace(mesh.positions[i], uint32_t(out.positions.size()));
    if (added) out.positions.push_back(mesh.positions[i]);
    remap[i] = it->second;
  }
  out.normals.assign(out.positions.size(), glm::vec3(0.0f));
  for (const auto& t : mesh.triangles) {
    glm::uvec3 w(remap[t.x], remap[t.y], remap[t.z]);
    glm::vec3 n = glm::cross(out.positions[w.y] - out.positions[w.x],
                             out.positions[w.z] - out.positions[w.x]);
    for (int k = 0; k < 3; ++k) out.normals[w[k]] += n;
    out.triangles.push_back(w);
  }
  for (auto& n : out.normals) n = glm::length(n) > 0 ? glm::normalize(n) : glm::vec3(0, 1, 0);
  // At a fold sharper than a right angle the mean can face away from a face meeting there: that
  // corner keeps the face's own normal, so no shading normal points below its triangle.
  for (auto& t : out.triangles) {
    const glm::vec3 face = glm::normalize(glm::cross(out.positions[t.y] - out.positions[t.x],
                                                     out.positions[t.z] - out.positions[t.x]));
    for (int k = 0; k < 3; ++k)
      if (!(glm::dot(face, out.normals[t[k]]) > 0)) {
        out.positions.push_back(out.positions[t[k]]);
        out.normals.push_back(face);
        t[k] = uint32_t(out.positions.size() - 1);
      }
  }
  return out;
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

const KeyTable& scene_table() { return kSceneTable; }

namespace {

// A glTF file's warning once per process per file: the plan, the runner and each cell load the
// same scene.
void warn_once(const fs::path& file, const GltfModel& model) {
  const std::string warning = unsupported_warning(file, model);
  if (warning.empty()) return;
  static std::mutex mutex;
  static std::set<std::string> warned;
  std::lock_guard lock(mutex);
  if (warned.insert(warning).second) fmt::print(stderr, "{}\n", warning);
}

// The glTF model's materials, objects, lights and camera into `scene`; materials whose names
// `material_index` already holds (the scene file's own) stay the scene file's.
void add_gltf(Scene& scene, GltfModel&& model, std::map<std::string, uint32_t>& material_index) {
  std::vector<uint32_t> material_of;
  std::set<std::string> from_gltf;  // two glTF materials of one name stay two
  for (auto& m : model.materials) {
    const std::string name = m.name;
    for (int k = 2; from_gltf.count(m.name); ++k) m.name = fmt::format("{}#{}", name, k);
    from_gltf.insert(m.name);
    auto [it, added] = material_index.try_emplace(m.name, uint32_t(scene.materials.size()));
    if (added) scene.materials.push_back(m);
    material_of.push_back(it->second);
  }
  for (auto& o : model.objects) {
    Object object;
    object.name = o.name;
    object.shape = std::make_shared<MeshShape>("gltf", o.mesh);
    object.mesh = std::move(o.mesh);
    object.material = material_of[o.material];
    object.transform = std::move(o.transform);
    scene.objects.push_back(std::move(object));
  }
  for (auto& l : model.lights) scene.lights.push_back(std::move(l));
  if (model.camera) scene.camera = std::move(*model.camera);
}

Scene load_gltf_scene(const fs::path& file) {
  GltfModel model = load_gltf(file);
  warn_once(file, model);
  Scene scene;
  scene.name = file.stem().string();
  scene.file = file;
  scene.purpose = fmt::format("the glTF file {}", file.filename().string());
  scene.fps = 30;
  // The whole animation, or the default length of a still scene.
  scene.default_frames =
      model.duration > 0
          ? uint32_t(std::min<double>(std::ceil(double(model.duration) * scene.fps) + 1,
                                      config::kMaxMeasuredFrames))
          : 32;
  if (!model.camera)
    throw InputError(fmt::format(
        "{}: no perspective camera on a node of its scene; a scene file naming it (gltf: {{file: "
        "...}}) can give the camera",
        file.string()));
  std::map<std::string, uint32_t> material_index;
  add_gltf(scene, std::move(model), material_index);
  check_frames(scene, 0, scene.default_frames - 1);
  return scene;
}

}  // namespace

Scene load_scene(const fs::path& file) {
  if (is_gltf_path(file)) return load_gltf_scene(file);
  return parse_scene(config::read_text_file(file, config::kMaxYamlBytes, "scene file"), file);
}

Scene parse_scene(const std::string& text, const fs::path& file) {
  YamlView root = YamlView::parse(text, file.string());
  const char* keys = "purpose, fps, frames, gltf, camera, lights, materials, objects";
  if (root.node().IsNull() || !root.node().IsDefined())
    root.fail(fmt::format("the file is empty; a scene is a mapping of keys ({})", keys));
  if (!root.is_map())
    root.fail(fmt::format("not a scene file: a scene is a mapping of keys ({})", keys));
  kSceneTable.allow(root);
  Scene scene;
  scene.name = file.stem().string();
  scene.file = file;
  scene.purpose = kSceneTable.string(root, "purpose");
  scene.fps = float(kSceneTable.number(root, "fps"));
  scene.default_frames = uint32_t(kSceneTable.integer(root, "frames"));
  const std::optional<YamlView> gltf = root.get("gltf");
  // Without a glTF file the camera and the objects are required: reading them says so.
  if (!gltf || root.has("camera")) scene.camera = read_camera(root["camera"]);

  std::map<std::string, uint32_t> material_index;
  if (auto materials = root.get("materials")) {
    for (const auto& [name, spec] : materials->entries()) {
      if (material_index.count(name))
        spec.fail(fmt::format("material '{}' is defined twice", name));
      material_index[name] = uint32_t(scene.materials.size());
      scene.materials.push_back(read_material(name, spec));
    }
  }

  const fs::path directory = file.parent_path();
  std::set<std::string> object_names;
  size_t triangles = 0;
  if (gltf) {
    kGltfTable.allow(*gltf);
    YamlView file_key = (*gltf)["file"];
    const fs::path gltf_path = directory / file_key.as_string();
    if (!is_gltf_path(gltf_path)) file_key.fail("expected a .gltf or .glb file");
    GltfOptions options;
    options.camera = int(kGltfTable.integer(*gltf, "camera"));
    options.animate = kGltfTable.boolean(*gltf, "animate");
    GltfModel model;
    try {
      model = load_gltf(gltf_path, options);
    } catch (const InputError& e) {
      file_key.fail(e.what());
    }
    warn_once(gltf_path, model);
    if (!root.has("camera") && !model.camera)
      gltf->fail(
          fmt::format("{} has no perspective camera on a node of its scene; give the scene "
                      "a 'camera'",
                      gltf_path.string()));
    if (root.has("camera")) model.camera.reset();
    const size_t first_object = scene.objects.size();
    add_gltf(scene, std::move(model), material_index);
    for (size_t i = first_object; i < scene.objects.size(); ++i) {
      object_names.insert(scene.objects[i].name);
      triangles += scene.objects[i].mesh.triangle_count();
    }
    if (auto transforms = gltf->get("transforms")) {
      for (const auto& entry : transforms->entries()) {
        const std::string& name = entry.first;
        const YamlView& spec = entry.second;
        auto it = std::find_if(scene.objects.begin() + long(first_object), scene.objects.end(),
                               [&](const Object& o) { return o.name == name; });
        if (it == scene.objects.end()) {
          std::vector<std::string> names(object_names.begin(), object_names.end());
          std::string hint = config::closest_name(name, names);
          spec.fail(fmt::format("no object '{}' in {}{}", name, gltf_path.string(),
                                hint.empty() ? "" : fmt::format("; did you mean '{}'?", hint)));
        }
        it->transform = read_transform(spec);
      }
    }
  }

  std::set<std::string> light_names;
  for (const auto& l : scene.lights) light_names.insert(l.light.name);
  const size_t gltf_lights = scene.lights.size();
  if (auto lights = root.get("lights")) {
    if (!lights->is_sequence()) lights->fail("expected a list of lights");
    for (const auto& spec : lights->elements()) {
      LightTrack light = read_light(spec, scene.lights.size());
      // A light named as one of the glTF file's replaces it.
      auto same =
          std::find_if(scene.lights.begin(), scene.lights.begin() + long(gltf_lights),
                       [&](const LightTrack& l) { return l.light.name == light.light.name; });
      if (same != scene.lights.begin() + long(gltf_lights)) {
        *same = std::move(light);
        continue;
      }
      scene.lights.push_back(std::move(light));
      if (!light_names.insert(scene.lights.back().light.name).second)
        spec["name"].fail(
            fmt::format("a light named '{}' already exists", scene.lights.back().light.name));
    }
  }

  if (gltf && !root.has("objects")) {
    check_frames(scene, 0, scene.default_frames - 1);
    return scene;
  }
  YamlView objects = root["objects"];
  if (!objects.is_sequence() || objects.size() == 0)
    objects.fail("expected a non-empty list of objects");
  for (const auto& spec : objects.elements()) {
    if (!spec.is_map()) spec.fail("expected an object mapping with a 'shape'");
    kObjectTable.allow(spec);
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
      kShapes.back()->allow(shape_spec);  // the obj variant
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
        add(part_name,
            std::make_shared<MeshShape>(
                "obj", shape_spec.has("smooth_normals") &&
                               kShapes.back()->boolean(shape_spec, "smooth_normals")
                           ? smooth_normals(part.mesh)
                           : part.mesh),
            material);
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
    return root.is_map() && ((root.has("camera") && root.has("objects")) || root.has("gltf"));
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
                 given.extension() == ".yml" || is_gltf_path(given);
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
