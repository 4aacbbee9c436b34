// bench_light_bvh: the cost of many-light selection on the CPU (trace/light_bvh.h), the per-light
// question of Paper III (seed 002):
//   1. how the light BVH's build time grows with the light count (1k, 4k, 16k, 64k lights; SAH
//      against SAOH), as log-log slopes beside the paper's (2.3, 26, 280 ms at 1k, 21k and
//      53k-200k lights: slope 0.80, then 1.05-2.57 depending on where in 53k-200k its 280 ms fall),
//      SAOH about 3x SAH;
//   2. what one selection costs through the tree against the uniform and power samplers (the
//      paper: BVH_DFBO 2-3x Uniform's time on the GPU, whole frame), with the variance each leaves
//      in the irradiance at a floor point, so that the efficiency 1/(time x variance) of Paper IV
//      can be read off;
//   3. SAOH against SAH in quality (the variance of the same estimate) and leaf sizes 1-10 (the
//      paper: within 5% in time).
//
//   bench_light_bvh [--rounds 5] [--samples 200000]
//
// The lights are a ceiling of emissive triangles (four power classes spanning 100x, tilted up to
// 30 degrees). Everything compared runs in alternating rounds on one shading point set; the ratios
// are medians of per-round ratios. Times are wall-clock on a shared machine: the slopes and ratios
// are the figures, the milliseconds this machine's.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "bench_support.h"
#include "trace/light_bvh.h"

using namespace pb;
using namespace pb::trace;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

std::vector<scene::EmissiveTriangle> ceiling(uint32_t count) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  uint32_t side = uint32_t(std::ceil(std::sqrt(double(count))));
  float spacing = 20.f / float(side), size = 0.4f * spacing;
  std::vector<scene::EmissiveTriangle> out;
  for (uint32_t k = 0; k < count; ++k) {
    scene::EmissiveTriangle t;
    glm::vec3 c{-10 + spacing * (float(k % side) + 0.5f), 4,
                -10 + spacing * (float(k / side) + 0.5f)};
    glm::vec3 n = glm::normalize(glm::vec3(0.6f * (u(rng) - 0.5f), -1, 0.6f * (u(rng) - 0.5f)));
    glm::vec3 a = glm::normalize(glm::cross(n, glm::vec3(0, 0, 1)));
    glm::vec3 b = glm::cross(n, a);
    t.p[0] = c, t.p[1] = c + size * a, t.p[2] = c + size * b;
    t.normal = n;
    t.radiance = glm::vec3(std::pow(10.f, float(k % 4) * 2.f / 3.f));
    t.area = 0.5f * size * size;
    t.flux = 3.14159265f * t.area * t.radiance;
    out.push_back(t);
  }
  return out;
}

struct Run {
  double ms = 0, mean = 0, variance = 0, nodes = 0;
};

// Irradiance at floor points through `sampler`: one light, one uniform point on it, per sample.
Run run(const LightSampler& sampler, const std::vector<scene::EmissiveTriangle>& lights,
        uint32_t samples) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  const glm::vec3 n{0, 1, 0};
  double sum = 0, sum2 = 0, nodes = 0;
  auto start = Clock::now();
  for (uint32_t k = 0; k < samples; ++k) {
    glm::vec3 p{-6.f + 12.f * float(k % 64) / 64.f, 0, -6.f + 12.f * float((k / 64) % 64) / 64.f};
    LightPick pick;
    float u0 = u(rng), u1 = u(rng), u2 = u(rng);
    double value = irradiance_sample(sampler, lights, p, n, u0, {u1, u2}, &pick).y;
    nodes += pick.nodes_visited;
    sum += value, sum2 += value * value;
  }
  Run r;
  r.ms = ms_since(start);
  r.mean = sum / samples;
  r.variance = sum2 / samples - r.mean * r.mean;
  r.nodes = nodes / samples;
  return r;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

std::string fmt_slope(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", s);
  return text;
}

// Build times (ms, median over rounds) of one split heuristic at each count, alternating SAH and
// SAOH within a round.
std::map<SplitHeuristic, std::vector<double>> build_times(const std::vector<uint32_t>& counts,
                                                          int rounds) {
  std::map<SplitHeuristic, std::vector<double>> out;
  for (uint32_t count : counts) {
    std::vector<LightPrimitive> primitives;
    for (const auto& t : ceiling(count)) primitives.push_back(primitive(t));
    std::map<SplitHeuristic, std::vector<double>> ms;
    for (int r = 0; r < rounds; ++r)
      for (SplitHeuristic split : {SplitHeuristic::sah, SplitHeuristic::saoh}) {
        LightBvhOptions o;
        o.split = split;
        auto t = Clock::now();
        LightBvh bvh(primitives, o);
        ms[split].push_back(ms_since(t));
      }
    for (auto& [split, v] : ms) out[split].push_back(median(v));
  }
  return out;
}

double slope(double n0, double t0, double n1, double t1) {
  return std::log(t1 / t0) / std::log(n1 / n0);
}

}  // namespace

