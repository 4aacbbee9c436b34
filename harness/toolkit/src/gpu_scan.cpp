// PrefixSum and CountingSort (photonbench/toolkit/gpu_scan.h).
#include "photonbench/toolkit/gpu_scan.h"

#include <fmt/format.h>

#include <algorithm>
#include <string>

#include "photonbench/error.h"
#include "toolkit_shaders.h"

namespace pb::toolkit {

namespace {

using gpu::Binding;
using U = vk::BufferUsageFlagBits;

constexpr uint32_t kScanBlock = 4096;  // words per scan_blocks group (scan_common.glsl)

// Mirrors ScanPush (scan_common.glsl).
struct ScanPush {
  uint32_t count = 0, total_at = 0;
};
// Mirrors SortPush (sort_common.glsl).
struct SortPush {
  uint32_t count_at = 0, key_mask = 0;
};

constexpr auto kStorage = U::eStorageBuffer | U::eTransferDst | U::eTransferSrc;

}  // namespace

void PrefixSum::setup(gpu::Device& gpu) {
  gpu_ = &gpu;
  std::vector<Binding> bindings(4, Binding::storage_buffer);
  blocks_pipeline_ = gpu.create_compute_pipeline("prefix-sum/blocks", kscan_blocks_comp_spv,
                                                 bindings, sizeof(ScanPush));
  top_pipeline_ =
      gpu.create_compute_pipeline("prefix-sum/top", kscan_top_comp_spv, bindings, sizeof(ScanPush));
  add_pipeline_ =
      gpu.create_compute_pipeline("prefix-sum/add", kscan_add_comp_spv, bindings, sizeof(ScanPush));
  no_total_ = gpu.create_buffer("prefix-sum/no-total", 16, kStorage, gpu::Memory::device_local);
}

void PrefixSum::reserve(uint32_t count) {
  const uint64_t bytes = uint64_t(std::max<uint32_t>(1, gpu::groups_for(count, kScanBlock))) * 4;
  if (blocks_.size() < bytes)
    blocks_ = gpu_->create_buffer("prefix-sum/blocks", std::max<uint64_t>(bytes, 16), kStorage,
                                  gpu::Memory::device_local);
}

void PrefixSum::record(vk::CommandBuffer cmd, const gpu::Buffer& in, const gpu::Buffer& out,
                       uint32_t count, const gpu::Buffer* total, uint32_t total_word) const {
  const uint32_t blocks = std::max<uint32_t>(1, gpu::groups_for(count, kScanBlock));
  if (blocks_.size() < uint64_t(blocks) * 4)
    throw Error(fmt::format("prefix sum of {} words: only {} reserved", count,
                            blocks_.size() / 4 * kScanBlock));
  ScanPush push{count, total ? total_word : 0xffffffffu};
  const gpu::Buffer* total_buffer = total ? total : &no_total_;
  blocks_pipeline_.bind(cmd, {&in, &out, &blocks_, total_buffer}, push);
  cmd.dispatch(blocks, 1, 1);
  gpu::full_barrier(cmd);
  top_pipeline_.bind(cmd, {&in, &out, &blocks_, total_buffer}, push);
  cmd.dispatch(1, 1, 1);
  gpu::full_barrier(cmd);
  add_pipeline_.bind(cmd, {&in, &out, &blocks_, total_buffer}, push);
  cmd.dispatch(blocks, 1, 1);
}

void CountingSort::setup(gpu::Device& gpu) {
  std::vector<Binding> bindings(6, Binding::storage_buffer);
  count_pipeline_ =
      gpu.create_compute_pipeline("sort/count", ksort_count_comp_spv, bindings, sizeof(SortPush));
  scatter_pipeline_ = gpu.create_compute_pipeline("sort/scatter", ksort_scatter_comp_spv, bindings,
                                                  sizeof(SortPush));
}

void CountingSort::resize(gpu::Device& gpu, PrefixSum& scan, uint32_t bins, std::string_view name) {
  bin_count_ = bins;
  scan.reserve(bins);
  uint64_t bytes = std::max<uint64_t>(uint64_t(bins) * 4, 16);
  auto make = [&](const char* what) {
    return gpu.create_buffer(std::string(name) + "/" + what, bytes, kStorage,
                             gpu::Memory::device_local);
  };
  bins_ = make("sort-bins");
  offsets_ = make("sort-offsets");
  cursors_ = make("sort-cursors");
}

void CountingSort::record(vk::CommandBuffer cmd, const PrefixSum& scan, const gpu::Buffer& items,
                          const gpu::Buffer& sorted, const gpu::Buffer& count_buffer,
                          uint32_t count_word, vk::DeviceSize args_offset,
                          uint32_t key_mask) const {
  cmd.fillBuffer(bins_.handle(), 0, VK_WHOLE_SIZE, 0u);
  cmd.fillBuffer(cursors_.handle(), 0, VK_WHOLE_SIZE, 0u);
  gpu::full_barrier(cmd);
  SortPush push{count_word, key_mask};
  count_pipeline_.bind(cmd, {&items, &sorted, &count_buffer, &bins_, &offsets_, &cursors_}, push);
  cmd.dispatchIndirect(count_buffer.handle(), args_offset);
  gpu::full_barrier(cmd);
  scan.record(cmd, bins_, offsets_, bin_count_);
  gpu::full_barrier(cmd);
  scatter_pipeline_.bind(cmd, {&items, &sorted, &count_buffer, &bins_, &offsets_, &cursors_}, push);
  cmd.dispatchIndirect(count_buffer.handle(), args_offset);
}

}  // namespace pb::toolkit
