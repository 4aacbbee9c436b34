// Scenes: each shape's tessellation against closed-form counts, areas, volumes and normals; OBJ/MTL
// import; every scene under scenes/ loads and animates; errors name file:line:col and the key path;
// the camera's matrices map to Vulkan clip space.
#include "scene/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/gtc/constants.hpp>
#include <regex>

#include "photonbench/error.h"
#include "scene/obj_import.h"
#include "scene/shapes.h"
#include "trace/embree_scene.h"

namespace pb::scene {
namespace scene_test {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;

const fs::path kData = fs::path(PB_TEST_DATA_DIR) / "scenes";
const fs::path kScenes = fs::path(PB_SOURCE_DIR) / "scenes";

double area(const Mesh& m) {
  double a = 0;
  for (auto t : m.triangles) {
    glm::dvec3 p0 = m.positions[t.x], p1 = m.positions[t.y], p2 = m.positions[t.z];
    a += 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
  }
  return a;
}

// Signed volume by the divergence theorem; positive for a closed mesh wound outward.
double volume(const Mesh& m) {
  double v = 0;
  for (auto t : m.triangles) {
    glm::dvec3 p0 = m.positions[t.x], p1 = m.positions[t.y], p2 = m.positions[t.z];
    v += glm::dot(p0, glm::cross(p1, p2)) / 6.0;
  }
  return v;
}

// Every triangle's winding agrees with its vertex normals, every normal is unit length, no triangle
// is degenerate and every index is in range.
void expect_well_formed(const Mesh& m) {
  ASSERT_EQ(m.positions.size(), m.normals.size());
  for (auto n : m.normals) ASSERT_NEAR(glm::length(n), 1.0f, 1e-5f);
  for (auto t : m.triangles) {
    ASSERT_LT(std::max({t.x, t.y, t.z}), m.positions.size());
    glm::vec3 g =
        glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]);
    ASSERT_GT(glm::length(g), 0.0f) << "degenerate triangle";
    for (uint32_t i : {t.x, t.y, t.z}) ASSERT_GT(glm::dot(glm::normalize(g), m.normals[i]), 0.0f);
  }
}

TEST(Shapes, QuadIsTwoTrianglesFacingUp) {
  Mesh m = QuadShape({2.0f, 3.0f}).tessellate(0);
  expect_well_formed(m);
  EXPECT_EQ(m.triangle_count(), 2u);
  EXPECT_NEAR(area(m), 6.0, 1e-6);
  for (auto n : m.normals) EXPECT_EQ(n, glm::vec3(0, 1, 0));
  for (auto p : m.positions) EXPECT_EQ(p.y, 0.0f);
}

TEST(Shapes, BoxAreaVolumeAndOutwardNormals) {
  Mesh m = BoxShape({1.0f, 2.0f, 3.0f}).tessellate(0);
  expect_well_formed(m);
  EXPECT_EQ(m.triangle_count(), 12u);
  EXPECT_NEAR(area(m), 2 * (1 * 2 + 2 * 3 + 3 * 1), 1e-5);
  EXPECT_NEAR(volume(m), 6.0, 1e-5);
  for (size_t i = 0; i < m.positions.size(); ++i) {
    // Each vertex lies on the face its normal names.
    glm::vec3 n = m.normals[i], p = m.positions[i];
    EXPECT_NEAR(glm::dot(p, n), glm::dot(glm::abs(n), glm::vec3(0.5f, 1.0f, 1.5f)), 1e-6);
  }
}

TEST(Shapes, SphereConvergesToFourPiRSquared) {
  const float r = 0.7f;
  double previous_error = 1e9, error_64 = 0;
  for (uint32_t segments : {8u, 16u, 64u, 256u}) {
    SphereShape shape(r, segments);
    Mesh m = shape.tessellate(0);
    expect_well_formed(m);
    EXPECT_EQ(m.triangle_count(), 2u * segments * (shape.stacks() - 1));
    double error = std::abs(area(m) - 4 * kPi * r * r) / (4 * kPi * r * r);
    EXPECT_LT(error, previous_error);
    previous_error = error;
    if (segments == 64) error_64 = error;
    EXPECT_GT(volume(m), 0.0);
    EXPECT_LT(volume(m), 4.0 / 3.0 * kPi * r * r * r);  // inscribed
    for (size_t i = 0; i < m.positions.size(); ++i) {
      EXPECT_NEAR(glm::length(m.positions[i]), r, 1e-5);
      EXPECT_LT(glm::length(m.normals[i] - m.positions[i] / r), 1e-5f);
    }
  }
  // Second-order convergence of the inscribed polyhedron: 4x the segments, 1/16 the error.
  EXPECT_LT(previous_error, 2e-4);  // 256 segments
  EXPECT_NEAR(error_64 / previous_error, 16.0, 2.0);
  EXPECT_NEAR(volume(SphereShape(r, 256).tessellate(0)), 4.0 / 3.0 * kPi * r * r * r, 1e-3);
}