int main(int argc, char** argv) {
  auto options = bench::parse_options(argc, argv, {{"--rounds", "5"}, {"--samples", "200000"}},
                                      "bench_light_bvh [--rounds 5] [--samples 200000]");
  if (!options) return 2;
  int rounds = std::stoi((*options)["--rounds"]);
  uint32_t samples = uint32_t(std::stoul((*options)["--samples"]));
  std::printf("bench_light_bvh: %d rounds, %u samples per sampler and round\n", rounds, samples);
  std::printf("cpu: %s\nvector units: %s\n\n", bench::cpu_model().c_str(),
              bench::vector_units().c_str());

  // 1. Build time against the light count.
  const std::vector<uint32_t> counts = {1024, 4096, 16384, 65536};
  auto builds = build_times(counts, rounds);
  std::printf("%7s %10s %10s %9s %11s %12s\n", "lights", "sah (ms)", "saoh (ms)", "saoh/sah",
              "sah slope", "saoh slope");
  for (size_t i = 0; i < counts.size(); ++i) {
    const auto &sah = builds[SplitHeuristic::sah], &saoh = builds[SplitHeuristic::saoh];
    std::string s_sah = "-", s_saoh = "-";
    if (i > 0) {
      s_sah = fmt_slope(slope(counts[i - 1], sah[i - 1], counts[i], sah[i]));
      s_saoh = fmt_slope(slope(counts[i - 1], saoh[i - 1], counts[i], saoh[i]));
    }
    std::printf("%7u %10.2f %10.2f %9.2f %11s %12s\n", counts[i], sah[i], saoh[i], saoh[i] / sah[i],
                s_sah.c_str(), s_saoh.c_str());
  }
  const auto& saoh = builds[SplitHeuristic::saoh];
  std::printf(
      "slope 1k-64k: sah %.2f, saoh %.2f; the paper (SAH, one CPU thread): 1k-21k %.2f, "
      "21k-(53k..200k) %.2f..%.2f\n\n",
      slope(counts.front(), builds[SplitHeuristic::sah].front(), counts.back(),
            builds[SplitHeuristic::sah].back()),
      slope(counts.front(), saoh.front(), counts.back(), saoh.back()), slope(1e3, 2.3, 21e3, 26),
      slope(21e3, 26, 200e3, 280), slope(21e3, 26, 53e3, 280));

  // 2. Selection: time, nodes and variance against uniform; 3. SAOH against SAH, leaf sizes.
  std::printf("%7s | %-14s %9s %9s %10s %12s\n", "lights", "sampler", "time/unif", "nodes",
              "var/unif", "eff vs unif");
  for (uint32_t count : {1024u, 16384u}) {
    auto lights = ceiling(count);
    std::vector<LightPrimitive> primitives;
    for (const auto& t : lights) primitives.push_back(primitive(t));
    auto uniform = make_uniform_sampler(count);
    auto power = make_power_sampler(primitives);
    auto options_with = [](LightImportance importance, SplitHeuristic split, uint32_t leaf) {
      LightBvhOptions o;
      o.importance = importance;
      o.split = split;
      o.leaf_size = leaf;
      return o;
    };
    using I = LightImportance;
    using S = SplitHeuristic;
    LightBvh bvh_d(primitives, options_with(I::d, S::saoh, 1));
    LightBvh bvh_dfbo(primitives, options_with(I::dfbo, S::saoh, 1));
    LightBvh bvh_sah(primitives, options_with(I::dfbo, S::sah, 1));
    LightBvh leaf2(primitives, options_with(I::dfbo, S::saoh, 2));
    LightBvh leaf4(primitives, options_with(I::dfbo, S::saoh, 4));
    LightBvh leaf10(primitives, options_with(I::dfbo, S::saoh, 10));
    const char* names[] = {"uniform",      "power",       "bvh d",       "bvh dfbo",
                           "bvh dfbo sah", "dfbo leaf 2", "dfbo leaf 4", "dfbo leaf 10"};
    const LightSampler* samplers[] = {uniform.get(), power.get(), &bvh_d, &bvh_dfbo,
                                      &bvh_sah,      &leaf2,      &leaf4, &leaf10};
    constexpr int kSamplers = 8;
    std::vector<std::vector<double>> time_ratio(kSamplers), var_ratio(kSamplers);
    std::vector<double> nodes(kSamplers);
    for (int r = 0; r < rounds; ++r) {
      Run base = run(*samplers[0], lights, samples);
      for (int s = 1; s < kSamplers; ++s) {
        Run x = run(*samplers[s], lights, samples);
        time_ratio[s].push_back(x.ms / base.ms);
        var_ratio[s].push_back(x.variance / base.variance);
        nodes[s] = x.nodes;
      }
    }
    for (int s = 1; s < kSamplers; ++s)
      std::printf("%7u | %-14s %9.2f %9.1f %10.4f %12.1f\n", count, names[s], median(time_ratio[s]),
                  nodes[s], median(var_ratio[s]),
                  1.0 / (median(time_ratio[s]) * median(var_ratio[s])));
    std::printf(
        "%7u | saoh against sah: variance x%.3f (dfbo, leaf 1); leaf 2, 4, 10 against 1: time "
        "x%.3f, x%.3f, x%.3f (the paper: within 5%%)\n",
        count, median(var_ratio[3]) / median(var_ratio[4]),
        median(time_ratio[5]) / median(time_ratio[3]),
        median(time_ratio[6]) / median(time_ratio[3]),
        median(time_ratio[7]) / median(time_ratio[3]));
  }
  return 0;
}
