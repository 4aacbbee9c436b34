// Many-light selection for next-event estimation: which light a shading point samples, and with
// what probability. Three samplers share one interface (`sampler: uniform | power | bvh`):
//   uniform: 1/N over the lights (Paper III's "Uniform" baseline);
//   power:   by flux alone, the same for every shading point (what photon emission uses);
//   bvh:     a light BVH (Conty Estevez & Kulla 2018 as simplified by Moreau & Clarberg,
//            "Importance Sampling of Many Lights on the GPU", Ray Tracing Gems ch. 18, which is
//            Paper III of seed 002):
//            binary, built top-down on the CPU with binned splits (`bins` 16, along the largest
//            axis or all three), split cost `sah | saoh | vh | voh`, leaves of `leaf_size` lights.
//            Each node holds its lights' summed flux, box and orientation cone. A walk from the
//            root picks a child with probability proportional to its importance seen from the
//            shading point (`importance: d | df | dfb | dfbo`: distance, flux, the n.l bound, the
//            orientation cone), rescaling its one random number at each level, and a leaf picks
//            among its lights uniformly or by the same importance. The probability of any light is
//            the product of the choices on its path (pdf(), for multiple importance sampling).
// Lights here are anything with a box, a flux and a cone of normals: the scene's emissive
// triangles (scene/emissive_triangles.h), point lights (theta_o = pi) and spots (theta_e their
// outer angle). Directional lights have no position and stay outside the tree.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <memory>
#include <string>
#include <vector>

#include "scene/emissive_triangles.h"
#include "trace/embree_scene.h"

namespace pb::trace {

// Bounds on the normals of a set of emitters (CEK18 section 4.1): every normal lies within theta_o
// of `axis`, and every emitter sends light at most theta_e away from its normal.
struct OrientationCone {
  glm::vec3 axis{0, 0, 1};
  float theta_o = 0;
  float theta_e = 0;
  // The angles' cosines and sine, kept beside them so that a walk's importance needs no
  // trigonometric call (LightBvh::importance).
  float cos_o = 1, sin_o = 0, cos_e = 1;

  OrientationCone() = default;
  OrientationCone(glm::vec3 axis, float theta_o, float theta_e);
  // CEK18's orientation measure M_Omega, the SAOH/VOH weight of a cone.
  float measure() const;
};
// The smallest cone (by CEK18's construction) holding both.
OrientationCone merge(const OrientationCone& a, const OrientationCone& b);

struct LightPrimitive {
  Aabb box;
  OrientationCone cone;
  float flux = 0;      // W, the mean of the RGB flux
  uint32_t count = 1;  // lights it stands for (a bottom tree's root in a two-level tree: many)
};
LightPrimitive primitive(const scene::EmissiveTriangle& triangle);
// A point light (intensity I, W/sr): flux 4 pi I, emitting every way. A spot: its axis, theta_e
// its outer angle.
LightPrimitive point_primitive(glm::vec3 position, float flux);
LightPrimitive spot_primitive(glm::vec3 position, glm::vec3 direction, float outer_angle,
                              float flux);

enum class LightSamplerKind { uniform, power, bvh };
enum class SplitHeuristic { sah, saoh, vh, voh };
enum class LightImportance { d, df, dfb, dfbo };
enum class LeafChoice { uniform, importance };

struct LightBvhOptions {
  uint32_t bins = 16;
  bool all_axes = false;  // `axes: all`: bin along x, y and z and keep the cheapest split
  SplitHeuristic split = SplitHeuristic::saoh;
  uint32_t leaf_size = 1;  // lights per leaf, 1..10
  LightImportance importance = LightImportance::dfbo;
  LeafChoice leaf_choice = LeafChoice::importance;
};
// Throws pb::InputError naming `where` and the key for a value outside its range.
void validate(const LightBvhOptions& options, const std::string& where);
// The names of the enumerations as configs spell them; unknown names throw pb::InputError naming
// `where`, the key and the accepted names.
LightSamplerKind parse_sampler(const std::string& name, const std::string& where);
SplitHeuristic parse_split(const std::string& name, const std::string& where);
LightImportance parse_importance(const std::string& name, const std::string& where);

struct LightPick {
  uint32_t light = 0;
  float pdf = 0;               // the probability of choosing `light` at this shading point
  uint32_t nodes_visited = 0;  // tree nodes whose importance the walk evaluated (bvh only)
};

class LightSampler {
 public:
  virtual ~LightSampler() = default;
  // Chooses a light for shading point p (normal n; zero for a point that receives from every side)
  // with one number u in [0, 1). False when no light can reach p.
  virtual bool sample(const glm::vec3& p, const glm::vec3& n, float u, LightPick& out) const = 0;
  // The probability sample() gives light i at (p, n).
  virtual float pdf(const glm::vec3& p, const glm::vec3& n, uint32_t i) const = 0;
};

std::unique_ptr<LightSampler> make_uniform_sampler(uint32_t light_count);
std::unique_ptr<LightSampler> make_power_sampler(const std::vector<LightPrimitive>& lights);

class LightBvh final : public LightSampler {
 public:
  struct Node {
    Aabb box;
    OrientationCone cone;
    float flux = 0;
    uint32_t count = 0;  // lights below
    // Internal: the children's indices. Leaf: first light in order() and how many (leaf_lights).
    uint32_t left = 0, right = 0;
    uint32_t parent = ~0u;
    uint32_t first = 0, leaf_lights = 0;
    bool leaf() const { return leaf_lights > 0; }
  };