TEST(Shapes, CappedCylinderMatchesItsPolygonAndTheCircle) {
  const float r = 0.3f, h = 1.2f;
  for (uint32_t n : {6u, 32u, 512u}) {
    Mesh m = CylinderShape(r, h, n, true).tessellate(0);
    expect_well_formed(m);
    EXPECT_EQ(m.triangle_count(), 4u * n);
    // Exactly the inscribed n-gon prism.
    double chord = 2 * r * std::sin(kPi / n), polygon = 0.5 * n * r * r * std::sin(2 * kPi / n);
    EXPECT_NEAR(area(m), n * chord * h + 2 * polygon, 1e-4);
    EXPECT_NEAR(volume(m), polygon * h, 1e-4);
    for (auto p : m.positions) EXPECT_NEAR(std::abs(p.y), h / 2, 1e-6);
  }
  Mesh fine = CylinderShape(r, h, 512, true).tessellate(0);
  EXPECT_NEAR(area(fine), 2 * kPi * r * h + 2 * kPi * r * r, 1e-3 * area(fine));
  EXPECT_EQ(CylinderShape(r, h, 16, false).tessellate(0).triangle_count(), 32u);
}

TEST(Shapes, TubeHasInwardInnerWallAndAnnularCaps) {
  const float r = 0.5f, inner = 0.45f, h = 0.2f;
  const uint32_t n = 1024;
  Mesh m = CylinderShape(r, h, n, true, inner).tessellate(0);
  expect_well_formed(m);
  EXPECT_EQ(m.triangle_count(), 8u * n);
  double expected = 2 * kPi * (r + inner) * h + 2 * kPi * (r * r - inner * inner);
  EXPECT_NEAR(area(m), expected, 1e-3 * expected);
  double solid = kPi * (r * r - inner * inner) * h;
  EXPECT_NEAR(volume(m), solid, 1e-3 * solid);
  // Inner-wall vertices face the axis.
  for (size_t i = 0; i < m.positions.size(); ++i) {
    glm::vec2 radial(m.positions[i].x, m.positions[i].z);
    if (std::abs(glm::length(radial) - inner) < 1e-5f && m.normals[i].y == 0)
      EXPECT_LT(glm::dot(glm::vec2(m.normals[i].x, m.normals[i].z), radial), 0.0f);
  }
}

TEST(Shapes, TorusAreaAndVolume) {
  const float R = 0.5f, r = 0.15f;
  Mesh m = TorusShape(R, r, 256, 128).tessellate(0);
  expect_well_formed(m);
  EXPECT_EQ(m.triangle_count(), 2u * 256 * 128);
  EXPECT_NEAR(area(m), 4 * kPi * kPi * R * r, 1e-3 * 4 * kPi * kPi * R * r);
  EXPECT_NEAR(volume(m), 2 * kPi * kPi * R * r * r, 1e-3 * 2 * kPi * kPi * R * r * r);
  for (size_t i = 0; i < m.positions.size(); ++i) {
    glm::vec3 p = m.positions[i];
    glm::vec3 ring = R * glm::normalize(glm::vec3(p.x, 0, p.z));
    EXPECT_NEAR(glm::length(p - ring), r, 1e-5);
    EXPECT_LT(glm::length(m.normals[i] - (p - ring) / r), 1e-4f);
  }
}

TEST(Shapes, StaticHeightFieldIsAFlatGrid) {
  HeightFieldShape flat({4.0f, 2.0f}, {8, 5}, {});
  EXPECT_FALSE(flat.animated());
  Mesh m = flat.tessellate(0);
  expect_well_formed(m);
  EXPECT_EQ(m.triangle_count(), 2u * 8 * 5);
  EXPECT_NEAR(area(m), 8.0, 1e-5);
  // A wave that does not travel is static too.
  EXPECT_FALSE(HeightFieldShape({1, 1}, {2, 2}, {Wave{0.1f, 1.0f, 0.0f, {1, 0}, 0}}).animated());
}

