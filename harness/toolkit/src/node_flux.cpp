// NodeFlux (photonbench/toolkit/node_flux.h).
#include "photonbench/toolkit/node_flux.h"

#include <fmt/format.h>

#include "photonbench/toolkit/technique.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

namespace {

// Mirrors the push block of harness/shaders/toolkit/flux/node_flux_common.glsl.
struct NodeFluxPush {
  glm::vec4 watts_per_unit;
  uint32_t stop_level, words_per_node, pad0, pad1;
};

}  // namespace

void NodeFlux::setup(gpu::Device& gpu) {
  std::vector<gpu::Binding> bindings(Hierarchy::kBindingCount + 3, gpu::Binding::storage_buffer);
  args_pipeline_ = gpu.create_compute_pipeline("node-flux/args", knode_flux_args_comp_spv, bindings,
                                               sizeof(NodeFluxPush));
  resolve_pipeline_ = gpu.create_compute_pipeline("node-flux/resolve", knode_flux_resolve_comp_spv,
                                                  bindings, sizeof(NodeFluxPush));
  using U = vk::BufferUsageFlagBits;
  args_ = gpu.create_buffer("node-flux/args", 16, U::eStorageBuffer | U::eIndirectBuffer,
                            gpu::Memory::device_local);
}

void NodeFlux::resize(gpu::Device& gpu, const Hierarchy& hierarchy, uint32_t stop_level,
                      uint32_t words_per_node, std::string name, std::string_view what) {
  stop_level_ = stop_level;
  words_per_node_ = words_per_node;
  const uint64_t nodes = hierarchy.first_cid(stop_level) + hierarchy.node_capacity(stop_level);
  const uint64_t bytes = nodes * words_per_node * 4;
  check_storage_range(gpu, bytes, what);
  lo_ = storage_buffer(gpu, name + "-lo", bytes);
  hi_ = storage_buffer(gpu, name + "-hi", bytes);
}

void NodeFlux::clear(vk::CommandBuffer cmd) const {
  cmd.fillBuffer(lo_.handle(), 0, VK_WHOLE_SIZE, 0u);
  cmd.fillBuffer(hi_.handle(), 0, VK_WHOLE_SIZE, 0u);
}

void NodeFlux::resolve(vk::CommandBuffer cmd, const Hierarchy& hierarchy,
                       const FluxScale& scale) const {
  NodeFluxPush push{glm::vec4(scale.watts_per_unit, 0.0f), stop_level_, words_per_node_, 0, 0};
  std::vector<gpu::Resource> resources;
  hierarchy.append_bindings(resources);
  resources.insert(resources.end(), {&lo_, &hi_, &args_});
  args_pipeline_.bind(cmd, resources, push);
  cmd.dispatch(1, 1, 1);
  gpu::full_barrier(cmd);
  resolve_pipeline_.bind(cmd, resources, push);
  cmd.dispatchIndirect(args_.handle(), 0);
}

}  // namespace pb::toolkit
