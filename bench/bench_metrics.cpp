// bench_metrics: our metrics next to their anchors, measured in the same run. FLIP (LDR and HDR)
// runs against NVIDIA's reference FLIP tool (the C++ CPU tool, v1.6 defaults), SSIM and PSNR
// against scikit-image (Debian python3-skimage) with the settings of the conformance set
// (tests/unit/metrics_test.cpp). Targets: FLIP LDR at least 4x the tool, FLIP
// HDR at least 2x, SSIM at least 10x scikit-image, on AVX2 as on AVX-512, each value within 1e-4 of
// the anchor's.
//
//   bench_metrics [--rounds 5] [--threads 2] [--flip-tool PATH] [--python /usr/bin/python3]
//                 [--vector-path widest|avx512|avx2|baseline] [--only NAME,...]
//
// The header names the CPU's vector units and the build of the metrics' hot loops in use
// (metrics.h: VectorPath): the widest the CPU runs, or --vector-path's (so the AVX2 build can be
// measured on an AVX-512 machine). --only keeps the rows whose names contain one of the given
// words (case-insensitive), e.g. --only ssim,flip.
//
// The pair is a deterministic synthetic 1920x1080 scene and a noisy, shifted copy, written to a
// temporary folder as PNG (LDR, 8-bit sRGB) and EXR (HDR, 32-bit float) and read back, so both
// sides score the very same values; scikit-image gets them as float64 .npy files. Both sides get
// the same threads: this process pins itself to `--threads` CPUs (sched_setaffinity), which the
// anchors inherit, runs TBB with that many workers, and starts the anchors with OMP_NUM_THREADS
// (and the BLAS thread variables) set to it. Each round times ours once and the anchor once, in
// alternation, so a change of load on a shared machine hits both; the ratio printed is the median
// of the per-round ratios. Timed: our metric call on images in memory; the tool's own "Evaluation
// time" (its FLIP computation, without reading the files); scikit-image's call, timed inside the
// Python process (tools' start-up and image reading are not counted on either side).
//
// The FLIP tool's path: --flip-tool, else $PB_FLIP_TOOL, else ../shared/oracles/flip/flip-tool
// beside the source tree. When it is absent the FLIP rows say so and are skipped.
#include <fmt/format.h>
#include <sched.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "bench_support.h"
#include "io/image.h"
#include "metrics/metrics.h"

namespace fs = std::filesystem;

namespace {

using pb::io::Image;

constexpr int kWidth = 1920, kHeight = 1080;

// Radiance of a made-up scene: smooth gradients, a sine pattern, discs of light up to 60x the
// background and fine stripes, so every filter scale and every tone-mapping exposure has work.
Image synthetic_scene() {
  Image img(kWidth, kHeight, 3, true);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const float u = float(x) / kWidth, v = float(y) / kHeight;
      float base = 0.05f + 0.6f * u * v + 0.2f * (0.5f + 0.5f * std::sin(40.f * u + 25.f * v));
      const float dx = u - 0.7f, dy = v - 0.3f;
      if (dx * dx + dy * dy < 0.01f) base += 60.f * (0.01f - dx * dx - dy * dy) / 0.01f;
      if ((x / 7) % 2 == 0 && y > kHeight * 3 / 4) base *= 0.3f;
      img.at(x, y, 0) = base * (0.8f + 0.4f * u);
      img.at(x, y, 1) = base;
      img.at(x, y, 2) = base * (1.2f - 0.4f * v);
    }
  return img;
}

// The test: the reference with seeded noise (a Monte Carlo estimate's look) and a slight shift.
Image noisy_copy(const Image& ref, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(1.f, 0.15f);
  Image out = ref;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const float n = std::max(0.f, noise(rng));
      const int xs = std::min(kWidth - 1, x + 1);
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = ref.at(xs, y, c) * n;
    }
  return out;
}

