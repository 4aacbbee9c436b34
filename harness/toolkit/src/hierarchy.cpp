// pb::toolkit::Hierarchy: allocation of the dense per-level layout and the per-frame GPU build
// (Paper I §4.1, §4.5, §5.2). The layout and its reasons are described at the top of hierarchy.h.
#include "photonbench/toolkit/hierarchy.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <sstream>

#include "photonbench/error.h"
#include "photonbench/toolkit/technique.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

namespace {

using gpu::Binding;
using gpu::Memory;

// Mirrors the push block of harness/shaders/toolkit/hierarchy/hierarchy_build.glsl.
struct BuildPush {
  glm::mat4 view;
  uint32_t level = 0;
  int32_t normal_scale = 0;
  float ln_q_min = 0;
  uint32_t pad0 = 0;
};
static_assert(sizeof(BuildPush) == 80);
static_assert(sizeof(layout::HierInfo) ==
              3 * 16 + 4 * HIER_MAX_LEVELS * 16 + 16 + 4 * HIER_MAX_LEVELS);

constexpr uint64_t kMaxDenseNodes = uint64_t(1) << 28;  // 1 GiB of key -> cid map

uint32_t parse_uint(const std::string& text, const std::string& what, const std::string& layout) {
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || text.size() > 6)
    throw InputError(
        fmt::format("{} = \"{}\": \"{}\" is not a positive whole number (expected "
                    "ROOT:XxYxZ,XxYxZ,... e.g. \"256:2x2x8,2x2x8,2x2x8,4x4x2\")",
                    what, layout, text));
  return uint32_t(std::stoul(text));
}

}  // namespace

HierarchyOptions HierarchyOptions::named_layout(const std::string& name) {
  if (name == "shallow") return parse_layout("128:2x2x8,2x2x8,4x4x2", "layout shallow");
  if (name == "deep") return parse_layout("512:2x2x4,2x2x4,2x2x4,2x2x4,4x4x2", "layout deep");
  if (name == "default") return parse_layout("256:2x2x8,2x2x8,2x2x8,4x4x2", "layout default");
  throw InputError("cluster hierarchy: unknown layout '" + name + "' (default, shallow or deep)");
}

HierarchyOptions HierarchyOptions::named_layout(HierarchyLayout layout) {
  switch (layout) {
    case HierarchyLayout::kShallow:
      return named_layout("shallow");
    case HierarchyLayout::kDeep:
      return named_layout("deep");
    case HierarchyLayout::kDefault:
      break;
  }
  return named_layout("default");
}

HierarchyOptions HierarchyOptions::parse_layout(const std::string& layout,
                                                const std::string& what) {
  HierarchyOptions options;
  auto colon = layout.find(':');
  if (colon == std::string::npos)
    throw InputError(
        fmt::format("{} = \"{}\": expected ROOT:XxYxZ,XxYxZ,... (e.g. "
                    "\"256:2x2x8,2x2x8,2x2x8,4x4x2\")",
                    what, layout));
  options.root_tile_px = parse_uint(layout.substr(0, colon), what, layout);
  options.splits.clear();
  std::stringstream levels(layout.substr(colon + 1));
  std::string level;
  while (std::getline(levels, level, ',')) {
    LevelSplit split;
    auto x = level.find('x'), y = level.find('x', x == std::string::npos ? x : x + 1);
    if (x == std::string::npos || y == std::string::npos)
      throw InputError(fmt::format("{} = \"{}\": level \"{}\" is not XxYxZ", what, layout, level));
    split.x = parse_uint(level.substr(0, x), what, layout);
    split.y = parse_uint(level.substr(x + 1, y - x - 1), what, layout);
    split.z = parse_uint(level.substr(y + 1), what, layout);
    if (split.x == 0 || split.y == 0 || split.z == 0 || split.x * split.y * split.z > 32 ||
        split.x * split.y * split.z < 2)
      throw InputError(
          fmt::format("{} = \"{}\": level \"{}\" must have 2 to 32 children (5 key "
                      "bits per level, Paper I §4.3)",
                      what, layout, level));
    options.splits.push_back(split);
  }
  if (options.splits.empty() || options.splits.size() > 6)
    throw InputError(
        fmt::format("{} = \"{}\": 1 to 6 splits (2 to 7 levels) are supported", what, layout));
  uint32_t px = 1, py = 1;
  for (const auto& s : options.splits) px *= s.x, py *= s.y;
  if (options.root_tile_px == 0 || options.root_tile_px % px != 0 || options.root_tile_px % py != 0)
    throw InputError(
        fmt::format("{} = \"{}\": the root tile ({} px) must be divisible by the "
                    "product of the x splits ({}) and of the y splits ({})",
                    what, layout, options.root_tile_px, px, py));
  return options;
}

