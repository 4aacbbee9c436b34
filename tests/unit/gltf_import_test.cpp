// glTF 2.0 import: files the test writes itself, one per feature (each material kind and light kind
// maps to the harness's; a glTF camera matches the same camera written in a scene file; node
// animations become tracks; broken files name the element), and the glTF 2.0 fixtures Debian's
// assimp-testmodels ships.
#include "scene/gltf_import.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "photonbench/error.h"
#include "scene/scene.h"

namespace pb::scene {
namespace gltf_import_test {

namespace fs = std::filesystem;
using nlohmann::json;

std::string base64(const std::vector<unsigned char>& bytes) {
  static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t v = uint32_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= bytes[i + 2];
    out += digits[(v >> 18) & 63];
    out += digits[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? digits[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? digits[v & 63] : '=';
  }
  return out;
}

// A glTF document under construction: one buffer (embedded as a data URI) that accessors append
// to, and helpers for the common parts.
struct Doc {
  json j = {{"asset", {{"version", "2.0"}}}, {"scenes", json::array({{{"nodes", json::array()}}})},
            {"nodes", json::array()},        {"meshes", json::array()},
            {"accessors", json::array()},    {"bufferViews", json::array()}};
  std::vector<unsigned char> buffer;

  int accessor(const std::vector<float>& values, const char* type, int components) {
    const size_t offset = buffer.size();
    buffer.resize(offset + values.size() * 4);
    std::memcpy(buffer.data() + offset, values.data(), values.size() * 4);
    j["bufferViews"].push_back(
        {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", values.size() * 4}});
    j["accessors"].push_back({{"bufferView", j["bufferViews"].size() - 1},
                              {"componentType", 5126},
                              {"count", values.size() / components},
                              {"type", type}});
    return int(j["accessors"].size() - 1);
  }
  int indices(const std::vector<uint16_t>& values) {
    const size_t offset = buffer.size();
    buffer.resize(offset + ((values.size() * 2 + 3) & ~size_t(3)));
    std::memcpy(buffer.data() + offset, values.data(), values.size() * 2);
    j["bufferViews"].push_back(
        {{"buffer", 0}, {"byteOffset", offset}, {"byteLength", values.size() * 2}});
    j["accessors"].push_back({{"bufferView", j["bufferViews"].size() - 1},
                              {"componentType", 5123},
                              {"count", values.size()},
                              {"type", "SCALAR"}});
    return int(j["accessors"].size() - 1);
  }
  // A unit quad in the xy plane facing +z (two triangles), with normals unless `normals` is false.
  int quad_mesh(int material = -1, bool normals = true) {
    json attributes = {{"POSITION", accessor({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}, "VEC3", 3)}};
    if (normals) attributes["NORMAL"] = accessor({0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1}, "VEC3", 3);
    json primitive = {{"attributes", attributes}, {"indices", indices({0, 1, 2, 0, 2, 3})}};
    if (material >= 0) primitive["material"] = material;
    j["meshes"].push_back({{"primitives", json::array({primitive})}});
    return int(j["meshes"].size() - 1);
  }
  int node(json n) {
    j["nodes"].push_back(std::move(n));
    const int index = int(j["nodes"].size() - 1);
    j["scenes"][0]["nodes"].push_back(index);
    return index;
  }
  void use(const std::string& extension) {
    if (!j.contains("extensionsUsed")) j["extensionsUsed"] = json::array();
    j["extensionsUsed"].push_back(extension);
  }
  std::string text() {
    json out = j;
    out["buffers"] =
        json::array({{{"byteLength", buffer.size()},
                      {"uri", "data:application/octet-stream;base64," + base64(buffer)}}});
    return out.dump(1);
  }
};

fs::path scratch() {
  const fs::path dir =
      fs::temp_directory_path() /
      ("pb-gltf-test-" +
       std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  fs::create_directories(dir);
  return dir;
}

fs::path write(const fs::path& file, const std::string& text) {
  std::ofstream(file, std::ios::binary) << text;
  return file;
}

GltfModel load(Doc& doc, const std::string& name) {
  return load_gltf(write(scratch() / (name + ".gltf"), doc.text()));
}

// One file per material kind: what the glTF material becomes.
TEST(GltfImport, EachMaterialKindMapsToTheHarnessMaterial) {
  struct Case {
    const char* name;
    json material;
    std::vector<std::string> extensions;
    MaterialType type;
  };
  const json base = {{"baseColorFactor", {0.5, 0.25, 0.125, 1.0}}};
  auto pbr = [&](double metallic, double roughness) {
    json p = base;
    p["metallicFactor"] = metallic;
    p["roughnessFactor"] = roughness;
    return p;
  };
  const std::vector<Case> cases = {
      {"diffuse", {{"pbrMetallicRoughness", pbr(0, 1)}}, {}, MaterialType::diffuse},
      {"metal", {{"pbrMetallicRoughness", pbr(1, 0.5)}}, {}, MaterialType::rough_conductor},
      {"mirror", {{"pbrMetallicRoughness", pbr(1, 0)}}, {}, MaterialType::mirror},
      {"glass",
       {{"pbrMetallicRoughness", pbr(0, 0)},
        {"extensions",
         {{"KHR_materials_transmission", {{"transmissionFactor", 1.0}}},
          {"KHR_materials_ior", {{"ior", 1.33}}}}}},
       {"KHR_materials_transmission", "KHR_materials_ior"},
       MaterialType::dielectric},
      {"frosted",
       {{"pbrMetallicRoughness", pbr(0, 0.5)},
        {"extensions", {{"KHR_materials_transmission", {{"transmissionFactor", 1.0}}}}}},
       {"KHR_materials_transmission"},
       MaterialType::rough_dielectric},
      {"lamp",
       {{"pbrMetallicRoughness", pbr(0, 1)},
        {"emissiveFactor", {1.0, 0.5, 0.25}},
        {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 8.0}}}}}},
       {"KHR_materials_emissive_strength"},
       MaterialType::emissive},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    Doc doc;
    json material = c.material;
    material["name"] = c.name;
    doc.j["materials"] = json::array({material});
    for (const auto& e : c.extensions) doc.use(e);
    doc.node({{"mesh", doc.quad_mesh(0)}});
    GltfModel model = load(doc, c.name);
    ASSERT_EQ(model.objects.size(), 1u);
    const Material& m = model.materials.at(model.objects[0].material);
    EXPECT_EQ(m.name, c.name);
    EXPECT_EQ(m.type, c.type);
    EXPECT_TRUE(model.unsupported.empty()) << unsupported_warning("x", model);
    const glm::vec3 colour(0.5f, 0.25f, 0.125f);
    switch (c.type) {
      case MaterialType::diffuse:
        EXPECT_EQ(m.albedo, colour);
        break;
      case MaterialType::rough_conductor:
        EXPECT_EQ(m.specular, colour);
        EXPECT_FLOAT_EQ(m.roughness, 0.25f);  // alpha = roughness^2
        break;
      case MaterialType::mirror:
        EXPECT_EQ(m.specular, colour);
        break;
      case MaterialType::dielectric:
        EXPECT_FLOAT_EQ(m.ior, 1.33f);
        break;
      case MaterialType::rough_dielectric:
        EXPECT_FLOAT_EQ(m.ior, 1.5f);  // KHR_materials_ior's default
        EXPECT_FLOAT_EQ(m.roughness, 0.25f);
        break;
      case MaterialType::emissive:
        EXPECT_EQ(m.emission, glm::vec3(8.f, 4.f, 2.f));
        EXPECT_EQ(m.albedo, colour);
        break;
    }
  }
}

// One file per light kind: type, radiometric quantity (683 lm/W), position and the node's -z.
TEST(GltfImport, EachPunctualLightKindMapsToTheHarnessLight) {
  const glm::quat down = glm::angleAxis(-glm::half_pi<float>(), glm::vec3(1, 0, 0));  // -z -> -y
  for (const char* type : {"point", "spot", "directional"}) {
    SCOPED_TRACE(type);
    Doc doc;
    doc.use("KHR_lights_punctual");
    json light = {{"type", type}, {"color", {1.0, 0.5, 0.25}}, {"intensity", 683.0 * 2}};
    if (std::string(type) == "spot")
      light["spot"] = {{"innerConeAngle", 0.2}, {"outerConeAngle", 0.5}};
    doc.j["extensions"] = {{"KHR_lights_punctual", {{"lights", json::array({light})}}}};
    doc.node({{"mesh", doc.quad_mesh()}});
    doc.node({{"translation", {1.0, 2.0, 3.0}},
              {"rotation", {down.x, down.y, down.z, down.w}},
              {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
    GltfModel model = load(doc, type);
    ASSERT_EQ(model.lights.size(), 1u);
    const Light l = model.lights[0].at(0);
    EXPECT_EQ(l.type, std::string(type) == "point"  ? LightType::point
                      : std::string(type) == "spot" ? LightType::spot
                                                    : LightType::directional);
    EXPECT_NEAR(glm::length(l.radiant - glm::vec3(2.f, 1.f, 0.5f)), 0, 1e-5);
    EXPECT_NEAR(glm::length(l.position - glm::vec3(1, 2, 3)), 0, 1e-5);
    if (l.type != LightType::point)
      EXPECT_NEAR(glm::length(l.direction - glm::vec3(0, -1, 0)), 0, 1e-5);
    if (l.type == LightType::spot) {
      EXPECT_FLOAT_EQ(l.spot_inner, 0.2f);
      EXPECT_FLOAT_EQ(l.spot_outer, 0.5f);
    }
  }
}

// A camera in a glTF file and the same camera in a scene file give the same view and projection.
TEST(GltfImport, GltfCameraMatchesTheSameCameraWrittenInYaml) {
  Doc doc;
  // Looking from (1, 2, 5) at (0, 1, 0): the node's -z along that direction, +y as close to up as
  // a lookAt makes it.
  const glm::vec3 eye(1, 2, 5), target(0, 1, 0);
  const glm::mat4 view = glm::lookAt(eye, target, glm::vec3(0, 1, 0));
  const glm::quat rotation = glm::quat_cast(glm::mat3(glm::inverse(view)));
  doc.j["cameras"] = json::array(
      {{{"type", "perspective"},
        {"perspective", {{"yfov", glm::radians(40.0)}, {"znear", 0.05}, {"zfar", 50.0}}}}});
  doc.node({{"mesh", doc.quad_mesh()}});
  doc.node({{"camera", 0},
            {"translation", {eye.x, eye.y, eye.z}},
            {"rotation", {rotation.x, rotation.y, rotation.z, rotation.w}}});
  const fs::path dir = scratch();
  write(dir / "camera.gltf", doc.text());
  const Scene from_gltf = load_scene(dir / "camera.gltf");
  const Scene from_yaml = load_scene(write(dir / "camera.yaml", R"(purpose: the same camera
gltf: {file: camera.gltf}
camera: {position: [1, 2, 5], target: [0, 1, 0], fov_deg: 40, near: 0.05, far: 50}
)"));
  const Camera a = from_gltf.at(0).camera, b = from_yaml.at(0).camera;
  for (int c = 0; c < 4; ++c) {
    EXPECT_NEAR(glm::length(a.view()[c] - b.view()[c]), 0, 1e-5) << "view column " << c;
    EXPECT_NEAR(glm::length(a.projection(1.5f)[c] - b.projection(1.5f)[c]), 0, 1e-5)
        << "projection column " << c;
  }
}

// Normals: given ones are kept; absent ones are flat (the specification's rule).
TEST(GltfImport, NormalsAreReadOrMadeFlat) {
  for (bool with_normals : {true, false}) {
    SCOPED_TRACE(with_normals ? "NORMAL given" : "no NORMAL");
    Doc doc;
    doc.node({{"mesh", doc.quad_mesh(-1, with_normals)}, {"translation", {0.0, 0.0, 2.0}}});
    GltfModel model = load(doc, with_normals ? "normals" : "flat");
    ASSERT_EQ(model.objects.size(), 1u);
    const Mesh& m = model.objects[0].mesh;
    EXPECT_EQ(m.triangles.size(), 2u);
    EXPECT_EQ(m.positions.size(), with_normals ? 4u : 6u);  // flat: three vertices a triangle
    for (auto n : m.normals) EXPECT_NEAR(glm::length(n - glm::vec3(0, 0, 1)), 0, 1e-6);
    for (auto p : m.positions) EXPECT_FLOAT_EQ(p.z, 2.f);  // a still node is baked into the mesh
  }
}

// A node's translation and rotation channels become a transform track that reproduces them.
TEST(GltfImport, NodeAnimationBecomesTheObjectsTrack) {
  Doc doc;
  doc.node({{"mesh", doc.quad_mesh()}});
  const int times = doc.accessor({0, 1, 2}, "SCALAR", 1);
  const int moves = doc.accessor({0, 0, 0, 2, 0, 0, 2, 4, 0}, "VEC3", 3);
  const glm::quat q1 = glm::angleAxis(glm::radians(90.f), glm::vec3(0, 1, 0));
  const glm::quat q2 = glm::angleAxis(glm::radians(180.f), glm::vec3(0, 1, 0));
  const int turns =
      doc.accessor({0, 0, 0, 1, q1.x, q1.y, q1.z, q1.w, q2.x, q2.y, q2.z, q2.w}, "VEC4", 4);
  doc.j["animations"] = json::array(
      {{{"samplers", json::array({{{"input", times}, {"output", moves}},
                                  {{"input", times}, {"output", turns}}})},
        {"channels",
         json::array({{{"sampler", 0}, {"target", {{"node", 0}, {"path", "translation"}}}},
                      {{"sampler", 1}, {"target", {{"node", 0}, {"path", "rotation"}}}}})}}});
  GltfModel model = load(doc, "animated");
  ASSERT_EQ(model.objects.size(), 1u);
  EXPECT_FLOAT_EQ(model.duration, 2.f);
  const TransformTrack& track = model.objects[0].transform;
  ASSERT_TRUE(track.animated());
  for (float t : {0.f, 0.5f, 1.f, 1.25f, 2.f, 3.f}) {
    SCOPED_TRACE(t);
    const float u = std::min(t, 2.f);
    const glm::vec3 translation = u <= 1 ? glm::vec3(2 * u, 0, 0) : glm::vec3(2, 4 * (u - 1), 0);
    const glm::mat4 expected =
        glm::translate(glm::mat4(1), translation) *
        glm::mat4_cast(glm::angleAxis(glm::radians(90.f * u), glm::vec3(0, 1, 0)));
    const glm::mat4 got = track.at(t);
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(glm::length(got[c] - expected[c]), 0, 2e-3) << c;
  }
}

// Unsupported features are listed in one warning, each naming its element.
TEST(GltfImport, UnsupportedFeaturesAreListedInOneWarning) {
  Doc doc;
  doc.use("KHR_materials_clearcoat");
  doc.j["materials"] = json::array(
      {{{"alphaMode", "BLEND"},
        {"pbrMetallicRoughness", {{"metallicFactor", 0.0}, {"baseColorTexture", {{"index", 0}}}}},
        {"extensions", {{"KHR_materials_clearcoat", {{"clearcoatFactor", 1.0}}}}}}});
  doc.j["textures"] = json::array({{{"source", 0}}});
  doc.j["images"] = json::array({{{"uri", "missing.png"}}});
  doc.node({{"mesh", doc.quad_mesh(0)}});
  GltfModel model = load(doc, "unsupported");
  const std::string warning = unsupported_warning("file.gltf", model);
  EXPECT_NE(warning.find("warning: file.gltf:"), std::string::npos) << warning;
  for (const char* part :
       {"extension KHR_materials_clearcoat", "materials[0]: baseColorTexture",
        "materials[0]: alphaMode BLEND", "materials[0]: extension KHR_materials_clearcoat"})
    EXPECT_NE(warning.find(part), std::string::npos) << part << " in " << warning;
}

// A scene file naming a glTF file adds objects and overrides a light by name.
TEST(GltfImport, SceneFileAddsToAndOverridesTheGltf) {
  Doc doc;
  doc.use("KHR_lights_punctual");
  doc.j["extensions"] = {
      {"KHR_lights_punctual", {{"lights", json::array({{{"type", "point"}, {"name", "bulb"}}})}}}};
  doc.node({{"mesh", doc.quad_mesh()}, {"name", "panel"}});
  doc.node({{"translation", {0.0, 3.0, 0.0}},
            {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
  const fs::path dir = scratch();
  write(dir / "base.gltf", doc.text());
  const Scene scene = load_scene(write(dir / "base.yaml", R"(purpose: overrides
gltf:
  file: base.gltf
  transforms: {panel: {translate: [0, 0, -1]}}
camera: {position: [0, 0, 4], target: [0, 0, 0], fov_deg: 45}
lights:
  - {name: bulb, type: point, position: [0, 5, 0], intensity: 3}
  - {name: fill, type: point, position: [0, 5, 5], intensity: 1}
materials:
  grey: {type: diffuse, albedo: 0.5}
objects:
  - {name: floor, shape: {type: quad}, material: grey}
)"));
  ASSERT_EQ(scene.lights.size(), 2u);
  EXPECT_EQ(scene.lights[0].light.name, "bulb");
  EXPECT_EQ(scene.lights[0].at(0).position, glm::vec3(0, 5, 0));
  EXPECT_FLOAT_EQ(scene.lights[0].at(0).radiant.x, 3.f);
  ASSERT_EQ(scene.objects.size(), 2u);
  EXPECT_EQ(scene.objects[0].name, "panel");
  EXPECT_EQ(glm::vec3(scene.at(0).object_to_world[0][3]), glm::vec3(0, 0, -1));
}

// Broken files: an InputError naming the file and the element.
TEST(GltfImport, BadFilesNameTheElement) {
  struct Case {
    const char* name;
    std::function<void(Doc&)> spoil;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"accessor", [](Doc& d) { d.j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 7; },
       "meshes[0].primitives[0]: POSITION: accessor 7 out of range (the file has 3)"},
      {"index",
       [](Doc& d) {
         d.j["accessors"][2]["byteOffset"] = 2;
         d.j["accessors"][2]["count"] = 6;
       },
       "meshes[0].primitives[0]: indices: accessor 2: 6 elements from byte 2 reach past"},
      {"material", [](Doc& d) { d.j["meshes"][0]["primitives"][0]["material"] = 4; },
       "meshes[0].primitives[0]: material 4 out of range (the file has 0)"},
      {"child", [](Doc& d) { d.j["nodes"][0]["children"] = {0}; },
       "nodes[0]: child 0 has another parent or closes a cycle"},
      {"mesh", [](Doc& d) { d.j["nodes"][0]["mesh"] = 3; },
       "nodes[0]: mesh 3 out of range (the file has 1)"},
      {"version", [](Doc& d) { d.j.erase("asset"); }, "asset"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    Doc doc;
    doc.node({{"mesh", doc.quad_mesh()}});
    c.spoil(doc);
    const fs::path file = scratch() / (std::string(c.name) + ".gltf");
    try {
      load_gltf(write(file, doc.text()));
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(file.string() + ": ", 0), 0u) << message;
      EXPECT_NE(message.find(c.message), std::string::npos) << message;
    }
  }
  // Not JSON at all.
  const fs::path not_json = write(scratch() / "text.gltf", "{\"asset\": [1, 2");
  EXPECT_THROW(load_gltf(not_json), InputError);
  // An index past the vertices, with its position in the index list.
  Doc doc;
  doc.node({{"mesh", doc.quad_mesh()}});
  doc.indices({0, 1, 9});
  doc.j["meshes"][0]["primitives"][0]["indices"] = 3;
  try {
    load(doc, "vertex");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "meshes[0].primitives[0]: indices[2] = 9 out of range (POSITION has 4 vertices)"),
              std::string::npos)
        << e.what();
  }
}

// Debian's assimp-testmodels: the well-formed files load, the broken ones are InputErrors.
TEST(GltfImport, AssimpTestModelsLoadOrFailCleanly) {
  const fs::path root = "/usr/share/assimp/models/glTF2";
  if (!fs::is_directory(root)) GTEST_SKIP() << root << " is absent (apt install assimp-testmodels)";
  size_t loaded = 0, refused = 0;
  std::map<std::string, bool> outcome;  // path under root -> loaded
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file() || !is_gltf_path(entry.path())) continue;
    try {
      GltfModel model = load_gltf(entry.path());
      EXPECT_FALSE(model.objects.empty()) << entry.path();
      ++loaded;
      outcome[fs::relative(entry.path(), root).string()] = true;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(entry.path().string(), 0), 0u) << e.what();
      ++refused;
      outcome[fs::relative(entry.path(), root).string()] = false;
    }
  }
  EXPECT_GE(loaded, 20u);
  for (const char* good :
       {"BoxTextured-glTF/BoxTextured.gltf", "BoxTextured-glTF-Binary/BoxTextured.glb",
        "2CylinderEngine-glTF-Binary/2CylinderEngine.glb", "cameras/Cameras.gltf"})
    EXPECT_TRUE(outcome.count(good) && outcome[good]) << good;
  for (const char* bad : {"IndexOutOfRange/IndexOutOfRange.gltf",
                          "RecursiveNodes/RecursiveNodes.gltf", "MissingBin/BoxTextured.gltf"})
    EXPECT_TRUE(outcome.count(bad) && !outcome[bad]) << bad;
  RecordProperty("loaded", int(loaded));
  RecordProperty("refused", int(refused));
}

}  // namespace gltf_import_test
}  // namespace pb::scene