// An image's first three channels as a float64 H x W x 3 .npy file (format version 1.0).
void write_npy(const fs::path& file, const Image& image) {
  std::string header =
      fmt::format("{{'descr': '<f8', 'fortran_order': False, 'shape': ({}, {}, 3), }}",
                  image.height, image.width);
  // Magic (6) + version (2) + header length (2) + header, padded to a multiple of 64 with '\n'
  // last.
  header.append(63 - (10 + header.size()) % 64, ' ');
  header += '\n';
  std::ofstream out(file, std::ios::binary);
  const uint16_t length = uint16_t(header.size());
  out.write("\x93NUMPY\x01\x00", 8);
  out.write(reinterpret_cast<const char*>(&length), 2);
  out << header;
  std::vector<double> values;
  values.reserve(size_t(image.width) * image.height * 3);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) values.push_back(image.at(x, y, std::min(c, image.channels - 1)));
  out.write(reinterpret_cast<const char*>(values.data()), std::streamsize(values.size() * 8));
}

// The number after "<key>: " in the FLIP tool's output, or NaN.
double tool_value(const std::string& text, const std::string& key) {
  const size_t at = text.find(key + ": ");
  return at == std::string::npos ? NAN : std::atof(text.c_str() + at + key.size() + 2);
}

// One anchor run: the value it computed and the seconds its computation took.
struct Measured {
  double value = NAN, seconds = NAN;
};

struct Row {
  std::string name;
  double target;                     // ratio anchor seconds / ours; 0: none
  std::function<double()> ours;      // our value
  std::function<Measured()> anchor;  // empty: no anchor available
  std::string missing;               // why there is no anchor
};

// Pins this process to the first `threads` CPUs it may use; the anchors it starts inherit that.
// Returns the CPUs as a list ("0,1") for the header.
std::string pin_to_cpus(int threads) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  sched_getaffinity(0, sizeof allowed, &allowed);
  cpu_set_t chosen;
  CPU_ZERO(&chosen);
  std::string list;
  for (int cpu = 0, taken = 0; cpu < CPU_SETSIZE && taken < threads; ++cpu)
    if (CPU_ISSET(cpu, &allowed)) {
      CPU_SET(cpu, &chosen);
      list += (taken++ ? "," : "") + std::to_string(cpu);
    }
  sched_setaffinity(0, sizeof chosen, &chosen);
  return list;
}

volatile double sink = 0;  // keeps results alive

// The comma-separated words of `list`, lower-cased ("" gives none; a name without commas one).
std::vector<std::string> split_lower(const std::string& list) {
  std::vector<std::string> words;
  size_t at = 0;
  while (at < list.size()) {
    const size_t comma = std::min(list.find(',', at), list.size());
    std::string word = list.substr(at, comma - at);
    std::transform(word.begin(), word.end(), word.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (!word.empty()) words.push_back(word);
    at = comma + 1;
  }
  if (words.empty()) words.push_back("");
  return words;
}

// The builds of the hot loops this CPU can run, widest first.
std::string built_paths() {
  std::string list;
  for (auto path : {pb::metrics::VectorPath::avx512, pb::metrics::VectorPath::avx2,
                    pb::metrics::VectorPath::baseline})
    if (pb::metrics::cpu_runs(path))
      list += (list.empty() ? "" : " / ") + std::string(pb::metrics::to_string(path));
  return list;
}

}  // namespace

