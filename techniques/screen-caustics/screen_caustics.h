// screen-caustics' CPU side (seed 001, Ch. 12), a static library linked into the plugin and the
// test program: the parameters, and the Halton emission of the caustic photons,
// aimed at the specular objects by the tracer's aimed emission and re-traced a slice a frame.
#pragma once

#include <glm/glm.hpp>
#include <optional>
#include <string>
#include <vector>

#include "photonbench/param_table.h"
#include "photonbench/photons.h"
#include "photonbench/toolkit/technique.h"

namespace sc {

using glm::max;
using glm::min;
using glm::sqrt;
#include "sc_layout.h"
// After the layout: the filter reads its SC_PRECISION_* and SC_AREA_* constants.
#include "sc_filter.h"

enum class CountPrecision : uint32_t { bits8, floating };
enum class AreaScaling : uint32_t { none, multiply, divide };

struct ScParams {
  uint32_t photons = 10000;
  uint32_t retrace_frames = 8;
  uint32_t max_bounces = 6;
  CountPrecision count_precision = CountPrecision::bits8;
  uint32_t grid = 10;
  uint32_t filter_k = 3;
  AreaScaling area_scaling = AreaScaling::divide;
  float depth_tolerance = 0.01f;
  uint32_t shadow_map_size = pb::kDefaultShadowMapSize;
};

namespace tk = pb::toolkit;

// clang-format off
inline constexpr auto kParams = pb::params(
    pb::param("photons", &ScParams::photons, 10000, {1, 1e7}, "photons",
              "caustic light paths, Halton points aimed at the specular objects (Ch. 12, Ch. 14's "
              "demo: 10,000)"),
    pb::param("retrace_frames", &ScParams::retrace_frames, 8, {1, 1024}, "frames",
              "frames over which every photon is re-traced once: each frame re-traces 1 / "
              "retrace_frames of them, round robin, and keeps the rest (Ch. 14: 8); with fewer "
              "photons than frames, some frames re-trace none"),
    pb::bind(tk::with_range(tk::kMaxBouncesParam, 6, 2, 31,
                            "surface interactions per caustic path; photons are stored at the "
                            "first diffuse hit after specular ones (L S+ D)"),
             &ScParams::max_bounces),
    pb::param("count_precision", &ScParams::count_precision, CountPrecision::bits8, "8bit|float",
              "the count buffer: 8bit saturates a pixel at 255 photons (the thesis's pbuffer), "
              "float does not"),
    pb::param("grid", &ScParams::grid, 10, {1, 256}, "cells",
              "screen grid cells per side; the filter skips cells with no photon within k pixels "
              "(the thesis's occlusion queries; 100 were timed, so 10 x 10)"),
    pb::param("filter_k", &ScParams::filter_k, 3, {0, 15}, "px",
              "half-width of Eq. 12.1's filter, (2k + 1)^2 pixels (the thesis: k = 3, 7 x 7)"),
    pb::param("area_scaling", &ScParams::area_scaling, AreaScaling::divide,
              "none|multiply|divide",
              "Eq. 12.2's pixel-area term: none (a fixed scale), multiply (the cosine multiplies "
              "the area, as printed) or divide (the physical footprint)"),
    pb::param("depth_tolerance", &ScParams::depth_tolerance, 0.01, {1e-6, 1}, "",
              "a point passes the depth test when its distance is within this fraction of the "
              "visible surface's (the photons lie on the surfaces the G-buffer sees)"),
    pb::bind(tk::kShadowMapSizeParam, &ScParams::shadow_map_size));
// clang-format on

// Where the caustic photons leave the lights: photon i of `photons` is the Halton point
// (radical inverses in bases 2 and 3 for the emission domain, 5 and 7 for a surface emitter's
// direction, 11 for the light), its light chosen by power and its point warped into the light's
// aimed density (PhotonTracer::aimed_emission_densities), so every photon starts towards a
// specular object. Each trace lists the photons of one slice, i = slice + k * slices, so that
// `slices` traces cover all of them once (the thesis's round robin over 8 frames). A seed axis's
// scramble starts the sequence further on (a hashed offset of its index), so that its seeds see
// other photons while the points stay a Halton sequence.
class HaltonEmission final : public pb::trace::EmissionSampler {
 public:
  // The aimed densities (one per light, nothing: uniform) and the photon count.
  void configure(std::vector<std::optional<pb::trace::EmissionDensity>> densities, uint32_t photons,
                 uint32_t slices);
  void select_slice(uint32_t slice) { slice_ = slice; }
  uint64_t prepare(const pb::trace::EmissionFrame& frame) override;
  pb::trace::EmissionPoint emission(uint64_t i) const override;
  // Photons of `slice` (the last slices may hold one fewer).
  uint32_t slice_size(uint32_t slice) const;

 private:
  struct Aim {  // a piecewise-constant 2D distribution: rows (v) then columns (u) by inversion
    int width = 0, height = 0;
    std::vector<float> row_cdf, column_cdf;  // height + 1; height * (width + 1)
    std::vector<float> texels;
    float mean = 1;
  };
  std::vector<std::optional<Aim>> aims_;
  std::vector<float> light_cdf_;
  uint32_t photons_ = 0, slices_ = 1, slice_ = 0;
  uint64_t start_ = 0;  // the Halton index of photon 0
};

float radical_inverse(uint32_t base, uint64_t i);

}  // namespace sc
