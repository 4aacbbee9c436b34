// RadixSort (photonbench/toolkit/radix_sort.h).
#include "photonbench/toolkit/radix_sort.h"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "photonbench/error.h"
#include "photonbench/toolkit/technique.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

namespace {

// Mirrors RadixPush (radix_common.glsl).
struct RadixPush {
  uint32_t count = 0, shift = 0, blocks = 0;
};

constexpr uint32_t kDigits = 1u << RadixSort::kDigitBits;

}  // namespace

void RadixSort::setup(gpu::Device& gpu, std::string_view name) {
  gpu_ = &gpu;
  name_ = std::string(name);
  scan_.setup(gpu);
  std::vector<gpu::Binding> bindings(6, gpu::Binding::storage_buffer);
  count_pipeline_ = gpu.create_compute_pipeline(name_ + "/radix-count", kradix_count_comp_spv,
                                                bindings, sizeof(RadixPush));
  scatter_pipeline_ = gpu.create_compute_pipeline(name_ + "/radix-scatter", kradix_scatter_comp_spv,
                                                  bindings, sizeof(RadixPush));
  reserve(kBlock);
}

void RadixSort::reserve(uint32_t count) {
  if (count <= capacity_) return;
  capacity_ = std::max(count, kBlock);
  const uint64_t words = uint64_t(gpu::groups_for(capacity_, kBlock)) * kDigits;
  keys_tmp_ = storage_buffer(*gpu_, name_ + "/radix-keys", uint64_t(capacity_) * 4);
  values_tmp_ = storage_buffer(*gpu_, name_ + "/radix-values", uint64_t(capacity_) * 4);
  counts_ = storage_buffer(*gpu_, name_ + "/radix-counts", words * 4);
  offsets_ = storage_buffer(*gpu_, name_ + "/radix-offsets", words * 4);
  scan_.reserve(uint32_t(words));
}

void RadixSort::record(vk::CommandBuffer cmd, const gpu::Buffer& keys, const gpu::Buffer& values,
                       uint32_t count, uint32_t key_bits) const {
  if (count > capacity_)
    throw Error(
        fmt::format("{}: radix sort of {} pairs, only {} reserved", name_, count, capacity_));
  if (count < 2) return;
  const uint32_t blocks = gpu::groups_for(count, kBlock);
  const uint32_t passes = (std::min(key_bits, 32u) + kDigitBits - 1) / kDigitBits;
  const gpu::Buffer* from[2] = {&keys, &values};
  const gpu::Buffer* to[2] = {&keys_tmp_, &values_tmp_};
  for (uint32_t pass = 0; pass < passes; ++pass) {
    RadixPush push{count, pass * kDigitBits, blocks};
    if (pass > 0) gpu::full_barrier(cmd);
    count_pipeline_.bind(cmd, {from[0], from[1], to[0], to[1], &counts_, &offsets_}, push);
    cmd.dispatch(blocks, 1, 1);
    gpu::full_barrier(cmd);
    scan_.record(cmd, counts_, offsets_, blocks * kDigits);
    gpu::full_barrier(cmd);
    scatter_pipeline_.bind(cmd, {from[0], from[1], to[0], to[1], &counts_, &offsets_}, push);
    cmd.dispatch(blocks, 1, 1);
    std::swap(from[0], to[0]);
    std::swap(from[1], to[1]);
  }
  if (passes % 2 == 1) {  // the sorted pairs are in the scratch buffers: copy them back
    gpu::full_barrier(cmd);
    cmd.copyBuffer(keys_tmp_.handle(), keys.handle(), vk::BufferCopy{0, 0, uint64_t(count) * 4});
    cmd.copyBuffer(values_tmp_.handle(), values.handle(),
                   vk::BufferCopy{0, 0, uint64_t(count) * 4});
  }
}

}  // namespace pb::toolkit