int main(int argc, char** argv) {
  const fs::path source_dir = pb::bench::source_dir();
  const char* env_tool = std::getenv("PB_FLIP_TOOL");
  auto options = pb::bench::parse_options(
      argc, argv,
      {{"--rounds", "5"},
       {"--threads", "2"},
       {"--flip-tool", env_tool && *env_tool
                           ? std::string(env_tool)
                           : (source_dir / "../shared/oracles/flip/flip-tool").string()},
       {"--python", "/usr/bin/python3"},
       {"--vector-path", "widest"},
       {"--only", ""}},
      "bench_metrics [--rounds N] [--threads N] [--flip-tool PATH] [--python PATH] "
      "[--vector-path widest|avx512|avx2|baseline] [--only NAME,...]");
  if (!options) return 2;
  auto& opt = *options;
  const int rounds = std::max(1, std::atoi(opt["--rounds"].c_str()));
  const int threads = std::max(1, std::atoi(opt["--threads"].c_str()));
  const std::string cpus = pin_to_cpus(threads);
  if (const std::string& path = opt["--vector-path"]; path != "widest") {
    const std::map<std::string, pb::metrics::VectorPath> paths = {
        {"avx512", pb::metrics::VectorPath::avx512},
        {"avx2", pb::metrics::VectorPath::avx2},
        {"baseline", pb::metrics::VectorPath::baseline}};
    if (!paths.count(path)) {
      std::fprintf(stderr, "--vector-path: '%s' is not widest, avx512, avx2 or baseline\n",
                   path.c_str());
      return 2;
    }
    if (!pb::metrics::cpu_runs(paths.at(path))) {
      std::fprintf(stderr, "--vector-path: this CPU cannot run the %s build\n",
                   pb::metrics::to_string(paths.at(path)));
      return 2;
    }
    pb::metrics::use_vector_path(paths.at(path));
  }
  const std::vector<std::string> only = split_lower(opt["--only"]);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));

  // ---- the pair, written for the anchors and read back for ours ----
  const fs::path dir = fs::temp_directory_path() / fmt::format("pb_bench_metrics_{}", ::getpid());
  fs::create_directories(dir);
  {
    const Image hdr_ref = synthetic_scene(), hdr_test = noisy_copy(hdr_ref, 1);
    pb::io::write_image(dir / "ref.exr", hdr_ref);
    pb::io::write_image(dir / "test.exr", hdr_test);
    pb::io::write_image(dir / "ref.png", pb::io::display_encode(hdr_ref));
    pb::io::write_image(dir / "test.png", pb::io::display_encode(hdr_test));
  }
  const Image hdr_ref = pb::io::read_image(dir / "ref.exr");
  const Image hdr_test = pb::io::read_image(dir / "test.exr");
  const Image ldr_ref = pb::io::read_image(dir / "ref.png");
  const Image ldr_test = pb::io::read_image(dir / "test.png");
  write_npy(dir / "ref.npy", ldr_ref);
  write_npy(dir / "test.npy", ldr_test);

  // ---- the anchors ----
  const std::string env =
      fmt::format("OMP_NUM_THREADS={0} OPENBLAS_NUM_THREADS={0} MKL_NUM_THREADS={0}", threads);
  const std::string& tool = opt["--flip-tool"];
  const bool have_tool = fs::is_regular_file(tool) && access(tool.c_str(), X_OK) == 0;
  auto flip_tool = [&](const char* ext, const char* flags) -> std::function<Measured()> {
    if (!have_tool) return nullptr;
    return [&, ext, flags]() -> Measured {
      const std::string out = pb::bench::run_capture(
          fmt::format("{} '{}' -r '{}' -t '{}' {} -d '{}' 2>&1", env, tool,
                      (dir / fmt::format("ref.{}", ext)).string(),
                      (dir / fmt::format("test.{}", ext)).string(), flags, dir.string()));
      return {tool_value(out, "Mean"), tool_value(out, "Evaluation time")};
    };
  };
  const fs::path skimage_script = source_dir / "bench/skimage_anchor.py";
  const bool skimage_ok =
      pb::bench::run_capture(
          fmt::format("'{}' -c 'import skimage' 2>&1 && echo ok", opt["--python"]))
          .find("ok") != std::string::npos;
  auto skimage = [&](const char* metric) -> std::function<Measured()> {
    if (!skimage_ok) return nullptr;
    return [&, metric]() -> Measured {
      const std::string out = pb::bench::run_capture(
          fmt::format("{} '{}' '{}' {} '{}' '{}'", env, opt["--python"], skimage_script.string(),
                      metric, (dir / "ref.npy").string(), (dir / "test.npy").string()));
      Measured m;
      if (std::sscanf(out.c_str(), "%lf %lf", &m.value, &m.seconds) != 2) return {};
      return m;
    };
  };
  const std::string no_tool = fmt::format("no FLIP tool at {} (--flip-tool PATH)", tool);
  const std::string no_skimage = "scikit-image not importable (Debian python3-skimage)";

  using namespace pb::metrics;
  std::vector<Row> rows = {
      {"FLIP (LDR)", 4, [&] { return flip(ldr_ref, ldr_test).stats.mean; },
       flip_tool("png", "-nerm"), no_tool},
      {"FLIP (HDR, ACES)", 2, [&] { return flip(hdr_ref, hdr_test).stats.mean; },
       flip_tool("exr", "-nerm -nexm"), no_tool},
      {"SSIM (LDR)", 10, [&] { return ssim(ldr_ref, ldr_test); }, skimage("ssim"), no_skimage},
      {"PSNR (LDR)", 0, [&] { return psnr(ldr_ref, ldr_test).db.value_or(INFINITY); },
       skimage("psnr"), no_skimage},
      {"SSIM (HDR, display)", 0, [&] { return ssim(hdr_ref, hdr_test); }, nullptr, ""},
      {"RMSE (HDR)", 0, [&] { return rmse(hdr_ref, hdr_test); }, nullptr, ""},
      {"relMSE (HDR)", 0, [&] { return relmse(hdr_ref, hdr_test); }, nullptr, ""},
      {"evaluate (HDR, all)", 0, [&] { return evaluate(hdr_ref, hdr_test).flip.mean; }, nullptr,
       ""},
  };

  std::erase_if(rows, [&](const Row& row) {
    const std::string name = split_lower(row.name).front();
    return !only.empty() && std::none_of(only.begin(), only.end(), [&](const std::string& word) {
      return name.find(word) != std::string::npos;
    });
  });
  std::printf("bench_metrics: %dx%d pair, %d alternating rounds, %d threads a side (CPUs %s)\n",
              kWidth, kHeight, rounds, threads, cpus.c_str());
  std::printf("CPU vector units: %s; metrics built for %s, running %s\n",
              pb::bench::vector_units().c_str(), built_paths().c_str(),
              pb::metrics::to_string(pb::metrics::vector_path()));
  std::printf("%-20s %9s %9s %8s %7s %12s %12s %9s\n", "metric", "ours s", "anchor s", "ratio",
              "target", "ours", "anchor", "|diff|");
  bool all_met = true;
  for (const Row& row : rows) {
    std::vector<double> ours_s, anchor_s, ratios;
    double value = NAN, anchor_value = NAN;
    for (int r = 0; r < rounds; ++r) {
      const auto start = std::chrono::steady_clock::now();
      value = row.ours();
      ours_s.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
      sink = sink + value;
      if (!row.anchor) continue;
      const Measured m = row.anchor();
      if (!std::isfinite(m.seconds)) continue;
      anchor_value = m.value;
      anchor_s.push_back(m.seconds);
      ratios.push_back(m.seconds / ours_s.back());
    }
    if (!row.anchor || ratios.empty()) {
      std::printf("%-20s %9.4f %9s %8s %7s %12.9f %12s %9s%s\n", row.name.c_str(),
                  pb::bench::median(ours_s), "-", "-", "-", value, "-", "-",
                  row.missing.empty() ? ""
                  : row.anchor        ? "  (anchor gave no timing)"
                                      : fmt::format("  ({}: row skipped)", row.missing).c_str());
      if (row.target > 0) all_met = false;
      continue;
    }
    const double ratio = pb::bench::median(ratios), diff = std::abs(value - anchor_value);
    const bool met = (row.target == 0 || ratio >= row.target) && diff <= 1e-4;
    all_met &= met;
    std::printf("%-20s %9.4f %9.4f %7.1fx %7s %12.9f %12.9f %9.1e%s\n", row.name.c_str(),
                pb::bench::median(ours_s), pb::bench::median(anchor_s), ratio,
                row.target > 0 ? fmt::format(">={:.0f}x", row.target).c_str() : "-", value,
                anchor_value, diff, met ? "" : "  (missed)");
  }
  std::printf("targets %s\n", all_met ? "met" : "MISSED (or an anchor absent)");
  fs::remove_all(dir);
  return 0;
}
