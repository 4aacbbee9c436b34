// The view-sample cluster hierarchy (pb::toolkit::Hierarchy, Paper I §4.1, §4.5, §5.2) built on the
// device from random G-buffers (depth discontinuities, background holes, random normals facing the
// camera), then checked on the CPU against what the splatters rely on: every view sample is in a
// leaf whose key spells its pixel block, the key -> cid map and the cid -> key list invert each
// other at every level, child masks hold exactly the occupied children, every AABB contains its
// samples and its children's AABBs, and every normal cone bounds its samples' normals and its
// children's cones.
#include "photonbench/toolkit/hierarchy.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "gpu_context.h"
#include "validation.h"

namespace hierarchy_test {

using namespace pb;
using toolkit::Hierarchy;
using toolkit::HierarchyOptions;

gpu::Device& device() {
  static gpu::Device d({"", pb::testing::validation_on()});
  return d;
}

// The hierarchy's buffers, read back, with the CPU versions of hierarchy.glsl's lookups.
struct HostHierarchy {
  toolkit::layout::HierInfo info;
  std::vector<uint32_t> masks, slots, keys, leaves;
  std::vector<float> aabbs, cones;

  explicit HostHierarchy(const Hierarchy& h) {
    std::memcpy(&info, h.info().mapped(), sizeof info);
    auto read_u = [](const gpu::Buffer& b) {
      std::vector<uint32_t> v(b.size() / 4);
      device().download(b, v.data(), b.size());
      return v;
    };
    auto read_f = [](const gpu::Buffer& b) {
      std::vector<float> v(b.size() / 4);
      device().download(b, v.data(), b.size());
      return v;
    };
    masks = read_u(h.masks());
    slots = read_u(h.slots());
    keys = read_u(h.node_keys());
    leaves = read_u(h.sample_leaves());
    aabbs = read_f(h.aabbs());
    cones = read_f(h.cones());
  }
  uint32_t levels() const { return info.dims.x; }
  uint32_t mask(uint32_t level, uint32_t key) const { return masks.at(info.level[level].x + key); }
  uint32_t cid(uint32_t level, uint32_t key) const {
    if (level + 1 < levels()) return slots.at(info.level[level].y + key);
    uint32_t parent = key >> 5;
    uint32_t parent_cid = slots.at(info.level[level - 1].y + parent);
    uint32_t base = masks.at(info.level[level].x + parent_cid - info.level[level - 1].z);
    uint32_t below = mask(level - 1, parent) & ((1u << (key & 31u)) - 1u);
    return base + uint32_t(std::popcount(below));
  }
  glm::vec3 lo(uint32_t cid) const {
    return {aabbs[6 * cid], aabbs[6 * cid + 1], aabbs[6 * cid + 2]};
  }
  glm::vec3 hi(uint32_t cid) const {
    return {aabbs[6 * cid + 3], aabbs[6 * cid + 4], aabbs[6 * cid + 5]};
  }
  glm::vec4 cone(uint32_t cid) const {
    return {cones[4 * cid], cones[4 * cid + 1], cones[4 * cid + 2], cones[4 * cid + 3]};
  }
  // The leaf-grid cell (x, y blocks, depth slice) a leaf key spells (inverse of hier_leaf_key_at).
  glm::uvec3 leaf_cell(uint32_t key) const {
    const uint32_t L = levels();
    uint32_t root = key >> (5 * (L - 1));
    glm::uvec3 top = glm::uvec3(info.divisor[0]) * glm::uvec3(info.split[0]);
    glm::uvec3 g((root % info.dims.y) * top.x, (root / info.dims.y) * top.y, 0);
    for (uint32_t l = 0; l + 1 < L; ++l) {
      uint32_t i = (key >> (5 * (L - 2 - l))) & 31u;
      glm::uvec3 s(info.split[l]);
      glm::uvec3 c(i % s.x, (i / s.x) % s.y, i / (s.x * s.y));
      g += c * glm::uvec3(info.divisor[l]);
    }
    return g;
  }
};

float angle(glm::vec3 a, glm::vec3 b) { return std::acos(std::clamp(glm::dot(a, b), -1.0f, 1.0f)); }

// A random G-buffer seen by a camera at the origin looking down -z: 12x12-pixel patches of planes
// at random depths (0.3 to 40 m: depth discontinuities at every patch edge) with random tilts,
// random normals facing the camera, and about a tenth of the patches background.
struct RandomScene {
  uint32_t width, height;
  std::vector<float> position, normal, albedo;
  RandomScene(uint32_t w, uint32_t h, uint32_t seed, float fov_y) : width(w), height(h) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    position.assign(size_t(w) * h * 4, 0.0f);
    normal.assign(size_t(w) * h * 4, 0.0f);
    albedo.assign(size_t(w) * h * 4, 0.5f);
    const float t = std::tan(fov_y * 0.5f), aspect = float(w) / float(h);
    const uint32_t patch = 12;
    for (uint32_t py = 0; py < h; py += patch)
      for (uint32_t px = 0; px < w; px += patch) {
        bool background = u(rng) < 0.1f;
        float depth = 0.3f * std::pow(40.0f / 0.3f, u(rng));
        glm::vec2 slope(u(rng) - 0.5f, u(rng) - 0.5f);
        for (uint32_t y = py; y < std::min(h, py + patch); ++y)
          for (uint32_t x = px; x < std::min(w, px + patch); ++x) {
            size_t at = (size_t(y) * w + x) * 4;
            if (background) continue;
            glm::vec2 ndc((x + 0.5f) / w * 2 - 1, 1 - (y + 0.5f) / h * 2);
            glm::vec3 dir(ndc.x * t * aspect, ndc.y * t, -1.0f);
            float z = depth * (1.0f + 0.02f * (slope.x * float(x - px) + slope.y * float(y - py)));
            glm::vec3 p = dir * z;  // view depth z along -z
            glm::vec3 n = glm::normalize(glm::vec3(u(rng) * 2 - 1, u(rng) * 2 - 1, u(rng) * 2 - 1));
            if (glm::dot(n, -p) < 0) n = -n;
            for (int k = 0; k < 3; ++k) position[at + k] = p[k], normal[at + k] = n[k];
            position[at + 3] = glm::length(p);
          }
      }
  }
};