TEST(Shapes, WaterHeightFieldFollowsItsSineSum) {
  std::vector<Wave> waves = {Wave{0.05f, 1.3f, 1.4f, glm::normalize(glm::vec2(1, 0.5f)), 0.3f},
                             Wave{0.02f, 0.6f, 0.9f, glm::normalize(glm::vec2(-0.2f, 1)), 1.0f}};
  HeightFieldShape water({3.0f, 3.0f}, {60, 60}, waves);
  EXPECT_TRUE(water.animated());
  for (float t : {0.0f, 0.77f}) {
    Mesh m = water.tessellate(t);
    expect_well_formed(m);
    for (size_t i = 0; i < m.positions.size(); i += 37) {
      glm::vec3 p = m.positions[i];
      double h = 0;
      for (const auto& w : waves)
        h += w.amplitude * std::sin(2 * kPi / w.wavelength *
                                        (w.direction.x * p.x + w.direction.y * p.z - w.speed * t) +
                                    w.phase);
      EXPECT_NEAR(p.y, h, 1e-5);
      // The analytic normal is the finite-difference gradient's.
      const float e = 1e-3f;
      float dx = (water.height(p.x + e, p.z, t) - water.height(p.x - e, p.z, t)) / (2 * e);
      float dz = (water.height(p.x, p.z + e, t) - water.height(p.x, p.z - e, t)) / (2 * e);
      EXPECT_LT(glm::length(m.normals[i] - glm::normalize(glm::vec3(-dx, 1, -dz))), 2e-3f);
    }
  }
  // Travelling: after one period of the first wave alone, the surface repeats.
  HeightFieldShape single({2, 2}, {10, 10}, {waves[0]});
  float period = waves[0].wavelength / waves[0].speed;
  Mesh a = single.tessellate(0.2f), b = single.tessellate(0.2f + period),
       c = single.tessellate(0.5f);
  for (size_t i = 0; i < a.positions.size(); ++i)
    EXPECT_NEAR(a.positions[i].y, b.positions[i].y, 1e-4);
  EXPECT_NE(a.positions, c.positions);
}

TEST(Obj, MtlMaterialsAreMapped) {
  ObjModel model = load_obj(kData / "mixed.obj");
  ASSERT_EQ(model.materials.size(), 5u);
  auto find = [&](const std::string& name) -> const Material& {
    for (const auto& m : model.materials)
      if (m.name == name) return m;
    throw std::runtime_error("no material " + name);
  };
  EXPECT_EQ(find("white").type, MaterialType::diffuse);
  EXPECT_EQ(find("white").albedo, glm::vec3(0.7f, 0.6f, 0.5f));
  EXPECT_EQ(find("lamp").type, MaterialType::emissive);
  EXPECT_EQ(find("lamp").emission, glm::vec3(5, 4, 3));
  EXPECT_EQ(find("lamp").albedo, glm::vec3(0.2f));
  EXPECT_EQ(find("glass").type, MaterialType::dielectric);
  EXPECT_FLOAT_EQ(find("glass").ior, 1.45f);
  EXPECT_EQ(find("glass7").type, MaterialType::dielectric);
  EXPECT_FLOAT_EQ(find("glass7").ior, 1.5f);  // illum 7 without Ni
  EXPECT_EQ(find("chrome").type, MaterialType::mirror);
  EXPECT_EQ(find("chrome").specular, glm::vec3(0.9f, 0.8f, 0.7f));

  ASSERT_EQ(model.parts.size(), 5u);
  size_t triangles[] = {2, 1, 4, 1, 1};  // the square polygon is triangulated
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(model.parts[i].mesh.triangle_count(), triangles[i]);
    EXPECT_EQ(model.materials[model.parts[i].material].name,
              std::vector<std::string>({"white", "lamp", "glass", "glass7", "chrome"})[i]);
  }
  // The square shares its four vertices (one normal index); the lamp triangle, without normals,
  // gets its flat face normal.
  EXPECT_EQ(model.parts[0].mesh.positions.size(), 4u);
  EXPECT_NEAR(area(model.parts[0].mesh), 1.0, 1e-6);
  EXPECT_EQ(model.parts[1].mesh.positions.size(), 3u);
  for (auto n : model.parts[1].mesh.normals) EXPECT_LT(glm::length(n - glm::vec3(0, -1, 0)), 1e-6f);
}

