// A stable least-significant-digit radix sort of (key, value) pairs of 32-bit words on the GPU
// (kernels: harness/shaders/toolkit/radix): 4-bit digits, per pass a per-block digit count, one
// PrefixSum over the digit-major counts, and a scatter in which each key's rank among the keys of
// its block with the same digit comes from ballots in shared memory, so equal digits keep their
// order (what an LSD sort needs, and CountingSort does not give). Seed 003 §6.2 sorts 30-bit
// Morton codes with it: ceil(30 / 4) = 8 passes.
//
//   RadixSort sort;  sort.setup(gpu, "pd/morton");  sort.reserve(n);
//   sort.record(cmd, keys, values, n, /* key_bits */ 30);   // in place, keys ascending
//
// record() puts full barriers between its own dispatches; the caller puts one before (keys and
// values written) and after (sorted pairs read).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "photonbench/gpu.h"
#include "photonbench/toolkit/gpu_scan.h"

namespace pb::toolkit {

class RadixSort {
 public:
  static constexpr uint32_t kDigitBits = 4;
  static constexpr uint32_t kBlock = 256;  // keys per group (radix_common.glsl)

  void setup(gpu::Device& gpu, std::string_view name);
  // Makes room for sorts of up to `count` pairs (replaces the scratch buffers: call before
  // recording any of the frame's work that sorts).
  void reserve(uint32_t count);
  // Sorts keys[0, count) ascending by their low `key_bits` bits, values alongside; pairs of equal
  // keys keep their input order. Bits above key_bits must be zero. Throws pb::Error when `count`
  // exceeds what was reserved.
  void record(vk::CommandBuffer cmd, const gpu::Buffer& keys, const gpu::Buffer& values,
              uint32_t count, uint32_t key_bits) const;
  uint64_t bytes() const {
    return keys_tmp_.size() + values_tmp_.size() + counts_.size() + offsets_.size() +
           scan_.scratch_bytes();
  }
  uint32_t capacity() const { return capacity_; }

 private:
  gpu::Device* gpu_ = nullptr;
  std::string name_;
  uint32_t capacity_ = 0;
  PrefixSum scan_;
  gpu::Pipeline count_pipeline_, scatter_pipeline_;
  gpu::Buffer keys_tmp_, values_tmp_, counts_, offsets_;
};

}  // namespace pb::toolkit