std::string HierarchyOptions::layout_string() const {
  std::string s = std::to_string(root_tile_px) + ":";
  for (size_t i = 0; i < splits.size(); ++i)
    s += fmt::format("{}{}x{}x{}", i ? "," : "", splits[i].x, splits[i].y, splits[i].z);
  return s;
}

void Hierarchy::setup(gpu::Device& gpu, const HierarchyOptions& options) {
  options_ = HierarchyOptions::parse_layout(options.layout_string(), "cluster hierarchy layout");
  options_.normal_cones = options.normal_cones;
  auto B = Binding::storage_buffer;
  auto I = Binding::storage_image;
  std::vector<Binding> bindings = {B, B, B, B, B, B, B, I, I};
  constexpr uint32_t kPush = sizeof(BuildPush);
  depth_range_ = gpu.create_compute_pipeline("cluster-build/depth-range",
                                             khierarchy_depth_range_comp_spv, bindings, kPush);
  occupancy_ = gpu.create_compute_pipeline("cluster-build/occupancy", khierarchy_occupancy_comp_spv,
                                           bindings, kPush);
  leaf_alloc_ = gpu.create_compute_pipeline("cluster-build/leaf-alloc",
                                            khierarchy_leaf_alloc_comp_spv, bindings, kPush);
  leaf_bounds_ = gpu.create_compute_pipeline("cluster-build/leaf-bounds",
                                             khierarchy_leaf_bounds_comp_spv, bindings, kPush);
  leaf_finalize_ = gpu.create_compute_pipeline("cluster-build/leaf-finalize",
                                               khierarchy_leaf_finalize_comp_spv, bindings, kPush);
  leaf_cones_ = gpu.create_compute_pipeline("cluster-build/cones", khierarchy_leaf_cones_comp_spv,
                                            bindings, kPush);
  propagate_ = gpu.create_compute_pipeline("cluster-build/propagate", khierarchy_propagate_comp_spv,
                                           bindings, kPush);
}

uint64_t Hierarchy::dense_nodes(uint32_t level) const {
  return uint64_t(root_count()) << (5 * level);
}
uint32_t Hierarchy::first_cid(uint32_t level) const { return layout_.level[level].z; }
uint32_t Hierarchy::node_capacity(uint32_t level) const { return layout_.level[level].w; }
uint32_t Hierarchy::node_capacity() const {
  return first_cid(leaf_level()) + node_capacity(leaf_level());
}
uint32_t Hierarchy::node_footprint_px(uint32_t level) const { return layout_.footprint[level].x; }
uint32_t Hierarchy::depth_slices(uint32_t level) const { return layout_.footprint[level].z; }

uint32_t Hierarchy::occupied(uint32_t level) const {
  if (!info_) return 0;
  const auto* info = static_cast<const layout::HierInfo*>(info_.mapped());
  return info->counts[level];
}