TEST(Obj, SceneNamesObjMaterialsAndLetsTheSceneOverride) {
  Scene scene = load_scene(kData / "obj-scene.yaml");
  ASSERT_EQ(scene.objects.size(), 6u);  // five parts of mixed.obj and the plain triangle
  EXPECT_EQ(scene.objects[0].name, "mixed/white");
  EXPECT_EQ(scene.objects[5].name, "tri");
  auto material_of = [&](size_t i) -> const Material& {
    return scene.materials[scene.objects[i].material];
  };
  EXPECT_EQ(material_of(0).name, "mixed/white");
  EXPECT_EQ(material_of(0).type, MaterialType::diffuse);
  EXPECT_EQ(material_of(1).name, "mixed/lamp");
  EXPECT_EQ(material_of(1).type, MaterialType::emissive);
  EXPECT_EQ(material_of(2).type, MaterialType::dielectric);
  // The scene defines mixed/glass7 itself, which wins over the MTL's.
  EXPECT_EQ(material_of(3).name, "mixed/glass7");
  EXPECT_EQ(material_of(3).type, MaterialType::rough_dielectric);
  EXPECT_FLOAT_EQ(material_of(3).ior, 1.33f);
  EXPECT_EQ(material_of(4).type, MaterialType::mirror);
  EXPECT_EQ(material_of(5).name, "floor");
  for (size_t i = 0; i < 5; ++i)
    EXPECT_EQ(scene.objects[i].transform.at(0)[3],
              glm::vec4(0, 0.5f, 0, 1));  // parts share the transform
}