  LightBvh(std::vector<LightPrimitive> lights, const LightBvhOptions& options);

  bool sample(const glm::vec3& p, const glm::vec3& n, float u, LightPick& out) const override {
    return walk(p, n, u, out, nullptr);
  }
  // The walk with its one number in double precision; `rest` (if given) receives what is left of
  // it after the last choice, uniform in [0, 1) again, for a walk that continues in a lower tree.
  bool walk(const glm::vec3& p, const glm::vec3& n, double u, LightPick& out, double* rest) const;
  // Paper IV's refit: the same tree over `lights` (as many as it was built over, in the same order:
  // moved, turned or dimmed), every node's box, cone and flux recomputed bottom-up from its leaves
  // (children before parents). Throws pb::Error on another light count.
  void refit(std::vector<LightPrimitive> lights);
  float pdf(const glm::vec3& p, const glm::vec3& n, uint32_t i) const override;

  // Paper III's importance of a node (or of one light, seen as a node of its own) from (p, n).
  float importance(const glm::vec3& p, const glm::vec3& n, const Aabb& box,
                   const OrientationCone& cone, float flux, uint32_t count) const;

  const std::vector<Node>& nodes() const { return nodes_; }
  const std::vector<LightPrimitive>& lights() const { return lights_; }
  // Light indices in leaf order: leaf k holds order()[first .. first + leaf_lights).
  const std::vector<uint32_t>& order() const { return order_; }
  size_t bytes() const;

 private:
  uint32_t build(uint32_t begin, uint32_t end, uint32_t parent);
  // The probability that a leaf picks its j-th light, and the choice for number u.
  float leaf_probability(const Node& leaf, uint32_t j, const glm::vec3& p,
                         const glm::vec3& n) const;

  LightBvhOptions options_;
  std::vector<LightPrimitive> lights_;
  std::vector<uint32_t> order_;
  std::vector<uint32_t> leaf_of_;  // per light: its leaf node
  std::vector<Node> nodes_;
};

// Paper IV's two levels: a bottom-level tree over each group of lights (an emissive object's
// triangles, one scene light) and a top-level tree over the bottom trees' roots. A walk goes down
// the top tree to a group, then on down its bottom tree with the number left over; the probability
// of a light is the product of the two walks'. On a refit the bottom trees are refit and the top
// tree, small, is rebuilt (Paper IV §3).
class TwoLevelLightBvh final : public LightSampler {
 public:
  // group[i]: the group of light i (any numbering; empty groups do not occur).
  TwoLevelLightBvh(const std::vector<LightPrimitive>& lights, const std::vector<uint32_t>& group,
                   const LightBvhOptions& options);
  bool sample(const glm::vec3& p, const glm::vec3& n, float u, LightPick& out) const override;
  float pdf(const glm::vec3& p, const glm::vec3& n, uint32_t i) const override;
  // The same lights, in the same order and groups, moved: bottom trees refit, top tree rebuilt.
  void refit(const std::vector<LightPrimitive>& lights);
  const LightBvh& top() const { return *top_; }
  const std::vector<std::unique_ptr<LightBvh>>& bottoms() const { return bottoms_; }
  size_t node_count() const;
  size_t bytes() const;

 private:
  void build_top();
  LightBvhOptions options_;
  std::vector<uint32_t> light_group_, light_local_;  // per light: its group and index there
  std::vector<std::vector<uint32_t>> members_;       // per group: its lights
  std::vector<std::unique_ptr<LightBvh>> bottoms_;
  std::unique_ptr<LightBvh> top_;
};

// One next-event estimate of the irradiance at p (normal n) from emissive triangles, unoccluded:
// a light chosen by `sampler` with u_select, a uniform point on it with u (Paper III: p = 1/A),
// and L cos(theta_p) cos(theta_y) A / (r^2 pdf). Zero when no light is chosen or the point faces
// away; `pick` (if given) receives the choice. The shadow ray between p and the point is the
// caller's.
glm::vec3 irradiance_sample(const LightSampler& sampler,
                            const std::vector<scene::EmissiveTriangle>& triangles,
                            const glm::vec3& p, const glm::vec3& n, float u_select, glm::vec2 u,
                            LightPick* pick = nullptr);

}  // namespace pb::trace