void Hierarchy::allocate(gpu::Device& gpu, uint32_t width, uint32_t height) {
  width_ = width;
  height_ = height;
  const uint32_t L = levels();
  const uint32_t root = options_.root_tile_px;
  roots_x_ = gpu::groups_for(width, root);
  roots_y_ = gpu::groups_for(height, root);
  uint32_t root_bits = 0;
  while ((uint64_t(1) << root_bits) < root_count()) ++root_bits;
  if (5 * (L - 1) + root_bits > 32)
    throw InputError(fmt::format(
        "cluster hierarchy layout \"{}\": {} roots at {}x{} need {} key bits with {} levels "
        "(more than 32); use larger root tiles or fewer levels",
        options_.layout_string(), root_count(), width, height, 5 * (L - 1) + root_bits, L));
  uint64_t dense_total = 0;  // the leaves have no dense arrays (hier_cid)
  for (uint32_t l = 0; l + 1 < L; ++l) dense_total += dense_nodes(l);
  if (dense_total > kMaxDenseNodes)
    throw InputError(fmt::format(
        "cluster hierarchy layout \"{}\": {} dense nodes at {}x{} exceed 2^28; use fewer levels",
        options_.layout_string(), dense_total, width, height));

  layout::HierInfo& h = layout_;
  h = {};
  uint32_t px = 1, py = 1, pz = 1;
  for (const auto& s : options_.splits) px *= s.x, py *= s.y, pz *= s.z;
  h.dims = {L, roots_x_, roots_y_, root_count()};
  h.frame = {width, height, root / px, root / py};
  h.grid = {roots_x_ * px, roots_y_ * py, pz, options_.normal_cones ? HIER_FLAG_CONES : 0u};
  uint64_t pixels = uint64_t(width) * height;
  uint64_t mask_at = root_count(), slot_at = 0, cid_at = 0;
  uint32_t fx = root, fy = root, fz = pz;
  for (uint32_t l = 0; l < L; ++l) {
    glm::uvec4 div{1, 1, 1, 0};
    if (l + 1 < L) {
      const auto& s = options_.splits[l];
      h.split[l] = {s.x, s.y, s.z, 0};
      for (uint32_t k = l + 1; k + 1 < L; ++k)
        div *= glm::uvec4(options_.splits[k].x, options_.splits[k].y, options_.splits[k].z, 0);
      div.w = 0;
    }
    h.divisor[l] = div;
    uint64_t dense = dense_nodes(l);
    uint64_t capacity = std::min<uint64_t>(dense, pixels);
    h.level[l] = {uint32_t(mask_at), uint32_t(l + 1 < L ? slot_at : 0), uint32_t(cid_at),
                  uint32_t(capacity)};
    h.footprint[l] = {fx, fy, fz, uint32_t(std::min<uint64_t>(dense, 0xffffffffu))};
    if (l + 1 < L) {
      mask_at += dense;  // child masks
      slot_at += dense;  // key -> cid map
      fx /= options_.splits[l].x;
      fy /= options_.splits[l].y;
      fz /= options_.splits[l].z;
    } else {
      mask_at += h.level[l - 1].w;  // leaf bases, one per node of the level above
    }
    cid_at += capacity;
  }

  uint64_t limit = gpu.limits().max_storage_buffer_range;
  uint64_t largest = std::max({mask_at * 4, slot_at * 4, cid_at * 24, pixels * 4});
  if (largest > limit)
    throw InputError(fmt::format(
        "cluster hierarchy layout \"{}\" at {}x{}: a buffer of {} bytes exceeds the device's "
        "maxStorageBufferRange ({}); use fewer levels or a lower resolution",
        options_.layout_string(), width, height, largest, limit));
  info_ = storage_buffer(gpu, "hierarchy/info", sizeof(layout::HierInfo), Memory::host_visible);
  std::memcpy(info_.mapped(), &h, sizeof(h));
  masks_ = storage_buffer(gpu, "hierarchy/masks", mask_at * 4);
  slots_ = storage_buffer(gpu, "hierarchy/slots", slot_at * 4);
  node_keys_ = storage_buffer(gpu, "hierarchy/node-keys", cid_at * 4);
  aabbs_ = storage_buffer(gpu, "hierarchy/aabbs", cid_at * 24);
  cones_ = storage_buffer(gpu, "hierarchy/cones", options_.normal_cones ? cid_at * 16 : 16);
  sample_leaves_ = storage_buffer(gpu, "hierarchy/sample-leaves", pixels * 4);
}

