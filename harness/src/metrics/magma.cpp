// The magma colour map for FLIP error maps (EG 2021 and the reference tool show errors in magma).
//
// The 256 entries are matplotlib's "magma" (Smith and van der Walt 2015, perceptually uniform in
// CAM02-UCS), read from the installed matplotlib when photonbench is built.
#include <algorithm>
#include <cmath>

#include "metrics/metrics.h"
#include "photonbench/error.h"

namespace pb::metrics {
namespace {

// sRGB-encoded colours, index 0 for error 0 and 255 for error 1, generated at build time from
// Debian's python3-matplotlib by cmake/magma_table.py (the repository holds no copy of the table).
constexpr float kMagma[256][3] =
#include "magma_table.inc"
    ;

}  // namespace

io::Image magma(const io::Image& error_map) {
  if (error_map.channels < 1) throw Error("magma: the error map has no channels");
  io::Image out(error_map.width, error_map.height, 3, /*is_linear=*/false);
  const size_t n = error_map.pixel_count();
  for (size_t i = 0; i < n; ++i) {
    float e = error_map.pixels[i * error_map.channels];
    // The reference tool picks the nearest of the 256 entries (round, since its v1.1).
    int index = std::isfinite(e) ? int(std::clamp(e, 0.f, 1.f) * 255.f + 0.5f) : 255;
    std::copy_n(kMagma[index], 3, &out.pixels[i * 3]);
  }
  return out;
}

}  // namespace pb::metrics