// Writes `text` as a scene file in a fresh directory and returns the load error's message.
std::string load_error(const std::string& text, const std::string& file_name = "bad.yaml") {
  fs::path dir = fs::temp_directory_path() / ("pb_scene_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  fs::path file = dir / file_name;
  std::ofstream(file) << text;
  try {
    load_scene(file);
  } catch (const InputError& e) {
    fs::remove_all(dir);
    return e.what();
  }
  fs::remove_all(dir);
  ADD_FAILURE() << "no error for:\n" << text;
  return "";
}

const std::string kGoodHead =
    "purpose: test\n"
    "camera: {position: [0, 1, 3], target: [0, 0, 0], fov_deg: 45}\n"
    "materials:\n"
    "  white: {type: diffuse, albedo: 0.8}\n";

TEST(SceneErrors, UnknownKeyNamesFileLineColumnAndKey) {
  std::string message = load_error(kGoodHead +
                                   "objects:\n"
                                   "  - shape: {type: sphere, radius: 0.5, segmets: 12}\n"
                                   "    material: white\n");
  EXPECT_NE(message.find(
                "bad.yaml:6:40: objects[0].shape.segmets: unknown key; did you mean 'segments'?"),
            std::string::npos)
      << message;
}

TEST(SceneErrors, WrongTypeNamesFileLineColumnAndKey) {
  std::string message = load_error(kGoodHead +
                                   "objects:\n"
                                   "  - shape: {type: box, size: [1, 1, 1]}\n"
                                   "    material: white\n"
                                   "    transform: {translate: up}\n");
  EXPECT_NE(
      message.find("bad.yaml:8:28: objects[0].transform.translate: expected a number, got 'up'"),
      std::string::npos)
      << message;
  message = load_error(kGoodHead +
                       "lights:\n"
                       "  - {type: point, position: [0, 1, 0], intensity: bright}\n"
                       "objects: [{shape: {type: quad}, material: white}]\n");
  EXPECT_NE(message.find("bad.yaml:6:51: lights[0].intensity: expected a number, got 'bright'"),
            std::string::npos)
      << message;
}

TEST(SceneErrors, OutOfRangeNamesFileLineColumnAndKey) {
  std::string message = load_error(kGoodHead +
                                   "  glass: {type: dielectric, ior: 0.5}\n"
                                   "objects: [{shape: {type: quad}, material: glass}]\n");
  EXPECT_NE(message.find("bad.yaml:5:34: materials.glass.ior: value 0.5 is out of range [1, 4]"),
            std::string::npos)
      << message;
  message =
      load_error(kGoodHead + "objects: [{shape: {type: sphere, segments: 2}, material: white}]\n");
  EXPECT_NE(
      message.find("bad.yaml:5:44: objects[0].shape.segments: value 2 is out of range [3, 1024]"),
      std::string::npos)
      << message;
  message = load_error(kGoodHead +
                       "  red: {type: diffuse, albedo: [1.2, 0, 0]}\n"
                       "objects: [{shape: {type: quad}, material: red}]\n");
  EXPECT_NE(
      message.find("bad.yaml:5:33: materials.red.albedo[0]: value 1.2 is out of range [0, 1]"),
      std::string::npos)
      << message;
}

TEST(SceneErrors, MissingObjFileNamesFileLineColumnAndKey) {
  std::string message = load_error(kGoodHead +
                                   "objects:\n"
                                   "  - shape: {type: obj, file: meshes/nothere.obj}\n"
                                   "    material: white\n");
  EXPECT_TRUE(std::regex_search(
      message,
      std::regex(
          R"(bad\.yaml:6:30: objects\[0\]\.shape\.file: .*/nothere\.obj: OBJ file not found)")))
      << message;
}

TEST(SceneErrors, ObjErrorsNameTheObjFileAndLine) {
  auto with_obj = [&](const std::string& obj) {
    return load_error(kGoodHead + "objects:\n  - shape: {type: obj, file: " +
                      (kData / obj).string() + "}\n    material: white\n");
  };
  // Absolute paths stay absolute when joined to the scene's directory.
  std::string message = with_obj("bad-index.obj");
  EXPECT_NE(message.find("objects[0].shape.file: "), std::string::npos) << message;
  EXPECT_NE(message.find("bad-index.obj:5: face refers to vertex 9 but the file has only 3"),
            std::string::npos)
      << message;
  message = with_obj("missing-mtl.obj");
  EXPECT_NE(message.find("missing-mtl.obj:1: MTL file 'nowhere.mtl' not found"), std::string::npos)
      << message;
  message = with_obj("unknown-usemtl.obj");
  EXPECT_NE(message.find("unknown-usemtl.obj:7: usemtl 'marble': no such material"),
            std::string::npos)
      << message;
}

TEST(SceneErrors, UnknownMaterialAndMissingKeys) {
  std::string message =
      load_error(kGoodHead + "objects: [{shape: {type: quad}, material: whit}]\n");
  EXPECT_NE(
      message.find(
          "bad.yaml:5:43: objects[0].material: unknown material 'whit'; did you mean 'white'?"),
      std::string::npos)
      << message;
  message = load_error(
      "camera: {position: [0, 1, 3], target: [0, 0, 0], fov_deg: 45}\n"
      "objects: []\n");
  EXPECT_NE(message.find("missing required key 'purpose'"), std::string::npos) << message;
  message = load_error(kGoodHead +
                       "lights: [{type: point, position: [0, 1, 0]}]\n"
                       "objects: [{shape: {type: quad}, material: white}]\n");
  EXPECT_NE(message.find("lights[0]: a point light needs exactly one of 'intensity' or 'power'"),
            std::string::npos)
      << message;
  message = load_error(kGoodHead +
                       "objects:\n  - shape: {type: quad}\n    material: white\n"
                       "    transform: {rotate_deg: {keys: [[0, 0], [0, 90]]}}\n");
  EXPECT_NE(
      message.find("bad.yaml:8:46: objects[0].transform.rotate_deg.keys[1][0]: key times must be "
                   "strictly increasing"),
      std::string::npos)
      << message;
}

TEST(SceneFile, ReadsTracksLightsAndUnits) {
  fs::path dir = fs::temp_directory_path() / ("pb_scene_test_ok_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "tracks.yaml")
      << kGoodHead
      << "fps: 24\n"
         "frames: 48\n"
         "lights:\n"
         "  - {name: bulb, type: point, position: {orbit: {center: [0, 1, 0], radius: 2, period: "
         "4}}, power: 100}\n"
         "  - {type: spot, position: [0, 3, 0], target: [1, 0, 0], intensity: 5, color: [1, 0.5, "
         "0.25],\n"
         "     inner_deg: 10, outer_deg: 20}\n"
         "  - {type: directional, direction: [0, -2, 0], irradiance: 3}\n"
         "  - {type: quad, position: [0, 2, 0], edge_u: [0.5, 0, 0], edge_v: [0, 0, 0.4], power: "
         "10}\n"
         "  - {type: disc, position: {keys: [[0, [0, 2, 0]], [2, [2, 2, 0]]]}, normal: [1, -2, "
         "0.5],"
         " radius: 0.3, power: 10}\n"
         "objects:\n"
         "  - name: ball\n"
         "    shape: {type: sphere, radius: 0.25, segments: 12}\n"
         "    material: white\n"
         "    transform:\n"
         "      translate: {keys: [[0, [0, 0, 0]], [1, [1, 0, 0]], [2, [0, 0, 0]]], interpolation: "
         "catmull-rom, loop: true}\n"
         "      spin_deg_per_s: [0, 90, 0]\n"
         "      scale: 2\n";
  Scene scene = load_scene(dir / "tracks.yaml");
  EXPECT_EQ(scene.name, "tracks");
  EXPECT_EQ(scene.fps, 24.0f);
  EXPECT_EQ(scene.default_frames, 48u);
  ASSERT_EQ(scene.lights.size(), 5u);
  EXPECT_EQ(scene.lights[0].light.name, "bulb");
  EXPECT_EQ(scene.lights[1].light.name, "light1");
  // Point power P -> intensity P / 4 pi; quad power P -> radiance P / (pi A).
  EXPECT_NEAR(scene.lights[0].light.radiant.x, 100 / (4 * kPi), 1e-4);
  EXPECT_NEAR(scene.lights[3].light.radiant.x, 10 / (kPi * 0.2), 1e-4);
  EXPECT_LT(glm::length(scene.lights[3].light.normal() - glm::vec3(0, -1, 0)),
            1e-6f);  // u x v faces down
  // Disc: two orthogonal radii whose cross product is the unit normal; power P -> P / (pi^2 r^2).
  const Light& disc = scene.lights[4].light;
  EXPECT_EQ(disc.type, LightType::disc);
  EXPECT_LT(glm::length(disc.normal() - glm::normalize(glm::vec3(1, -2, 0.5f))), 1e-6f);
  EXPECT_NEAR(glm::length(disc.edge_u), 0.3f, 1e-6f);
  EXPECT_NEAR(glm::length(disc.edge_v), 0.3f, 1e-6f);
  EXPECT_NEAR(glm::dot(disc.edge_u, disc.edge_v), 0.f, 1e-6f);
  EXPECT_NEAR(disc.area(), kPi * 0.09f, 1e-6f);
  EXPECT_NEAR(disc.radiant.x, 10 / (kPi * kPi * 0.09f), 1e-4);
  EXPECT_EQ(scene.lights[1].light.radiant, glm::vec3(5, 2.5f, 1.25f));
  EXPECT_NEAR(scene.lights[1].light.spot_outer, glm::radians(20.0f), 1e-6);
  EXPECT_EQ(scene.lights[2].light.direction, glm::vec3(0, -1, 0));
  FrameState s = scene.at(24);  // t = 1 s: a quarter orbit, the ball at its far key
  EXPECT_LT(glm::length(s.lights[0].position - glm::vec3(0, 1, -2)), 1e-5f);
  EXPECT_LT(glm::length(s.lights[4].position - glm::vec3(1, 2, 0)), 1e-5f);  // the centre moves
  EXPECT_EQ(s.lights[4].edge_u, disc.edge_u);
  EXPECT_LT(glm::length(s.lights[1].direction - glm::normalize(glm::vec3(1, -3, 0))), 1e-6f);
  EXPECT_LT(glm::length(glm::vec3(s.object_to_world[0][3]) - glm::vec3(1, 0, 0)), 1e-5f);
  EXPECT_TRUE(scene.objects[0].moves());
  EXPECT_EQ(scene.objects[0].mesh.triangle_count(), 2u * 12 * 5);
  fs::remove_all(dir);
}

TEST(Camera, ViewAndVulkanProjection) {
  Camera c;
  c.position = {1, 2, 5};
  c.target = {1, 2, 0};
  c.fov_y = glm::radians(90.0f);
  c.near_plane = 0.1f;
  c.far_plane = 10.0f;
  glm::mat4 vp = c.projection(2.0f) * c.view();
  auto ndc = [&](glm::vec3 p) {
    glm::vec4 clip = vp * glm::vec4(p, 1);
    return glm::vec3(clip) / clip.w;
  };
  // The target is at the centre; up in the world is up on screen, which is -y in Vulkan.
  EXPECT_LT(glm::length(glm::vec2(ndc({1, 2, 0}))), 1e-6f);
  EXPECT_NEAR(ndc({1, 3, 4}).y, -1.0f,
              1e-5);  // 1 up at distance 1 with a 90 degree fov: the top edge
  EXPECT_NEAR(ndc({3, 2, 4}).x, 1.0f, 1e-5);     // right edge at aspect 2
  EXPECT_NEAR(ndc({1, 2, 4.9f}).z, 0.0f, 1e-5);  // near plane -> depth 0
  EXPECT_NEAR(ndc({1, 2, -5}).z, 1.0f, 1e-5);    // far plane -> depth 1
  glm::vec3 in_view = glm::vec3(c.view() * glm::vec4(1, 2, 0, 1));
  EXPECT_LT(glm::length(in_view - glm::vec3(0, 0, -5)), 1e-5f);  // looks down -z
}

TEST(Scene, BoundsCoverTransformedMeshes) {
  Scene scene;
  Object box;
  box.shape = std::make_shared<BoxShape>(glm::vec3(1, 2, 3));
  box.mesh = box.shape->tessellate(0);
  box.transform.translation.constant = {10, 0, 0};
  box.transform.scale = {2, 1, 1};
  scene.objects.push_back(box);
  auto [lo, hi] = scene.bounds();
  EXPECT_EQ(lo, glm::vec3(9, -1, -1.5f));
  EXPECT_EQ(hi, glm::vec3(11, 1, 1.5f));
}

const std::vector<std::string> kExpectedScenes = {
    "cornell-box", "cornell-glass", "dynamic-room", "merry-go-round",      "mirror-box", "pillars",
    "pool",        "ring",          "villa",        "torus-in-glass-cube", "walker"};

TEST(SceneFiles, EveryShippedSceneLoadsAndAnimates) {
  std::vector<std::string> names = list_scenes({});
  for (const auto& expected : kExpectedScenes)
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  for (const auto& name : names) {
    SCOPED_TRACE(name);
    Scene scene = load_scene(find_scene(name, {}));
    EXPECT_EQ(scene.name, name);
    EXPECT_GT(scene.purpose.size(), 20u);
    EXPECT_FALSE(scene.lights.empty());
    size_t triangles = 0;
    for (const auto& o : scene.objects) {
      triangles += o.mesh.triangle_count();
      EXPECT_LT(o.material, scene.materials.size());
      expect_well_formed(o.mesh);
    }
    // They run on a software rasteriser: tens of thousands of triangles (bunny-glass: 69,676), up
    // to seed 001's largest final-gather timing scene (cornell-bumpy-133k: 133,160; Table 14.2).
    EXPECT_LT(triangles, 140000u);
    // The default animation changes something between its first and last frame, and every frame is
    // finite.
    FrameState first = scene.at(0), last = scene.at(scene.default_frames - 1);
    bool moves = first.camera.position != last.camera.position ||
                 first.camera.target != last.camera.target ||
                 first.object_to_world != last.object_to_world || !first.deformed_objects.empty();
    for (size_t i = 0; i < first.lights.size(); ++i)
      moves = moves || first.lights[i].position != last.lights[i].position ||
              first.lights[i].direction != last.lights[i].direction ||
              first.lights[i].radiant != last.lights[i].radiant;  // power tracks
    EXPECT_TRUE(moves);
    for (uint32_t f = 0; f < scene.default_frames; f += 7) {
      FrameState s = scene.at(f);
      for (int c = 0; c < 3; ++c) ASSERT_TRUE(std::isfinite(s.camera.position[c]));
      for (const auto& m : s.object_to_world)
        for (int c = 0; c < 4; ++c) ASSERT_TRUE(std::isfinite(m[3][c]));
    }
    auto [lo, hi] = scene.bounds();
    EXPECT_TRUE(glm::all(glm::lessThan(lo, hi)));
  }
}

// Paper II's three situations (§5, Fig. 6), each lit by a disc light as all its experiments are:
// objects moving in the light's direct field under a static light (merry-go-round), one figure
// that walks and then stands still under a static light (walker: nothing moves over its last
// second), and a moving light among static objects (villa).
TEST(SceneFiles, PaperTwoScenesModelTheirSituationWithADiscLight) {
  auto moving_objects = [](const Scene& scene, float t0, float t1) {
    FrameState a = scene.at(uint32_t(t0 * scene.fps)), b = scene.at(uint32_t(t1 * scene.fps));
    size_t n = 0;
    for (size_t i = 0; i < a.object_to_world.size(); ++i)
      n += a.object_to_world[i] != b.object_to_world[i];
    return n;
  };
  for (const char* name : {"merry-go-round", "walker", "villa"}) {
    SCOPED_TRACE(name);
    Scene scene = load_scene(find_scene(name, {}));
    ASSERT_EQ(scene.lights.size(), 1u);
    EXPECT_EQ(scene.lights[0].light.type, LightType::disc);
    float end = float(scene.default_frames - 1) / scene.fps;
    bool light_moves =
        scene.at(0).lights[0].position != scene.at(scene.default_frames / 2).lights[0].position;
    std::string n = name;
    if (n == "merry-go-round") {
      EXPECT_FALSE(light_moves);
      EXPECT_EQ(moving_objects(scene, 0, 1), 11u);  // three "teapots", eight "bunnies"
    } else if (n == "walker") {
      EXPECT_FALSE(light_moves);
      EXPECT_EQ(moving_objects(scene, 0, 1), 4u);          // torso, head, two legs
      EXPECT_EQ(moving_objects(scene, 3.5f, 6.5f), 0u);    // waiting at the stand
      EXPECT_EQ(moving_objects(scene, end - 1, end), 0u);  // arrived
    } else {
      EXPECT_TRUE(light_moves);
      EXPECT_EQ(moving_objects(scene, 0, end), 0u);
    }
  }
}

TEST(FindScene, ResolvesNamesPathsAndSearchDirs) {
  EXPECT_EQ(find_scene("cornell-box", {}), kScenes / "cornell-box.yaml");
  // A search dir comes before the source tree's scenes/.
  EXPECT_EQ(find_scene("obj-scene", {kData}), kData / "obj-scene.yaml");
  fs::path path = kData / "obj-scene.yaml";
  EXPECT_EQ(find_scene(path.string(), {}), path);
  try {
    find_scene("cornel-box", {});
    FAIL() << "no error";
  } catch (const InputError& e) {
    std::string message = e.what();
    EXPECT_NE(message.find("unknown scene 'cornel-box'; did you mean 'cornell-box'?"),
              std::string::npos)
        << message;
    for (const auto& name : kExpectedScenes)
      EXPECT_NE(message.find(name), std::string::npos) << message;
  }
  EXPECT_THROW(find_scene("missing/dir/x.yaml", {}), InputError);
}

// The frame checks name the camera's or the light's place in the file and the frame; a frame with
// a degenerate camera never reaches Embree, which would abort the process on its NaN rays.
TEST(FrameChecks, NameTheTrackAndTheFrame) {
  fs::path dir = fs::temp_directory_path() / ("pb_frame_checks_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  // The camera reaches its target at t = 1 s (frame 30), after the default animation (frames 0-1).
  std::ofstream(dir / "late.yaml")
      << "purpose: test\n"
         "frames: 2\n"
         "camera: {position: {keys: [[0, [0, 1, 3]], [1, [0, 1, 0]]]}, target: [0, 1, 0], "
         "fov_deg: 45}\n"
         "lights:\n"
         "  - {type: spot, position: [0, 2, 0], target: {keys: [[0, [0, 0, 0]], [2, [0, 4, "
         "0]]]}, intensity: 1}\n"
         "materials: {white: {type: diffuse}}\n"
         "objects: [{shape: {type: box}, material: white}]\n";
  Scene scene = load_scene(dir / "late.yaml");
  EXPECT_NO_THROW(check_frames(scene, 0, 29));
  try {
    check_frames(scene, 0, 40);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("late.yaml:3:9: camera: at frame 30 (t = 1 s) the "
                                         "position (0, 1, 0) equals the target"),
              std::string::npos)
        << e.what();
  }
  // The spot light's target passes through the light at t = 1 s too; the camera is checked first,
  // so move the camera's key away.
  scene.camera.position.keys.values[1] = {0, 1, 1};
  try {
    check_frames(scene, 0, 40);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("late.yaml:5:5: lights[0]: at frame 30 (t = 1 s) the "
                                         "target (0, 2, 0) is the light's own position"),
              std::string::npos)
        << e.what();
  }
  fs::remove_all(dir);
}

TEST(FrameChecks, EmbreeSceneRefusesAFrameItCannotTrace) {
  Scene scene;
  scene.file = "probe.yaml";
  scene.camera.where = "probe.yaml:3:9: camera";
  scene.camera.position.constant = {0, 1, 3};
  scene.camera.target.constant = {0, 0, 0};
  Object box;
  box.name = "box";
  box.shape = std::make_shared<BoxShape>(glm::vec3(1));
  box.mesh = box.shape->tessellate(0);
  scene.objects.push_back(box);
  scene.materials.push_back(Material{});
  FrameState good = scene.at(0);
  EXPECT_NO_THROW(trace::EmbreeScene(scene, good));

  FrameState on_target = good;
  on_target.camera.target = on_target.camera.position;
  EXPECT_THROW(trace::EmbreeScene(scene, on_target), InputError);
  FrameState along_up = good;
  along_up.camera.target = along_up.camera.position + along_up.camera.up;
  EXPECT_THROW(trace::EmbreeScene(scene, along_up), InputError);
  FrameState huge = good;
  huge.camera.position.x = 1e23f;
  EXPECT_THROW(trace::EmbreeScene(scene, huge), InputError);
  FrameState nan_transform = good;
  nan_transform.object_to_world[0][3].x = std::nanf("");
  EXPECT_THROW(trace::EmbreeScene(scene, nan_transform), InputError);
  // update() checks each new frame as the constructor checks the first.
  trace::EmbreeScene world(scene, good);
  try {
    world.update(on_target);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("probe.yaml:3:9: camera: at frame 0"), std::string::npos)
        << e.what();
  }
}

}  // namespace scene_test
}  // namespace pb::scene
