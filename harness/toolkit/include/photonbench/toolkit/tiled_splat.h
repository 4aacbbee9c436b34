// Paper I's tiled photon splatting (§5.1, after Mara, Luebke & McGuire 2013) as a Splatter: 32x32
// screen tiles with view-depth bounds, photons binned into per-tile lists by testing each photon's
// sphere against the tiles under its screen rectangle, then per pixel a constant-kernel estimate
// over its tile's list. Passes: tile-bounds, splat/{count, prefix-sum, insert, check},
// radiance-estimate. Shaders: harness/shaders/toolkit/tiled/. The `tiled` technique is this alone;
// techniques/tiled/README.md describes it and its deviations.
#pragma once

#include "photonbench/toolkit/gpu_scan.h"
#include "photonbench/toolkit/photon_lists.h"
#include "photonbench/toolkit/technique.h"

namespace pb::toolkit {

class TiledSplat final : public Splatter {
 public:
  static constexpr const char* kName = "tiled";
  // Its parameters (tile_size a multiple of 8: check()).
  struct Options {
    uint32_t tile_size;
    uint32_t max_list_entries;
    float insert_radius_scale;  // the test hook kListCheckHookParam
  };
  // clang-format off
  static constexpr auto kParams = pb::params(
      pb::param("tile_size", &Options::tile_size, 32, {8, 256}, "pixels",
                "tile side, a multiple of 8; Paper I §5.1 uses 32"),
      pb::param("max_list_entries", &Options::max_list_entries, 1 << 22, {1, 1 << 28}, "entries",
                "capacity of all per-tile lists together (photon indices); overflowing entries are "
                "dropped and counted"),
      pb::bind(kListCheckHookParam, &Options::insert_radius_scale));
  static constexpr pb_counter_spec kBytesTileBoundsCounter = {
      "bytes_tile_bounds", PB_COUNTER_SIZE, "bytes",
      "2 floats per tile (Paper I Table 1's Tiles z-Bounds)"};
  // clang-format on
  static constexpr auto kCounters = join_counters(
      kPhotonListsCounters, std::array{kPhotonsReadCounter, kPhotonsRejectedCounter,
                                       kBytesTileBoundsCounter, kBytesPhotonListsCounter});
  // tile_size a multiple of 8 (the 8x8 work groups of tile-bounds must lie in one tile).
  static std::string check(const Params& params);

  void setup(Context& ctx, const Params& params, const PhotonParams& photon) override;
  const gpu::Image& render(Context& ctx, const PhotonSet& photons) override;
  void report(Context& ctx, const PhotonSet& photons) override;

 private:
  void ensure_resources(Context& ctx);

  Options options_ = kParams.defaults();
  float radius_ = 0;
  uint32_t width_ = 0, height_ = 0, tiles_x_ = 0, tiles_y_ = 0, tile_count_ = 0;
  PrefixSum scan_;
  PhotonLists lists_;
  gpu::Buffer bounds_, stats_;
  gpu::Image indirect_;
  gpu::Pipeline bounds_pipeline_, splat_pipeline_, estimate_pipeline_;
};

}  // namespace pb::toolkit