void Hierarchy::build(Context& ctx) {
  const auto& frame = ctx.frame();
  if (frame.width != width_ || frame.height != height_ || !info_)
    allocate(ctx.gpu(), frame.width, frame.height);
  auto scope = ctx.pass("cluster-build");
  auto gbuf = ctx.shared().gbuffer_images();
  const uint32_t L = levels();

  BuildPush push;
  push.view = frame.camera.view;
  uint32_t leaf_w = layout_.frame.z, leaf_h = layout_.frame.w;
  push.normal_scale = int32_t((1u << 30) / (leaf_w * leaf_h));
  // A slice as deep as the leaf block is wide at that depth: ratio 1 + (block's angular size).
  float pixel_angle = 2.f * std::tan(frame.camera.fov_y * 0.5f) / float(height_);
  push.ln_q_min = std::log1p(float(leaf_h) * pixel_angle);

  auto bind = [&](const gpu::Pipeline& pipeline, vk::CommandBuffer cmd) {
    pipeline.bind(cmd,
                  {&info_, &masks_, &slots_, &node_keys_, &aabbs_, &cones_, &sample_leaves_,
                   gbuf.position, gbuf.normal},
                  push);
  };
  const uint32_t gx = gpu::groups_for(width_, 8), gy = gpu::groups_for(height_, 8);
  // ctx.cmd() is fetched anew in every pass: with fenced timing (lavapipe) a pass scope submits and
  // continues in a fresh command buffer.
  {
    auto pass = ctx.pass("depth-range");
    auto cmd = ctx.cmd();
    cmd.fillBuffer(masks_.handle(), 0, VK_WHOLE_SIZE, 0u);
    cmd.fillBuffer(info_.handle(), offsetof(layout::HierInfo, depth), 4, 0x7f800000u);
    cmd.fillBuffer(info_.handle(), offsetof(layout::HierInfo, depth) + 4, 4, 0u);
    cmd.fillBuffer(info_.handle(), offsetof(layout::HierInfo, counts), 4 * HIER_MAX_LEVELS, 0u);
    gpu::full_barrier(cmd);
    bind(depth_range_, cmd);
    cmd.dispatch(gx, gy, 1);
  }
  gpu::full_barrier(ctx.cmd());
  // A pass of one invocation per pixel, then one per node of a level (up to its capacity).
  auto per_pixel_then_per_node = [&](const char* name, const gpu::Pipeline& per_pixel,
                                     const gpu::Pipeline& per_node, uint32_t level) {
    {
      auto pass = ctx.pass(name);
      auto cmd = ctx.cmd();
      bind(per_pixel, cmd);
      cmd.dispatch(gx, gy, 1);
      gpu::full_barrier(cmd);
      bind(per_node, cmd);
      cmd.dispatch(gpu::groups_for(node_capacity(level), 64), 1, 1);
    }
    gpu::full_barrier(ctx.cmd());
  };
  per_pixel_then_per_node("occupancy", occupancy_, leaf_alloc_, L - 2);
  per_pixel_then_per_node("leaf-bounds", leaf_bounds_, leaf_finalize_, L - 1);
  if (options_.normal_cones) {
    auto pass = ctx.pass("cones");
    auto cmd = ctx.cmd();
    bind(leaf_cones_, cmd);
    cmd.dispatch(gx, gy, 1);
  }
  gpu::full_barrier(ctx.cmd());
  {
    auto pass = ctx.pass("propagate");
    auto cmd = ctx.cmd();
    for (int l = int(L) - 2; l >= 0; --l) {
      push.level = uint32_t(l);
      bind(propagate_, cmd);
      cmd.dispatch(gpu::groups_for(node_capacity(uint32_t(l)), 64), 1, 1);
      gpu::full_barrier(cmd);
    }
  }
  gpu::full_barrier(ctx.cmd());
}

}  // namespace pb::toolkit
