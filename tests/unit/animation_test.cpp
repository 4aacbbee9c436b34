// Animation tracks: each interpolation at and between keys, clamping and looping, orbits, the order
// in which a transform composes, and that a frame's state depends only on frame / fps.
#include "scene/animation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/constants.hpp>

#include "scene/scene.h"
#include "scene/shapes.h"

namespace pb::scene {
namespace animation_test {

constexpr float kEps = 1e-5f;

void expect_vec3_near(glm::vec3 actual, glm::vec3 expected, float eps = kEps) {
  EXPECT_NEAR(actual.x, expected.x, eps);
  EXPECT_NEAR(actual.y, expected.y, eps);
  EXPECT_NEAR(actual.z, expected.z, eps);
}

Keyframes<float> scalar_keys(Interpolation interpolation, bool loop = false) {
  Keyframes<float> k;
  k.times = {0.0f, 1.0f, 3.0f, 4.0f};
  k.values = {0.0f, 10.0f, 30.0f, 0.0f};
  k.interpolation = interpolation;
  k.loop = loop;
  return k;
}

TEST(Keyframes, EveryInterpolationPassesThroughItsKeys) {
  for (auto mode : {Interpolation::step, Interpolation::linear, Interpolation::catmull_rom}) {
    auto k = scalar_keys(mode);
    for (size_t i = 0; i < k.times.size(); ++i) EXPECT_NEAR(k.at(k.times[i]), k.values[i], kEps);
  }
}

TEST(Keyframes, StepHoldsTheLastKeyReached) {
  auto k = scalar_keys(Interpolation::step);
  EXPECT_EQ(k.at(0.5f), 0.0f);
  EXPECT_EQ(k.at(0.999f), 0.0f);
  EXPECT_EQ(k.at(1.0f), 10.0f);
  EXPECT_EQ(k.at(2.9f), 10.0f);
  EXPECT_EQ(k.at(3.5f), 30.0f);
}

TEST(Keyframes, LinearInterpolatesBetweenKeys) {
  auto k = scalar_keys(Interpolation::linear);
  EXPECT_NEAR(k.at(0.5f), 5.0f, kEps);
  EXPECT_NEAR(k.at(2.0f), 20.0f, kEps);   // halfway through the 2 s segment
  EXPECT_NEAR(k.at(3.25f), 22.5f, kEps);  // a quarter of 30 -> 0
}

TEST(Keyframes, OutsideTheKeysHoldsTheEndValues) {
  for (auto mode : {Interpolation::step, Interpolation::linear, Interpolation::catmull_rom}) {
    auto k = scalar_keys(mode);
    EXPECT_EQ(k.at(-5.0f), 0.0f);
    EXPECT_EQ(k.at(4.5f), 0.0f);
    k.values.back() = 7.0f;
    EXPECT_EQ(k.at(100.0f), 7.0f);
  }
}

TEST(Keyframes, CatmullRomMatchesTheUniformSplineFormula) {
  // Segment 1 (keys 1 -> 2) at u = 0.5: 0.5 * (2 p1 + (p2 - p0) u + (2p0 - 5p1 + 4p2 - p3) u^2
  //                                            + (-p0 + 3p1 - 3p2 + p3) u^3)
  auto k = scalar_keys(Interpolation::catmull_rom);
  float p0 = 0, p1 = 10, p2 = 30, p3 = 0, u = 0.5f;
  float expected = 0.5f * (2 * p1 + (p2 - p0) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u * u +
                           (-p0 + 3 * p1 - 3 * p2 + p3) * u * u * u);
  EXPECT_NEAR(k.at(2.0f), expected, 1e-4f);
  EXPECT_NE(k.at(2.0f), 20.0f);  // differs from linear here
  // First segment: clamped, the missing neighbour is the first key itself (p0 = p1 = 0, p2 = 10, p3
  // = 30).
  float first =
      0.5f * (2 * 0 + (10 - 0) * u + (0 - 0 + 40 - 30) * u * u + (0 + 0 - 30 + 30) * u * u * u);
  EXPECT_NEAR(k.at(0.5f), first, 1e-4f);
}

TEST(Keyframes, CatmullRomReproducesAStraightLine) {
  // Evenly spaced collinear keys: the uniform spline is exactly linear in the interior segments.
  Keyframes<glm::vec3> k;
  k.times = {0, 1, 2, 3};
  k.values = {{0, 0, 0}, {1, 2, 3}, {2, 4, 6}, {3, 6, 9}};
  k.interpolation = Interpolation::catmull_rom;
  for (float t : {1.1f, 1.5f, 1.9f}) expect_vec3_near(k.at(t), t * glm::vec3(1, 2, 3), 1e-4f);
}

TEST(Keyframes, LoopWrapsTimeByThePeriod) {
  for (auto mode : {Interpolation::step, Interpolation::linear, Interpolation::catmull_rom}) {
    auto k = scalar_keys(mode, true);  // period 4 s
    for (float t : {0.3f, 1.7f, 2.5f, 3.9f}) {
      EXPECT_NEAR(k.at(t + 4.0f), k.at(t), 1e-3f);
      EXPECT_NEAR(k.at(t + 12.0f), k.at(t), 1e-3f);
      EXPECT_NEAR(k.at(t - 4.0f), k.at(t), 1e-3f);
    }
    EXPECT_NEAR(k.at(4.0f), k.at(0.0f), kEps);
    EXPECT_NEAR(k.at(5.0f), 10.0f, 1e-4f);  // key 1 one period later
  }
}

TEST(Keyframes, LoopingCatmullRomTakesNeighboursAcrossTheSeam) {
  // Keys 0..3 with key 3 == key 0 form a closed cycle of three points; on the first segment the
  // neighbour before key 0 is key 2, not key 0 as in a clamped track.
  Keyframes<float> k;
  k.times = {0, 1, 2, 3};
  k.values = {0, 10, 20, 0};
  k.interpolation = Interpolation::catmull_rom;
  k.loop = true;
  float p0 = 20, p1 = 0, p2 = 10, p3 = 20, u = 0.5f;
  float expected = 0.5f * (2 * p1 + (p2 - p0) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u * u +
                           (-p0 + 3 * p1 - 3 * p2 + p3) * u * u * u);
  EXPECT_NEAR(k.at(0.5f), expected, 1e-4f);
  // Last segment: the neighbour after key 3 (== key 0) is key 1.
  p0 = 10, p1 = 20, p2 = 0, p3 = 10;
  expected = 0.5f * (2 * p1 + (p2 - p0) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u * u +
                     (-p0 + 3 * p1 - 3 * p2 + p3) * u * u * u);
  EXPECT_NEAR(k.at(2.5f), expected, 1e-4f);
}

TEST(Orbit, CirclesCounterClockwiseSeenFromAbove) {
  Orbit o;
  o.center = {1, 2, 3};
  o.radius = 2;
  o.height = 0.5f;
  o.period = 8;
  o.phase = 0;
  expect_vec3_near(o.at(0), {3, 2.5f, 3});
  expect_vec3_near(o.at(2), {1, 2.5f, 1});  // a quarter turn: +x -> -z
  expect_vec3_near(o.at(4), {-1, 2.5f, 3});
  expect_vec3_near(o.at(6), {1, 2.5f, 5});
  expect_vec3_near(o.at(8), o.at(0), 1e-4f);
  o.phase = glm::half_pi<float>();
  expect_vec3_near(o.at(0), {1, 2.5f, 1});
  o.phase = 0;
  o.period = -8;  // clockwise
  expect_vec3_near(o.at(2), {1, 2.5f, 5});
  for (float t = 0; t < 8; t += 0.7f) {
    glm::vec3 p = o.at(t) - o.center;
    EXPECT_NEAR(std::hypot(p.x, p.z), 2.0f, 1e-5f);
  }
}

TEST(PositionTrack, PrefersOrbitThenKeysThenConstant) {
  PositionTrack p;
  p.constant = {1, 2, 3};
  EXPECT_FALSE(p.animated());
  expect_vec3_near(p.at(5), {1, 2, 3});
  p.keys.times = {0, 1};
  p.keys.values = {{0, 0, 0}, {2, 0, 0}};
  EXPECT_TRUE(p.animated());
  expect_vec3_near(p.at(0.5f), {1, 0, 0});
  p.orbit = Orbit{};
  expect_vec3_near(p.at(0), {1, 0, 0});  // default orbit: radius 1 around the origin
}

TEST(TransformTrack, ComposesTranslateRotateScale) {
  TransformTrack t;
  t.translation.constant = {1, 2, 3};
  t.rotation_deg = {0, 0, 90};
  t.scale = {2, 2, 2};
  // S first: (1,0,0) -> (2,0,0); R about z by 90: -> (0,2,0); T: -> (1,4,3).
  expect_vec3_near(glm::vec3(t.at(0) * glm::vec4(1, 0, 0, 1)), {1, 4, 3});
  // Directions ignore the translation.
  expect_vec3_near(glm::vec3(t.at(0) * glm::vec4(0, 1, 0, 0)), {-2, 0, 0});
  EXPECT_FALSE(t.animated());
}

TEST(TransformTrack, EulerAnglesApplyXThenYThenZ) {
  TransformTrack t;
  t.rotation_deg = {90, 90, 0};
  // x first: (0,1,0) -> (0,0,1); then y by 90: (0,0,1) -> (1,0,0). (y first would give (0,0,1).)
  expect_vec3_near(glm::vec3(t.at(0) * glm::vec4(0, 1, 0, 0)), {1, 0, 0});
  t.rotation_deg = {0, 90, 90};
  // y first: (1,0,0) -> (0,0,-1); z leaves it. (z first would give (0,1,0).)
  expect_vec3_near(glm::vec3(t.at(0) * glm::vec4(1, 0, 0, 0)), {0, 0, -1});
}

TEST(TransformTrack, SpinAndKeysAddToTheConstantRotation) {
  TransformTrack t;
  t.rotation_deg = {0, 30, 0};
  t.spin_deg_per_s = {0, 15, 0};
  t.rotation_keys.times = {0, 2};
  t.rotation_keys.values = {{0, 0, 0}, {0, 90, 0}};
  EXPECT_TRUE(t.animated());
  // t = 2: 30 + 15*2 + 90 = 150 degrees about y.
  float a = glm::radians(150.0f);
  expect_vec3_near(glm::vec3(t.at(2) * glm::vec4(1, 0, 0, 0)), {std::cos(a), 0, -std::sin(a)});
  // Scale keys multiply the constant scale.
  TransformTrack s;
  s.scale = {2, 2, 2};
  s.scale_keys.times = {0, 1};
  s.scale_keys.values = {{1, 1, 1}, {3, 3, 3}};
  expect_vec3_near(glm::vec3(s.at(0.5f) * glm::vec4(1, 0, 0, 0)), {4, 0, 0});
}

Scene animated_scene() {
  Scene scene;
  scene.fps = 24;
  scene.camera.position.keys.times = {0, 2};
  scene.camera.position.keys.values = {{0, 1, 5}, {4, 1, 5}};
  scene.camera.position.keys.interpolation = Interpolation::catmull_rom;
  scene.camera.target.constant = {0, 0, 0};
  scene.camera.fov_keys.times = {0, 2};
  scene.camera.fov_keys.values = {30, 60};
  LightTrack light;
  light.light.type = LightType::spot;
  Orbit orbit;
  orbit.radius = 2;
  orbit.height = 3;
  orbit.period = 3;
  light.position.orbit = orbit;
  light.target = PositionTrack{};
  scene.lights.push_back(light);
  Object ball;
  ball.name = "ball";
  ball.shape = std::make_shared<SphereShape>(0.5f, 8);
  ball.mesh = ball.shape->tessellate(0);
  ball.transform.spin_deg_per_s = {0, 40, 0};
  ball.transform.translation.keys.times = {0, 1, 2};
  ball.transform.translation.keys.values = {{0, 0, 0}, {1, 0, 0}, {0, 0, 0}};
  ball.transform.translation.keys.loop = true;
  scene.objects.push_back(ball);
  Object water;
  water.name = "water";
  water.shape = std::make_shared<HeightFieldShape>(
      glm::vec2(2), glm::uvec2(4), std::vector<Wave>{Wave{0.1f, 1.0f, 0.5f, {1, 0}, 0}});
  water.mesh = water.shape->tessellate(0);
  scene.objects.push_back(water);
  return scene;
}

TEST(SceneAt, TimeIsFrameOverFps) {
  Scene scene = animated_scene();
  FrameState s = scene.at(36);
  const float t = 36.0f / 24.0f;
  EXPECT_FLOAT_EQ(s.time, t);
  EXPECT_EQ(s.frame, 36u);
  expect_vec3_near(s.camera.position, scene.camera.position.at(t));
  EXPECT_NEAR(s.camera.fov_y, glm::radians(52.5f), 1e-5f);
  expect_vec3_near(s.lights[0].position, scene.lights[0].position.orbit->at(t));
  // The spot aims at its target (the origin) from its orbit position.
  expect_vec3_near(s.lights[0].direction, glm::normalize(-s.lights[0].position));
  EXPECT_EQ(s.object_to_world[0], scene.objects[0].transform.at(t));
  ASSERT_EQ(s.deformed_objects.size(), 1u);
  EXPECT_EQ(s.deformed_objects[0], 1u);
}

TEST(SceneAt, AFrameIsReproducibleOnItsOwn) {
  // Evaluating frames in any order, or twice, gives bit-identical states: nothing carries over.
  Scene scene = animated_scene();
  std::vector<FrameState> forward;
  for (uint32_t f = 0; f < 50; ++f) forward.push_back(scene.at(f));
  for (uint32_t f = 50; f-- > 0;) {
    FrameState again = scene.at(f);
    EXPECT_EQ(again.time, forward[f].time);
    EXPECT_EQ(again.camera.position, forward[f].camera.position);
    EXPECT_EQ(again.camera.fov_y, forward[f].camera.fov_y);
    EXPECT_EQ(again.lights[0].position, forward[f].lights[0].position);
    EXPECT_EQ(again.lights[0].direction, forward[f].lights[0].direction);
    EXPECT_EQ(again.object_to_world, forward[f].object_to_world);
  }
  Scene copy = animated_scene();
  EXPECT_EQ(copy.at(37).object_to_world, scene.at(37).object_to_world);
  Mesh a = scene.mesh_at(1, scene.at(17).time), b = copy.mesh_at(1, copy.at(17).time);
  EXPECT_EQ(a.positions, b.positions);
  // The frames do differ: the animation really moves.
  EXPECT_NE(forward[0].camera.position, forward[30].camera.position);
  EXPECT_NE(forward[0].object_to_world[0], forward[30].object_to_world[0]);
  EXPECT_NE(scene.mesh_at(1, 0).positions, scene.mesh_at(1, 0.5f).positions);
}

}  // namespace animation_test
}  // namespace pb::scene
