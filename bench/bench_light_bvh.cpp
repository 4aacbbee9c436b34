// bench_light_bvh: the cost of many-light selection on the CPU (trace/light_bvh.h), the per-light
// question of Paper III (seed 002): how the light BVH's build time grows with the light count
// (SAH against SAOH; the paper: 2.3, 26, 280 ms at 1k, 21k, 53k-200k lights, SAOH about 3x SAH),
// and what one selection costs through the tree against the uniform and power samplers (the
// paper: BVH_DFBO 2-3x Uniform's time on the GPU, whole frame), with the variance each leaves in
// the irradiance at a floor point, so that the efficiency 1/(time x variance) of Paper IV can be
// read off.
//
//   bench_light_bvh [--rounds 5] [--samples 200000]
//
// The lights are a ceiling of emissive triangles (four power classes spanning 100x, tilted up to
// 30 degrees) at 64, 1024 and 16384 lights. The samplers run in alternating rounds on one shading
// point set; the ratios are medians of per-round ratios. Times are wall-clock on a shared machine.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
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

}  // namespace

int main(int argc, char** argv) {
  auto options = bench::parse_options(argc, argv, {{"--rounds", "5"}, {"--samples", "200000"}},
                                      "bench_light_bvh [--rounds 5] [--samples 200000]");
  if (!options) return 2;
  int rounds = std::stoi((*options)["--rounds"]);
  uint32_t samples = uint32_t(std::stoul((*options)["--samples"]));
  std::printf("%7s %10s %10s %9s | %-12s %9s %9s %10s %12s\n", "lights", "sah (ms)", "saoh (ms)",
              "saoh/sah", "sampler", "time/unif", "nodes", "var/unif", "eff vs unif");
  for (uint32_t count : {64u, 1024u, 16384u}) {
    auto lights = ceiling(count);
    std::vector<LightPrimitive> primitives;
    for (const auto& t : lights) primitives.push_back(primitive(t));
    std::vector<double> sah_ms, saoh_ms;
    for (int r = 0; r < rounds; ++r)
      for (SplitHeuristic split : {SplitHeuristic::sah, SplitHeuristic::saoh}) {
        LightBvhOptions o;
        o.split = split;
        auto t = Clock::now();
        LightBvh bvh(primitives, o);
        (split == SplitHeuristic::sah ? sah_ms : saoh_ms).push_back(ms_since(t));
      }
    auto uniform = make_uniform_sampler(count);
    auto power = make_power_sampler(primitives);
    LightBvhOptions d, dfbo;
    d.importance = LightImportance::d;
    LightBvh bvh_d(primitives, d), bvh_dfbo(primitives, dfbo);
    const char* names[] = {"uniform", "power", "bvh d", "bvh dfbo"};
    const LightSampler* samplers[] = {uniform.get(), power.get(), &bvh_d, &bvh_dfbo};
    std::vector<std::vector<double>> time_ratio(4), var_ratio(4);
    std::vector<double> nodes(4);
    for (int r = 0; r < rounds; ++r) {
      Run base = run(*samplers[0], lights, samples);
      for (int s = 1; s < 4; ++s) {
        Run x = run(*samplers[s], lights, samples);
        time_ratio[s].push_back(x.ms / base.ms);
        var_ratio[s].push_back(x.variance / base.variance);
        nodes[s] = x.nodes;
      }
    }
    for (int s = 1; s < 4; ++s)
      std::printf("%7u %10.2f %10.2f %9.2f | %-12s %9.2f %9.1f %10.4f %12.1f\n", count,
                  median(sah_ms), median(saoh_ms), median(saoh_ms) / median(sah_ms), names[s],
                  median(time_ratio[s]), nodes[s], median(var_ratio[s]),
                  1.0 / (median(time_ratio[s]) * median(var_ratio[s])));
  }
  return 0;
}
