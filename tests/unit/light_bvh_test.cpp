// The light BVH of Paper III (seed 002) and the flat samplers beside it: every node bounds its
// lights (box, flux, orientation cone); the walk's probabilities over all lights sum to one (less
// the walks that find no light) and equal what sample() reports; sampling frequencies follow them
// (chi-square, fixed seed); and irradiance estimated through each sampler from hundreds of emissive
// triangles agrees with the exact sum of their polygon irradiances and with the uniform sampler.
#include "trace/light_bvh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "photonbench/error.h"
#include "scene/emissive_triangles.h"

namespace pb::trace {
namespace light_bvh_test {

constexpr SplitHeuristic kSplits[] = {SplitHeuristic::sah, SplitHeuristic::saoh, SplitHeuristic::vh,
                                      SplitHeuristic::voh};
constexpr LightImportance kImportances[] = {LightImportance::d, LightImportance::df,
                                            LightImportance::dfb, LightImportance::dfbo};

glm::vec3 random_unit(std::mt19937& rng) {
  std::normal_distribution<float> g;
  glm::vec3 v{g(rng), g(rng), g(rng)};
  return glm::normalize(v);
}

// `count` emissive triangles scattered in a 4 m box, facing every way, radiance spanning 100x.
std::vector<scene::EmissiveTriangle> random_triangles(uint32_t count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<scene::EmissiveTriangle> out;
  for (uint32_t i = 0; i < count; ++i) {
    scene::EmissiveTriangle t;
    glm::vec3 c{4 * u(rng) - 2, 4 * u(rng) - 2, 4 * u(rng) - 2};
    glm::vec3 n = random_unit(rng);
    glm::vec3 a = glm::normalize(glm::cross(n, random_unit(rng)));
    glm::vec3 b = glm::cross(n, a);
    float size = 0.05f + 0.2f * u(rng);
    t.p[0] = c;
    t.p[1] = c + size * a;
    t.p[2] = c + size * b;  // cross(a, b) = n
    t.normal = n;
    t.radiance = glm::vec3(std::pow(100.f, u(rng)));
    t.area = 0.5f * size * size;
    t.flux = float(M_PI) * t.area * t.radiance;
    t.triangle = i;
    out.push_back(t);
  }
  return out;
}

// Random triangles plus point lights and spots (flux spanning 100x).
std::vector<LightPrimitive> random_lights(uint32_t triangles, uint32_t points, uint32_t seed) {
  std::vector<LightPrimitive> lights;
  for (const auto& t : random_triangles(triangles, seed)) lights.push_back(primitive(t));
  std::mt19937 rng(seed + 1);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (uint32_t i = 0; i < points; ++i) {
    glm::vec3 p{4 * u(rng) - 2, 4 * u(rng) - 2, 4 * u(rng) - 2};
    float flux = std::pow(100.f, u(rng));
    lights.push_back(i % 2 ? point_primitive(p, flux)
                           : spot_primitive(p, random_unit(rng), 0.2f + 0.8f * u(rng), flux));
  }
  return lights;
}

struct Shading {
  glm::vec3 p, n;
};
std::vector<Shading> shading_points(uint32_t count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<Shading> out;
  for (uint32_t i = 0; i < count; ++i)
    out.push_back({{5 * u(rng) - 2.5f, 5 * u(rng) - 2.5f, 5 * u(rng) - 2.5f}, random_unit(rng)});
  out.push_back({{0, 0, 0}, {0, 0, 0}});  // a point that receives from every side
  return out;
}

bool contains(const Aabb& outer, const Aabb& inner) {
  return glm::all(glm::lessThanEqual(outer.lo, inner.lo)) &&
         glm::all(glm::greaterThanEqual(outer.hi, inner.hi));
}

// Every node of `bvh` holds what is below it: the lights' boxes, their normals' cones and the sum
// of their flux; leaves hold at most `leaf_size` lights and together all `total`.
void expect_bounds(const LightBvh& bvh, uint32_t leaf_size, uint32_t total) {
  const auto& nodes = bvh.nodes();
  ASSERT_FALSE(nodes.empty());
  EXPECT_EQ(nodes[0].count, total);
  uint32_t leaf_lights = 0;
  for (uint32_t k = 0; k < nodes.size(); ++k) {
    const auto& node = nodes[k];
    std::vector<uint32_t> below;  // every light under the node, through its leaves
    std::vector<uint32_t> stack = {k};
    while (!stack.empty()) {
      const auto& m = nodes[stack.back()];
      stack.pop_back();
      if (m.leaf()) {
        EXPECT_LE(m.leaf_lights, leaf_size);
        for (uint32_t j = 0; j < m.leaf_lights; ++j) below.push_back(bvh.order()[m.first + j]);
      } else {
        EXPECT_EQ(nodes[m.left].parent, uint32_t(&m - nodes.data()));
        stack.push_back(m.left), stack.push_back(m.right);
      }
    }
    if (node.leaf()) leaf_lights += node.leaf_lights;
    uint32_t count = 0;
    double flux = 0;
    for (uint32_t i : below) {
      const LightPrimitive& l = bvh.lights()[i];
      flux += l.flux;
      count += l.count;
      EXPECT_TRUE(contains(node.box, l.box)) << "node " << k << " light " << i;
      glm::dvec3 a(node.cone.axis), b(l.cone.axis);
      double angle = std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
      EXPECT_LE(angle, node.cone.theta_o + l.cone.theta_o + 1e-5) << "node " << k << " light " << i;
      EXPECT_GE(node.cone.theta_e, l.cone.theta_e);
    }
    ASSERT_EQ(count, node.count);
    EXPECT_NEAR(node.flux / flux, 1.0, 1e-5) << "node " << k;
  }
  EXPECT_EQ(leaf_lights, uint32_t(bvh.lights().size()));
}

TEST(LightBvh, EveryNodeBoundsItsLightsBoxFluxAndCone) {
  for (SplitHeuristic split : kSplits)
    for (uint32_t leaf_size : {1u, 3u, 10u})
      for (bool all_axes : {false, true}) {
        LightBvhOptions o;
        o.split = split;
        o.leaf_size = leaf_size;
        o.all_axes = all_axes;
        LightBvh bvh(random_lights(300, 40, 7), o);
        expect_bounds(bvh, leaf_size, 340);
      }
}

// The lights of `lights` moved, turned and dimmed or brightened at random (Paper IV's animated
// lights): each box shifted and stretched, each cone turned, each flux scaled up to 10x either way.
std::vector<LightPrimitive> moved(std::vector<LightPrimitive> lights, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (LightPrimitive& l : lights) {
    glm::vec3 shift{3 * u(rng) - 1.5f, 3 * u(rng) - 1.5f, 3 * u(rng) - 1.5f};
    l.box.lo += shift;
    l.box.hi += shift + glm::vec3(0.2f * u(rng));
    l.cone.axis = random_unit(rng);
    l.flux *= std::pow(10.f, 2 * u(rng) - 1);
  }
  return lights;
}

// Paper IV: after a refit (one level), and after the two-level trees' build and refit (bottom trees
// refit, top tree rebuilt), every node still bounds its children's lights.
TEST(LightBvh, EveryNodeBoundsItsLightsAfterARefitAndOnTwoLevels) {
  const std::vector<LightPrimitive> lights = random_lights(300, 40, 7);
  // Groups of lights as emissive objects are: 12 of 25 triangles, then one per point light.
  std::vector<uint32_t> group;
  for (uint32_t i = 0; i < lights.size(); ++i) group.push_back(i < 300 ? i / 25 : 100 + i);
  for (uint32_t leaf_size : {1u, 4u}) {
    LightBvhOptions o;
    o.leaf_size = leaf_size;
    // Distance and flux: never zero, so every walk finds a light and the probabilities sum to 1
    // (with the cones, a group may face p while each of its lights faces away).
    o.importance = LightImportance::df;
    LightBvh bvh(lights, o);
    bvh.refit(moved(lights, 3));
    SCOPED_TRACE("one level, refit");
    expect_bounds(bvh, leaf_size, 340);
    TwoLevelLightBvh two(lights, group, o);
    EXPECT_EQ(two.bottoms().size(), 12u + 40u);
    for (int round = 0; round < 2; ++round) {
      SCOPED_TRACE(round ? "two levels, refit" : "two levels, built");
      for (const auto& b : two.bottoms())
        expect_bounds(*b, leaf_size, uint32_t(b->lights().size()));
      expect_bounds(two.top(), leaf_size, 340);  // its leaves are the bottom trees' roots
      // Each bottom tree's root is the top tree's light of that group.
      for (size_t g = 0; g < two.bottoms().size(); ++g)
        EXPECT_EQ(two.top().lights()[g].flux, two.bottoms()[g]->nodes()[0].flux);
      // The walk over both levels: probabilities sum to 1 and sample() reports pdf().
      for (const Shading& s : shading_points(20, 5)) {
        double sum = 0;
        for (uint32_t i = 0; i < lights.size(); ++i) sum += two.pdf(s.p, s.n, i);
        if (sum > 0) EXPECT_NEAR(sum, 1.0, 1e-4);
        LightPick pick;
        if (two.sample(s.p, s.n, 0.37f, pick))
          EXPECT_NEAR(pick.pdf / two.pdf(s.p, s.n, pick.light), 1.0, 1e-4);
      }
      two.refit(moved(lights, 11));
    }
  }
  // A refit over another number of lights is refused.
  LightBvh bvh(lights, {});
  EXPECT_THROW(bvh.refit(random_lights(10, 0, 1)), Error);
}

// Enumerated over every light, the walk's probabilities sum to the probability that a walk finds a
// light at all: one wherever no pair of sibling nodes both has zero importance (always for d and
// df, whose importance is never zero, and dfb at a point receiving from every side; with the
// orientation cone a node facing away from p has none); and the pdf sample() reports is the one
// pdf() computes.
TEST(LightBvh, ProbabilitiesSumToOneAndEqualTheWalks) {
  auto lights = random_lights(120, 16, 3);
  for (SplitHeuristic split : kSplits)
    for (LightImportance importance : kImportances)
      for (uint32_t leaf_size : {1u, 4u})
        for (LeafChoice leaf : {LeafChoice::uniform, LeafChoice::importance}) {
          LightBvhOptions o;
          o.split = split;
          o.importance = importance;
          o.leaf_size = leaf_size;
          o.leaf_choice = leaf;
          LightBvh bvh(lights, o);
          for (const Shading& s : shading_points(12, 11)) {
            double sum = 0;
            for (uint32_t i = 0; i < lights.size(); ++i) sum += bvh.pdf(s.p, s.n, i);
            bool never_zero = importance == LightImportance::d ||
                              importance == LightImportance::df ||
                              (importance == LightImportance::dfb && glm::dot(s.n, s.n) == 0);
            if (never_zero) EXPECT_NEAR(sum, 1.0, 1e-5);
            EXPECT_LE(sum, 1.0 + 1e-5);
            uint32_t found = 0;
            for (int k = 0; k < 256; ++k) {
              LightPick pick;
              if (!bvh.sample(s.p, s.n, (k + 0.5f) / 256.f, pick)) continue;
              ++found;
              ASSERT_LT(pick.light, lights.size());
              EXPECT_NEAR(pick.pdf / bvh.pdf(s.p, s.n, pick.light), 1.0, 1e-5);
              EXPECT_GT(pick.nodes_visited, 0u);
            }
            if (never_zero)
              EXPECT_EQ(found, 256u);
            else  // the walks that fail fill a few intervals of u: stratified, near their share
              EXPECT_NEAR(found / 256.0, sum, 0.03);
          }
        }
}

// 400,000 walks from one shading point on a fixed seed: the count of each light (and of walks that
// find none) against the pdf, by Pearson's chi-square at p = 1e-4.
double chi_square_bound(int dof) {
  // Wilson-Hilferty: the chi-square quantile from the normal one (z = 3.719 for p = 1e-4).
  double k = dof, z = 3.719;
  return k * std::pow(1 - 2 / (9 * k) + z * std::sqrt(2 / (9 * k)), 3);
}

TEST(LightBvh, SamplingFrequenciesMatchThePdfs) {
  auto lights = random_lights(80, 8, 5);
  auto uniform = make_uniform_sampler(uint32_t(lights.size()));
  auto power = make_power_sampler(lights);
  for (int which = 0; which < 4; ++which) {
    LightBvhOptions o;
    o.leaf_size = which == 3 ? 4 : 1;
    o.importance = which == 2 ? LightImportance::df : LightImportance::dfbo;
    LightBvh bvh(lights, o);
    const LightSampler& sampler = which == 0 ? *uniform : which == 1 ? *power : bvh;
    glm::vec3 p{0.3f, -0.2f, 0.1f}, n = glm::normalize(glm::vec3(0.2f, 1, -0.3f));
    std::mt19937 rng(1234);
    std::uniform_real_distribution<float> u(0.f, 1.f);
    const int samples = 400000;
    std::vector<double> counts(lights.size() + 1, 0);
    for (int k = 0; k < samples; ++k) {
      LightPick pick;
      ++counts[sampler.sample(p, n, u(rng), pick) ? pick.light : lights.size()];
    }
    std::vector<double> expected(lights.size() + 1, 0);
    double found = 0;
    for (uint32_t i = 0; i < lights.size(); ++i) found += expected[i] = sampler.pdf(p, n, i);
    expected.back() = std::max(0.0, 1 - found);
    double chi2 = 0, pooled_count = 0, pooled_expected = 0;
    int dof = -1;
    for (size_t i = 0; i < counts.size(); ++i) {
      double e = expected[i] * samples;
      if (e < 5) {  // too rare for Pearson's statistic alone: pooled into one bin
        pooled_count += counts[i], pooled_expected += e;
        if (e == 0) EXPECT_EQ(counts[i], 0) << "light " << i << " has pdf 0 but was sampled";
        continue;
      }
      chi2 += (counts[i] - e) * (counts[i] - e) / e;
      ++dof;
    }
    if (pooled_expected >= 5) {
      chi2 += (pooled_count - pooled_expected) * (pooled_count - pooled_expected) / pooled_expected;
      ++dof;
    }
    ASSERT_GT(dof, 10);
    EXPECT_LT(chi2, chi_square_bound(dof)) << "sampler " << which << ", " << dof << " dof";
  }
}

// Irradiance at p from `triangles` by Lambert's contour integral over each (exact, no occlusion).
double exact_irradiance(const std::vector<scene::EmissiveTriangle>& triangles, glm::dvec3 p,
                        glm::dvec3 n) {
  double total = 0;
  for (const auto& t : triangles) {
    glm::dvec3 v[3] = {t.p[0], t.p[1], t.p[2]};
    if (glm::dot(p - v[0], glm::dvec3(t.normal)) <= 0) continue;
    // Clip to the receiver's upper half-space (what is below its horizon sends nothing).
    std::vector<glm::dvec3> poly;
    for (int i = 0; i < 3; ++i) {
      glm::dvec3 a = v[i], b = v[(i + 1) % 3];
      double da = glm::dot(a - p, n), db = glm::dot(b - p, n);
      if (da >= 0) poly.push_back(a);
      if ((da >= 0) != (db >= 0)) poly.push_back(a + (b - a) * (da / (da - db)));
    }
    double sum = 0;
    for (size_t i = 0; i < poly.size(); ++i) {
      glm::dvec3 ra = glm::normalize(poly[i] - p),
                 rb = glm::normalize(poly[(i + 1) % poly.size()] - p);
      glm::dvec3 g = glm::cross(ra, rb);
      if (glm::length(g) > 0)
        sum += std::acos(std::clamp(glm::dot(ra, rb), -1.0, 1.0)) * glm::dot(n, glm::normalize(g));
    }
    total += 0.5 * t.radiance.y * std::abs(sum);
  }
  return total;
}

struct Estimate {
  double mean = 0, variance_of_mean = 0;
};

// Next-event estimation of the irradiance: a light by `sampler`, a uniform point on it.
Estimate estimate_irradiance(const LightSampler& sampler,
                             const std::vector<scene::EmissiveTriangle>& triangles, glm::vec3 p,
                             glm::vec3 n, int samples, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  double sum = 0, sum2 = 0;
  for (int k = 0; k < samples; ++k) {
    float u0 = u(rng), u1 = u(rng), u2 = u(rng);
    double value = irradiance_sample(sampler, triangles, p, n, u0, {u1, u2}).y;
    sum += value, sum2 += value * value;
  }
  Estimate e;
  e.mean = sum / samples;
  e.variance_of_mean = std::max(0.0, sum2 / samples - e.mean * e.mean) / samples;
  return e;
}

// 600 emitters in a 10 x 10 m ceiling grid, lamps of four power classes spanning 100x, tilted up to
// 60 degrees; two receivers on the floor.
std::vector<scene::EmissiveTriangle> lamp_ceiling() {
  std::mt19937 rng(99);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::vector<scene::EmissiveTriangle> out;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 30; ++j) {
      scene::EmissiveTriangle t;
      glm::vec3 c{-5 + 10 * (i + 0.5f) / 20, 3, -5 + 10 * (j + 0.5f) / 30};
      glm::vec3 n =
          glm::normalize(glm::vec3(u(rng) - 0.5f, -1, u(rng) - 0.5f) * glm::vec3(1.7f, 1, 1.7f));
      glm::vec3 a = glm::normalize(glm::cross(n, glm::vec3(0, 0, 1)));
      glm::vec3 b = glm::cross(n, a);
      t.p[0] = c, t.p[1] = c + 0.15f * a, t.p[2] = c + 0.15f * b;
      t.normal = n;
      t.radiance = glm::vec3(std::pow(10.f, float((i * 7 + j) % 4) * 2.f / 3.f));
      t.area = 0.5f * 0.15f * 0.15f;
      t.flux = float(M_PI) * t.area * t.radiance;
      out.push_back(t);
    }
  return out;
}

TEST(LightBvh, IrradianceThroughEverySamplerIsUnbiased) {
  auto triangles = lamp_ceiling();
  std::vector<LightPrimitive> lights;
  for (const auto& t : triangles) lights.push_back(primitive(t));
  auto uniform = make_uniform_sampler(uint32_t(lights.size()));
  auto power = make_power_sampler(lights);
  for (glm::vec3 p : {glm::vec3(0.3f, 0, -0.2f), glm::vec3(4.6f, 0.5f, 4.1f)}) {
    glm::vec3 n = glm::normalize(glm::vec3(0.1f, 1, 0.05f));
    double exact = exact_irradiance(triangles, p, n);
    ASSERT_GT(exact, 0.0);
    Estimate base = estimate_irradiance(*uniform, triangles, p, n, 200000, 1);
    EXPECT_LT(std::abs(base.mean - exact) / std::sqrt(base.variance_of_mean), 4.0);
    Estimate by_power = estimate_irradiance(*power, triangles, p, n, 200000, 2);
    EXPECT_LT(std::abs(by_power.mean - exact) / std::sqrt(by_power.variance_of_mean), 4.0);
    for (SplitHeuristic split : {SplitHeuristic::sah, SplitHeuristic::saoh})
      for (LightImportance importance : kImportances) {
        LightBvhOptions o;
        o.split = split;
        o.importance = importance;
        LightBvh bvh(lights, o);
        Estimate e = estimate_irradiance(bvh, triangles, p, n, 100000, 3);
        double z_exact = (e.mean - exact) / std::sqrt(e.variance_of_mean);
        double z_uniform =
            (e.mean - base.mean) / std::sqrt(e.variance_of_mean + base.variance_of_mean);
        EXPECT_LT(std::abs(z_exact), 4.0) << int(split) << " " << int(importance);
        EXPECT_LT(std::abs(z_uniform), 4.0) << int(split) << " " << int(importance);
        // The point of the tree: a light near the receiver is chosen more often than uniformly.
        double variance_ratio = base.variance_of_mean * 200000 / (e.variance_of_mean * 100000);
        std::printf("p (%.1f, %.1f, %.1f) split %d importance %d: variance uniform / bvh %.2f\n",
                    p.x, p.y, p.z, int(split), int(importance), variance_ratio);
        if (importance == LightImportance::dfbo) EXPECT_GT(variance_ratio, 2.0);
      }
  }
}

TEST(LightBvh, BadOptionsAreRefusedNamingTheKey) {
  LightBvhOptions o;
  o.leaf_size = 11;
  try {
    validate(o, "configs/x.yaml:3:5: direct_light");
    FAIL() << "leaf_size 11 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("configs/x.yaml:3:5: direct_light: leaf_size: 11"),
              std::string::npos)
        << e.what();
  }
  try {
    parse_split("soah", "here");
    FAIL() << "split soah accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("split: unknown value 'soah' (expected one of sah, saoh"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(parse_importance("dfb", "here"), LightImportance::dfb);
  EXPECT_EQ(parse_sampler("power", "here"), LightSamplerKind::power);
  EXPECT_THROW(parse_sampler("bhv", "here"), InputError);
}

}  // namespace light_bvh_test
}  // namespace pb::trace
