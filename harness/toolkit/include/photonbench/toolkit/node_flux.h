// Per-node fixed-point flux sums over a Hierarchy's nodes (cluster's trivial-accept node flux,
// Paper I §4.6; directional's direction buckets, §4.7): `words_per_node` words (groups of r, g, b)
// per cid of levels 0 to `stop_level`, 64-bit each as a low and a high word (GPU side: PB_FLUX_ADD
// of toolkit/atomics.glsl; the scale and the error bound: fixed_point.h). After the splat,
// resolve() turns the occupied nodes' sums into floats in place (the low words hold the float
// bits), so an estimate reads `uintBitsToFloat(lo[at])`, in watts.
//
//   flux.resize(gpu, hierarchy, stop_level, words_per_node, "directional/accum-flux");
//   per frame: flux.clear(cmd); [splat: PB_FLUX_ADD into lo(), hi()]; flux.resolve(cmd, hierarchy,
//              scale); [estimate]
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "photonbench/gpu.h"
#include "photonbench/toolkit/fixed_point.h"
#include "photonbench/toolkit/hierarchy.h"

namespace pb::toolkit {

// clang-format off
inline constexpr pb_counter_spec kBytesAccumFluxCounter = {
    "bytes_accum_flux", PB_COUNTER_SIZE, "bytes", "the per-node flux sums, low and high words"};
// clang-format on

class NodeFlux {
 public:
  void setup(gpu::Device& gpu);
  // Sized for every node of levels 0 .. stop_level (per the hierarchy's cid capacity). Throws
  // InputError naming `what` when a binding exceeds the device's maxStorageBufferRange.
  void resize(gpu::Device& gpu, const Hierarchy& hierarchy, uint32_t stop_level,
              uint32_t words_per_node, std::string name, std::string_view what);
  void clear(vk::CommandBuffer cmd) const;
  void resolve(vk::CommandBuffer cmd, const Hierarchy& hierarchy, const FluxScale& scale) const;
  const gpu::Buffer& lo() const { return lo_; }
  const gpu::Buffer& hi() const { return hi_; }
  uint64_t bytes() const { return lo_.size() + hi_.size(); }

 private:
  uint32_t stop_level_ = 0, words_per_node_ = 3;
  gpu::Buffer lo_, hi_, args_;
  gpu::Pipeline args_pipeline_, resolve_pipeline_;
};

}  // namespace pb::toolkit