void check_hierarchy(const char* layout, uint32_t seed) {
  const uint32_t w = 300, h = 200;
  const float fov = 0.9f;
  auto& gpu = device();
  RandomScene scene(w, h, seed, fov);
  pb::testing::TestGBuffer gbuffer(gpu, w, h);
  pb::testing::TestGBuffer::upload(gpu, gbuffer.position, scene.position);
  pb::testing::TestGBuffer::upload(gpu, gbuffer.normal, scene.normal);
  pb::testing::TestGBuffer::upload(gpu, gbuffer.albedo, scene.albedo);
  pb::testing::TestContext ctx(gpu, gbuffer);
  ctx.set_camera(w, h, {0, 0, 0}, {0, 0, -1}, fov);

  Hierarchy hierarchy;
  auto options = HierarchyOptions::named_layout(layout);
  options.normal_cones = true;
  hierarchy.setup(gpu, options);
  hierarchy.build(ctx);
  ctx.submit();
  HostHierarchy host(hierarchy);
  const uint32_t L = host.levels();
  ASSERT_EQ(L, hierarchy.levels());

  // Per level: the keys the samples occupy (from their leaf keys), and per leaf its samples.
  std::vector<std::set<uint32_t>> occupied(L);
  std::map<uint32_t, std::vector<size_t>> samples_of_leaf;
  const glm::mat4 view = ctx.frame().camera.view;
  size_t samples = 0;
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      size_t i = size_t(y) * w + x;
      uint32_t key = host.leaves[i];
      if (scene.position[4 * i + 3] <= 0) {
        ASSERT_EQ(key, HIER_NO_LEAF) << "background pixel " << x << "," << y;
        continue;
      }
      ASSERT_NE(key, HIER_NO_LEAF) << "pixel " << x << "," << y;
      ++samples;
      glm::uvec3 cell = host.leaf_cell(key);
      ASSERT_EQ(cell.x, x / host.info.frame.z) << "leaf key of pixel " << x << "," << y;
      ASSERT_EQ(cell.y, y / host.info.frame.w) << "leaf key of pixel " << x << "," << y;
      ASSERT_LT(cell.z, host.info.grid.z);
      samples_of_leaf[key].push_back(i);
      for (uint32_t l = L; l-- > 0;) occupied[l].insert(key >> (5 * (L - 1 - l)));
    }
  ASSERT_GT(samples, size_t(w) * h / 2);

  for (uint32_t l = 0; l < L; ++l) {
    SCOPED_TRACE("level " + std::to_string(l));
    ASSERT_EQ(host.info.counts[l], occupied[l].size());
    std::set<uint32_t> cids;
    for (uint32_t key : occupied[l]) {
      uint32_t cid = host.cid(l, key);
      ASSERT_GE(cid, hierarchy.first_cid(l));
      ASSERT_LT(cid, hierarchy.first_cid(l) + host.info.counts[l]);
      ASSERT_EQ(host.keys[cid], key) << "key -> cid -> key";
      cids.insert(cid);
      if (l + 1 < L) {  // the child mask holds exactly the occupied children
        uint32_t expected = 0;
        for (uint32_t i = 0; i < 32; ++i)
          if (occupied[l + 1].count((key << 5) | i)) expected |= 1u << i;
        ASSERT_EQ(host.mask(l, key), expected) << "child mask of key " << key;
      }
      if (l > 0) {  // the parent's AABB and cone contain this node's
        uint32_t parent = host.cid(l - 1, key >> 5);
        for (int k = 0; k < 3; ++k) {
          ASSERT_LE(host.lo(parent)[k], host.lo(cid)[k]);
          ASSERT_GE(host.hi(parent)[k], host.hi(cid)[k]);
        }
        glm::vec4 pc = host.cone(parent), cc = host.cone(cid);
        // (a half-angle of pi, where propagation clamps, holds every direction)
        float needed = std::min(angle(glm::vec3(pc), glm::vec3(cc)) + cc.w, 3.14159265f);
        ASSERT_LE(needed, pc.w + 1e-3f) << "cone of key " << key;
      }
    }
    ASSERT_EQ(cids.size(), occupied[l].size()) << "two nodes share a cid";
  }

  // Every sample inside its leaf's AABB (view space) and within its leaf's normal cone; the AABB is
  // the samples' bounding box.
  for (const auto& [key, pixels] : samples_of_leaf) {
    uint32_t cid = host.cid(L - 1, key);
    glm::vec3 lo(1e30f), hi(-1e30f);
    for (size_t i : pixels) {
      glm::vec3 p = glm::vec3(view * glm::vec4(scene.position[4 * i], scene.position[4 * i + 1],
                                               scene.position[4 * i + 2], 1.0f));
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
      glm::vec3 n =
          glm::normalize(glm::mat3(view) * glm::vec3(scene.normal[4 * i], scene.normal[4 * i + 1],
                                                     scene.normal[4 * i + 2]));
      glm::vec4 c = host.cone(cid);
      ASSERT_LE(angle(n, glm::vec3(c)), c.w + 1e-3f) << "sample normal outside its leaf's cone";
    }
    float eps = 1e-5f * (1.0f + glm::length(hi));
    for (int k = 0; k < 3; ++k) {
      ASSERT_NEAR(host.lo(cid)[k], lo[k], eps) << "leaf AABB min, key " << key;
      ASSERT_NEAR(host.hi(cid)[k], hi[k], eps) << "leaf AABB max, key " << key;
    }
  }
  // Samples of one pixel block: deeper samples never get a nearer depth slice.
  std::map<std::pair<uint32_t, uint32_t>, std::vector<std::pair<float, uint32_t>>> blocks;
  for (const auto& [key, pixels] : samples_of_leaf)
    for (size_t i : pixels) {
      glm::uvec3 cell = host.leaf_cell(key);
      float depth = -(view * glm::vec4(scene.position[4 * i], scene.position[4 * i + 1],
                                       scene.position[4 * i + 2], 1.0f))
                         .z;
      blocks[{cell.x, cell.y}].push_back({depth, cell.z});
    }
  for (auto& [block, list] : blocks) {
    std::sort(list.begin(), list.end());
    for (size_t k = 1; k < list.size(); ++k) ASSERT_LE(list[k - 1].second, list[k].second);
  }
}

TEST(Hierarchy, InvariantsOnRandomGBuffersDefaultLayout) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    check_hierarchy("default", seed);
  }
}
TEST(Hierarchy, InvariantsOnRandomGBuffersShallowLayout) { check_hierarchy("shallow", 4); }
TEST(Hierarchy, InvariantsOnRandomGBuffersDeepLayout) { check_hierarchy("deep", 5); }

}  // namespace hierarchy_test
