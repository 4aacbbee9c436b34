// Image metrics: FLIP (LDR and HDR), SSIM, PSNR, RMSE, MAE, relMSE and temporal instability.
//
// Each metric reproduces a reference implementation, and the conformance set in tests/data/metrics
// holds the values those implementations give:
//   FLIP  LDR-FLIP: Andersson et al., "FLIP: A Difference Evaluator for Alternating Images",
//         HPG 2020; HDR-FLIP: Andersson et al., "Visualizing Errors in Rendered High Dynamic Range
//         Images", EG 2021; both with the defaults of the NVIDIA reference tool v1.6.
//   SSIM  Wang et al., "Image Quality Assessment: From Error Visibility to Structural Similarity",
//         IEEE TIP 2004, computed as scikit-image's structural_similarity with Gaussian weights.
//   PSNR  as scikit-image's peak_signal_noise_ratio with data range 1.
//
// Which values each metric sees:
//   - FLIP takes LDR images (linear == false) as sRGB-encoded values in [0, 1] and HDR images
//     (linear == true) as linear radiance; the reference image decides which FLIP runs.
//   - SSIM and PSNR take display-encoded values: LDR values as stored (8-bit / 255), HDR values
//     clamped to [0, 1] and then sRGB encoded.
//   - RMSE, MAE and relMSE take linear values: HDR values as stored, LDR values sRGB decoded.
// Images have 3 or 4 channels (a 4th, alpha, is ignored) or 1 (grey, used for all three colours).
// Mismatched sizes, LDR against HDR, or non-finite pixels throw pb::InputError.
#pragma once

#include <optional>
#include <string_view>
#include <vector>

#include "io/image.h"

namespace pb::metrics {

// The builds of the metrics' hot loops (x86-64 levels): baseline SSE2, AVX2 with FMA (x86-64-v3)
// and AVX-512 (x86-64-v4). The widest the CPU runs is used unless use_vector_path picks another;
// their values agree to rounding (1e-12 for SSIM), not to the bit, since FMA rounds once.
// Elsewhere than x86-64 with GCC there is only the baseline build.
enum class VectorPath { baseline, avx2, avx512 };
const char* to_string(VectorPath path);  // "baseline (SSE2)", "AVX2+FMA", "AVX-512"
bool cpu_runs(VectorPath path);          // this CPU runs that build (and it was built)
VectorPath vector_path();                // the build in use
// Switches every later metric call to `path` (for benches and tests); throws pb::InputError when
// cpu_runs(path) is false.
void use_vector_path(VectorPath path);

enum class Tonemapper { aces, hable, reinhard };

// "aces", "hable" or "reinhard" (case-insensitive); anything else throws pb::InputError.
Tonemapper parse_tonemapper(std::string_view name);
const char* to_string(Tonemapper tonemapper);

// The reference tool's default viewing condition: a 0.7 m wide, 3840 pixel monitor seen from 0.7 m,
// 3840 * pi / 180 = 67.02 pixels per degree (it prints this rounded to 67).
inline constexpr double kDefaultPixelsPerDegree = 67.02064327658226;

struct FlipOptions {
  double pixels_per_degree = kDefaultPixelsPerDegree;
  Tonemapper tonemapper = Tonemapper::aces;  // HDR-FLIP only
  // HDR-FLIP exposure range in stops. Unset values are computed from the reference image as the
  // reference tool does (EG 2021, the automatic exposure range): start from the largest luminance,
  // stop from the median, count = max(2, ceil(stop - start)).
  std::optional<double> start_exposure, stop_exposure;
  std::optional<int> num_exposures;
};

// Pooled statistics of a FLIP error map. The weighted median and quartiles weight every pixel's
// error by itself, as the reference tool does: the p-quantile is the smallest error e such that
// the errors <= e sum to more than p times the sum of all errors.
struct FlipStats {
  double mean = 0, weighted_median = 0, q1 = 0, q3 = 0, min = 0, max = 0;
};

struct HdrExposures {
  double start = 0, stop = 0;
  int count = 0;
};

struct FlipResult {
  FlipStats stats;
  io::Image error_map;                    // 1 channel, values in [0, 1], linear = false
  std::optional<HdrExposures> exposures;  // the range HDR-FLIP used; empty for LDR-FLIP
};

// LDR-FLIP when !reference.linear, HDR-FLIP otherwise.
FlipResult flip(const io::Image& reference, const io::Image& test, const FlipOptions& options = {});

// Pools an error map (any values; the map's first channel) into FlipStats.
FlipStats pool_flip(const io::Image& error_map);

// SSIM in [-1, 1], the mean over channels of the mean SSIM map, 5-pixel border excluded (as
// scikit-image crops it). Images smaller than the 11x11 window throw pb::InputError (as
// scikit-image refuses them), and so does evaluate() on them.
double ssim(const io::Image& reference, const io::Image& test);

struct Psnr {
  std::optional<double> db;  // empty when the images are identical (infinite PSNR)
  bool identical = false;    // the display-encoded values are equal everywhere
};
Psnr psnr(const io::Image& reference, const io::Image& test);

double rmse(const io::Image& reference, const io::Image& test);
double mae(const io::Image& reference, const io::Image& test);
// mean((t - r)^2 / (r^2 + 0.01)) over pixels and colour channels, on linear values.
double relmse(const io::Image& reference, const io::Image& test);

struct Scores {
  FlipStats flip;
  double ssim = 0;
  std::optional<double> psnr;  // empty when identical
  bool identical = false;
  double rmse = 0, mae = 0, relmse = 0;
};

// Which metrics evaluate() and noise_floor() compute. FLIP is the costly one (colour transforms and
// spatial and feature filters over a neighbourhood of every pixel): a caller that reports no FLIP
// (scoring, when the config's `metrics` do not name it) leaves it out, and Scores' flip then stays
// zero. The others always come.
struct MetricSelection {
  bool flip = true;
};

// Every metric of one pair (FLIP as `selection` says). When flip_error_map is given and FLIP is
// computed, FLIP's error map is moved into it.
Scores evaluate(const io::Image& reference, const io::Image& test, const FlipOptions& options = {},
                io::Image* flip_error_map = nullptr, const MetricSelection& selection = {});

// The magma colour map (matplotlib's, as the reference tool uses it) applied to an error map's
// first channel: 3 channels, display-encoded (linear = false), ready for io::write_image(".png").
io::Image magma(const io::Image& error_map);

// Flicker that per-frame error misses: the mean over pixels and consecutive frame pairs of
// |(T_t - T_{t-1}) - (R_t - R_{t-1})| on display-encoded luma (Rec. 709 weights applied to the
// display-encoded channels). 0 when the test changes exactly as the reference does. Needs two or
// more frames, the same count in both sequences and one size throughout.
double temporal_instability(const std::vector<io::Image>& reference_frames,
                            const std::vector<io::Image>& test_frames);

}  // namespace pb::metrics
