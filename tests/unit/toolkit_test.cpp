// The photon-technique toolkit's GPU building blocks on the device (lavapipe): fixed-point flux
// sums keep every channel within their documented error bound (a weak channel included, at Paper
// I's photon counts), the prefix sum equals a CPU scan, and the counting sort groups items by key.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <random>
#include <vector>

#include "photonbench/error.h"
#include "photonbench/gpu.h"
#include "photonbench/toolkit/fixed_point.h"
#include "photonbench/toolkit/gpu_scan.h"
#include "photonbench/toolkit/technique.h"
#include "toolkit_test_shaders.h"
#include "validation.h"

namespace toolkit_test {

using namespace pb;
using toolkit::FluxScale;

gpu::Device& device() {
  static gpu::Device d({"", pb::testing::validation_on()});
  return d;
}

struct FluxPush {
  glm::vec4 units_per_watt;
  uint32_t count, pad[3];
};

// Sums `values` (watts per channel) on the GPU with the toolkit's fixed point; returns the sums
// read back as watts.
glm::dvec3 gpu_flux_sum(const std::vector<glm::vec4>& values, const FluxScale& scale) {
  auto& gpu = device();
  auto in = toolkit::storage_buffer(gpu, "test/values", values.size() * 16);
  gpu.upload(in, values.data(), values.size() * 16);
  auto sums = toolkit::storage_buffer(gpu, "test/sums", 6 * 4, gpu::Memory::host_visible);
  std::memset(sums.mapped(), 0, 24);
  auto pipeline = gpu.create_compute_pipeline(
      "test/flux-sum", ktoolkit_test_flux_sum_comp_spv,
      {gpu::Binding::storage_buffer, gpu::Binding::storage_buffer}, sizeof(FluxPush));
  FluxPush push{glm::vec4(scale.units_per_watt, 0), uint32_t(values.size()), {}};
  gpu.submit_and_wait([&](vk::CommandBuffer cmd) {
    pipeline.bind(cmd, {&in, &sums}, push);
    cmd.dispatch(gpu::groups_for(values.size(), 64), 1, 1);
    vk::MemoryBarrier to_host{vk::AccessFlagBits::eMemoryWrite, vk::AccessFlagBits::eHostRead};
    cmd.pipelineBarrier(vk::PipelineStageFlagBits::eAllCommands, vk::PipelineStageFlagBits::eHost,
                        {}, to_host, {}, {});
  });
  auto w = sums.view<uint32_t>();
  glm::dvec3 watts;
  for (int c = 0; c < 3; ++c)
    watts[c] = (double(w[3 + c]) * 4294967296.0 + double(w[c])) * double(scale.watts_per_unit[c]);
  return watts;
}

// Paper I's 50M-photon settings, where the old scale (the frame's total flux of the strongest
// channel = 2^31 units) gave a photon 2^31 / 6e7 = 36 units of red and round(0.036) = 0 of a green
// at 1e-3 of it: Russian roulette leaves most photons with the same flux, so the whole channel was
// lost, not just noisy. 2^20 equal photons of one 6e7-photon frame: every channel's sum must be
// within the documented bound, the weak one included.
TEST(FixedPoint, WeakChannelKeepsItsShareAtPaperScale) {
  const double frame_photons = 6e7;
  const glm::vec3 photon = glm::vec3(1.0f, 1e-3f, 0.37f) * float(1.0 / frame_photons);
  std::vector<glm::vec4> values(1 << 20, glm::vec4(photon, 0.0f));
  const FluxScale scale = FluxScale::for_largest(photon);
  const glm::dvec3 sum = gpu_flux_sum(values, scale);
  for (int c = 0; c < 3; ++c) {
    double exact = double(values.size()) * double(photon[c]);
    double bound = scale.error_bound(values.size(), exact, photon[c]);
    EXPECT_LE(std::abs(sum[c] - exact), bound)
        << "channel " << c << ": " << sum[c] << " vs " << exact;
    EXPECT_LT(std::abs(sum[c] / exact - 1.0), 2.5e-7) << "channel " << c;
  }
}

// Photons of unequal flux (a log-normal spread over two decades, channels in random proportions):
// the bound holds for each channel's sum, also for a subset far below the largest photon.
TEST(FixedPoint, UnequalPhotonsStayWithinTheBound) {
  std::mt19937 rng(7);
  std::lognormal_distribution<float> spread(0.0f, 1.0f);
  std::uniform_real_distribution<float> tint(1e-4f, 1.0f);
  std::vector<glm::vec4> values(200000);
  for (auto& v : values)
    v = glm::vec4(spread(rng) * tint(rng), spread(rng) * tint(rng) * 1e-3f, spread(rng), 0) * 1e-6f;
  glm::vec3 largest(0.0f);
  for (const auto& v : values) largest = glm::max(largest, glm::vec3(v));
  const FluxScale scale = FluxScale::for_largest(largest);
  for (size_t n : {size_t(1000), values.size()}) {
    std::vector<glm::vec4> part(values.begin(), values.begin() + n);
    const glm::dvec3 sum = gpu_flux_sum(part, scale);
    for (int c = 0; c < 3; ++c) {
      double exact = 0;
      for (const auto& v : part) exact += v[c];
      EXPECT_LE(std::abs(sum[c] - exact), scale.error_bound(n, exact, largest[c]))
          << n << " values, channel " << c << ": " << sum[c] << " vs " << exact;
    }
  }
}

TEST(FixedPoint, ScaleIsPerChannelAndGuardsZero) {
  FluxScale s = FluxScale::for_largest({2.0f, 0.0f, 1e-9f});
  EXPECT_FLOAT_EQ(s.units_per_watt.x, float(1 << PB_FLUX_UNIT_BITS) / 2.0f);
  EXPECT_EQ(s.units_per_watt.y, 1.0f);  // a channel no photon carries
  EXPECT_EQ(s.units(1e-9f, 2), 1u << PB_FLUX_UNIT_BITS);
  EXPECT_EQ(s.units(-1.0f, 0), 0u);
}

std::vector<uint32_t> download_words(const gpu::Buffer& b, size_t n) {
  std::vector<uint32_t> words(n);
  device().download(b, words.data(), n * 4);
  return words;
}

// The prefix sum against a CPU scan, at sizes around its block boundaries and past one scan_top
// chunk (256 blocks of 4096 words).
TEST(PrefixSum, EqualsACpuScan) {
  auto& gpu = device();
  toolkit::PrefixSum scan;
  scan.setup(gpu);
  std::mt19937 rng(3);
  std::uniform_int_distribution<uint32_t> value(0, 50);
  for (uint32_t n : {1u, 255u, 4095u, 4096u, 4097u, 100000u, 1300000u}) {
    SCOPED_TRACE(n);
    std::vector<uint32_t> in(n);
    for (auto& v : in) v = value(rng);
    auto a = toolkit::storage_buffer(gpu, "test/in", n * 4ull);
    auto b = toolkit::storage_buffer(gpu, "test/out", n * 4ull);
    auto total = toolkit::storage_buffer(gpu, "test/total", 16, gpu::Memory::host_visible);
    gpu.upload(a, in.data(), n * 4ull);
    scan.reserve(n);
    gpu.submit_and_wait([&](vk::CommandBuffer cmd) {
      scan.record(cmd, a, b, n, &total, 2);
      gpu::full_barrier(cmd);
    });
    std::vector<uint32_t> expected(n);
    std::exclusive_scan(in.begin(), in.end(), expected.begin(), 0u);
    EXPECT_EQ(download_words(b, n), expected);
    EXPECT_EQ(total.view<uint32_t>()[2], std::accumulate(in.begin(), in.end(), 0u));
  }
}

TEST(PrefixSum, RefusesMoreThanItReserved) {
  auto& gpu = device();
  toolkit::PrefixSum scan;
  scan.setup(gpu);
  scan.reserve(4096);
  auto a = toolkit::storage_buffer(gpu, "test/in", 70000 * 4);
  EXPECT_THROW(gpu.submit_and_wait([&](vk::CommandBuffer cmd) { scan.record(cmd, a, a, 70000); }),
               pb::Error);
}

// The counting sort: the output is a permutation of the items, grouped by key in ascending key
// order (the prefix sum's offsets), whatever the order among one key's items.
TEST(CountingSort, GroupsItemsByKey) {
  auto& gpu = device();
  toolkit::PrefixSum scan;
  scan.setup(gpu);
  toolkit::CountingSort sort;
  sort.setup(gpu);
  const uint32_t n = 70000, bins = 5000;
  sort.resize(gpu, scan, bins, "test");
  std::mt19937 rng(5);
  std::uniform_int_distribution<uint32_t> key(0, bins - 1);
  std::vector<glm::uvec2> items(n);
  for (uint32_t i = 0; i < n; ++i) items[i] = {i, key(rng) | (i % 3 == 0 ? 0x80000000u : 0u)};
  auto in = toolkit::storage_buffer(gpu, "test/items", n * 8ull);
  auto out = toolkit::storage_buffer(gpu, "test/sorted", n * 8ull);
  gpu.upload(in, items.data(), n * 8ull);
  using U = vk::BufferUsageFlagBits;
  auto count = gpu.create_buffer("test/count", 32, U::eStorageBuffer | U::eIndirectBuffer,
                                 gpu::Memory::host_visible);
  uint32_t words[8] = {n, 0, 0, 0, gpu::groups_for(n, 64), 1, 1, 0};
  std::memcpy(count.mapped(), words, sizeof words);
  gpu.submit_and_wait([&](vk::CommandBuffer cmd) {
    sort.record(cmd, scan, in, out, count, 0, 16);
    gpu::full_barrier(cmd);
  });
  std::vector<glm::uvec2> sorted(n);
  gpu.download(out, sorted.data(), n * 8ull);
  for (uint32_t i = 1; i < n; ++i)
    ASSERT_LE(sorted[i - 1].y & 0x7fffffffu, sorted[i].y & 0x7fffffffu) << "at " << i;
  auto by_index = [](glm::uvec2 a, glm::uvec2 b) { return a.x < b.x; };
  std::sort(sorted.begin(), sorted.end(), by_index);
  for (uint32_t i = 0; i < n; ++i)
    ASSERT_EQ(sorted[i], items[i]) << "item " << i << " lost or changed";
}

}  // namespace toolkit_test
