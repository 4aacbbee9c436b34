// Per-bin photon lists from Paper I's count / prefix-sum / insert splatting (§4.3), with the check
// that the two splatting runs agree (GPU side and the reasons: harness/shaders/toolkit/
// photon_lists.glsl). Bins are tiles (tiled) or hierarchy nodes (cluster).
//
//   lists.setup(gpu, capacity, "tiled");   lists.resize(gpu, scan, bins);      (per resolution)
//   per frame: lists.clear(cmd); [count run]; lists.scan(cmd, scan); [insert run];
//              lists.check(cmd);
//   estimate: pb_list_range(bin); after ctx.flush(): lists.report(ctx, ...)
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "photonbench/context.h"
#include "photonbench/gpu.h"
#include "photonbench/param_table.h"
#include "photonbench/plugin.h"
#include "photonbench/toolkit/gpu_scan.h"
#include "photonbench/toolkit/photon_lists_layout.h"

namespace pb::toolkit {

// The test hook of every count / insert splatter (tiled, cluster): the insert run tests spheres of
// radius x this, so that the two runs disagree and the consistency check must report it.
// clang-format off
inline constexpr pb_param_spec kListCheckHookParam = pb::row<float>(
    "debug_insert_radius", 1, {0.25, 4}, "",
    "test hook: the insert run's sphere radius relative to the count run's (1: the same); "
    "anything else makes them disagree, which is counted (list_mismatches) and warned about");

// The counters PhotonLists::report emits.
inline constexpr pb_counter_spec kListEntriesCounter = {
    "list_entries", PB_COUNTER_SIZE, "entries", "list entries written"};
inline constexpr pb_counter_spec kListOverflowsCounter = {
    "list_overflows", PB_COUNTER_WORK, "entries",
    "list entries dropped for want of capacity (a warning when non-zero)"};
inline constexpr pb_counter_spec kListMismatchesCounter = {
    "list_mismatches", PB_COUNTER_WORK, "bins",
    "bins whose count and insert runs disagree (a warning when non-zero)"};
// The constant-kernel estimate over lists (photon_gather.glsl), and the lists' memory.
inline constexpr pb_counter_spec kPhotonsReadCounter = {
    "photons_read", PB_COUNTER_WORK, "photons", "list entries the estimate visited (64-bit exact)"};
inline constexpr pb_counter_spec kPhotonsRejectedCounter = {
    "photons_rejected", PB_COUNTER_WORK, "photons",
    "entries read but outside the sphere or arriving from below the tangent plane"};
inline constexpr pb_counter_spec kBytesPhotonListsCounter = {
    "bytes_photon_lists", PB_COUNTER_SIZE, "bytes",
    "lists, counts, offsets, cursors (and the scan's blocks)"};
// clang-format on
inline constexpr std::array kPhotonListsCounters = {kListEntriesCounter, kListOverflowsCounter,
                                                    kListMismatchesCounter};

class PhotonLists {
 public:
  static constexpr uint32_t kBindingCount = PB_LISTS_BINDING_COUNT;

  // `capacity` entries (4 bytes each) for all bins together; `name` prefixes the buffers' names.
  void setup(gpu::Device& gpu, uint32_t capacity, std::string name);
  // (Re)allocates the per-bin counters for `bins` bins and reserves the scan.
  void resize(gpu::Device& gpu, PrefixSum& scan, uint32_t bins);
  // Counts and cursors to zero, the stats words to this frame's capacity and bins.
  void clear(vk::CommandBuffer cmd) const;
  // Offsets = exclusive prefix sum of the counts; the total to the stats (entries wanted).
  void scan(vk::CommandBuffer cmd, const PrefixSum& scan) const;
  // After the insert run: counts the bins whose inserts differ from their counts, and leaves in
  // the counts what an estimate may read (pb_list_range). Must run before any estimate.
  void check(vk::CommandBuffer cmd) const;
  // Passes "count", "prefix-sum", "insert" and "check" (nested in the caller's scope): `splat`
  // records one splatting run into the command buffer, the count run (insert = false), then the
  // insert run; the lists must be cleared already.
  void record_runs(Context& ctx, const PrefixSum& scan,
                   const std::function<void(vk::CommandBuffer cmd, bool insert)>& splat) const;
  void append_bindings(std::vector<gpu::Resource>& resources) const;

  struct Stats {
    uint64_t wanted = 0, written = 0, overflows = 0, mismatched_bins = 0, mismatched_entries = 0;
  };
  Stats stats() const;  // this frame's, after ctx.flush()
  // Counters list_entries (written), list_overflows (entries dropped for want of capacity),
  // list_mismatches (bins whose count and insert runs disagree), with a warning for each non-zero
  // one; `who` ("tiled: per-tile photon lists") and `capacity_param` ("max_list_entries") name
  // them.
  void report(Context& ctx, std::string_view who, std::string_view capacity_param) const;
  uint64_t bytes() const;  // lists + counts + offsets + cursors
  uint32_t capacity() const { return capacity_; }
  uint32_t bins() const { return bins_; }

 private:
  gpu::Device* gpu_ = nullptr;
  std::string name_;
  uint32_t capacity_ = 0, bins_ = 0;
  gpu::Buffer counts_, offsets_, cursors_, lists_, stats_;
  gpu::Pipeline check_pipeline_;
};

}  // namespace pb::toolkit
