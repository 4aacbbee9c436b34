// The toolkit's GPU prefix sum and its one sort (kernels: harness/shaders/toolkit/scan, sort).
//
//   PrefixSum scan;          scan.setup(gpu);  scan.reserve(n);
//   scan.record(cmd, counts, offsets, n, &stats, kTotalWord);   // offsets = exclusive scan
//
//   CountingSort sort;       sort.setup(gpu);  sort.resize(gpu, scan, bins, "cluster/jobs");
//   sort.record(cmd, scan, items, sorted, count_buffer, count_word, args_offset);
//
// Both record into a command buffer with full barriers between their own dispatches; the caller
// puts a barrier before (inputs written) and after (outputs read).
#pragma once

#include <cstdint>
#include <string_view>

#include "photonbench/gpu.h"

namespace pb::toolkit {

// Exclusive prefix sum of 32-bit words (Paper I §4.3 turns per-node counts into list offsets with
// one): three dispatches, 4096 words per group; any count up to 2^28.
class PrefixSum {
 public:
  void setup(gpu::Device& gpu);
  // Makes room for scans of up to `count` words. Call before recording anything of the frame that
  // scans: the scratch buffer may be replaced, and recorded work still refers to the old one.
  void reserve(uint32_t count);
  // Records out[i] = in[0] + ... + in[i-1] for i < count; with `total`, total[total_word] = the sum
  // of all words. Throws pb::Error if `count` exceeds what was reserved.
  void record(vk::CommandBuffer cmd, const gpu::Buffer& in, const gpu::Buffer& out, uint32_t count,
              const gpu::Buffer* total = nullptr, uint32_t total_word = 0) const;
  uint64_t scratch_bytes() const { return blocks_.size(); }

 private:
  gpu::Device* gpu_ = nullptr;
  gpu::Pipeline blocks_pipeline_, top_pipeline_, add_pipeline_;
  gpu::Buffer blocks_, no_total_;
};

// Counting sort of uvec2 items by key = item.y & key_mask (< bins): count, prefix sum, scatter. The
// item count is read on the GPU from count_buffer[count_word], and the two item passes are
// dispatched indirectly from count_buffer at args_offset (bytes: a VkDispatchIndirectCommand of
// ceil(count / 64) groups), so a GPU producer's output is sorted without a read-back. Items of one
// key end up contiguous; their order among themselves is not fixed.
class CountingSort {
 public:
  static constexpr uint32_t kGroupSize = 64;  // items per group of the indirect dispatch
  void setup(gpu::Device& gpu);
  // (Re)allocates the per-key counters (bins keys).
  // (Re)allocates the per-key counters (bins keys) and reserves the scan for them.
  void resize(gpu::Device& gpu, PrefixSum& scan, uint32_t bins, std::string_view name);
  void record(vk::CommandBuffer cmd, const PrefixSum& scan, const gpu::Buffer& items,
              const gpu::Buffer& sorted, const gpu::Buffer& count_buffer, uint32_t count_word,
              vk::DeviceSize args_offset, uint32_t key_mask = 0x7fffffffu) const;
  uint64_t bytes() const { return bins_.size() + offsets_.size() + cursors_.size(); }
  uint32_t bins() const { return bin_count_; }

 private:
  gpu::Pipeline count_pipeline_, scatter_pipeline_;
  gpu::Buffer bins_, offsets_, cursors_;
  uint32_t bin_count_ = 0;
};

}  // namespace pb::toolkit
