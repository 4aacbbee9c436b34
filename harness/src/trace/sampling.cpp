#include "trace/sampling.h"

#include <array>
#include <numeric>

#include "photonbench/error.h"

namespace pb::trace {
namespace {

// Generator matrices of Sobol dimensions 0..3 as 32 direction numbers each (column j answers bit j
// of the index). Dimension d >= 1 uses the primitive polynomial of degree s with inner coefficients
// `a` and initial odd integers m_1..m_s (Joe & Kuo 2008, table entries d = 2, 3, 4); the rest
// follow the recurrence m_k = 2 a_1 m_{k-1} ^ 4 a_2 m_{k-2} ^ ... ^ 2^s m_{k-s} ^ m_{k-s}.
constexpr std::array<std::array<uint32_t, 32>, 4> make_sobol_matrices() {
  std::array<std::array<uint32_t, 32>, 4> v{};
  for (int k = 0; k < 32; ++k) v[0][k] = 1u << (31 - k);
  struct Poly {
    int s;
    uint32_t a;
    uint32_t m[3];
  };
  const Poly polys[3] = {{1, 0, {1, 0, 0}}, {2, 1, {1, 3, 0}}, {3, 1, {1, 3, 1}}};
  for (int d = 1; d < 4; ++d) {
    const Poly& p = polys[d - 1];
    uint32_t m[33] = {};  // 1-based
    for (int k = 1; k <= p.s; ++k) m[k] = p.m[k - 1];
    for (int k = p.s + 1; k <= 32; ++k) {
      uint32_t value = m[k - p.s] ^ (m[k - p.s] << p.s);
      for (int j = 1; j < p.s; ++j)
        if ((p.a >> (p.s - 1 - j)) & 1u) value ^= m[k - j] << j;
      m[k] = value;
    }
    for (int k = 1; k <= 32; ++k) v[d][k - 1] = m[k] << (32 - k);
  }
  return v;
}

// Byte tables: the matrix-vector product over GF(2) of one index byte, so a point costs four
// lookups (the photon tracer evaluates several per bounce).
struct SobolTables {
  uint32_t t[4][4][256];
};
constexpr SobolTables make_sobol_tables() {
  SobolTables tables{};
  auto v = make_sobol_matrices();
  for (int d = 0; d < 4; ++d)
    for (int byte = 0; byte < 4; ++byte)
      for (uint32_t x = 0; x < 256; ++x) {
        uint32_t r = 0;
        for (int bit = 0; bit < 8; ++bit)
          if ((x >> bit) & 1u) r ^= v[d][byte * 8 + bit];
        tables.t[d][byte][x] = r;
      }
  return tables;
}
constexpr SobolTables kSobolTables = make_sobol_tables();

constexpr uint32_t reverse_bits_constexpr(uint32_t x) {
  uint32_t r = 0;
  for (int bit = 0; bit < 32; ++bit) r |= ((x >> bit) & 1u) << (31 - bit);
  return r;
}

// reverse_bits o sobol_u32(., 1) o reverse_bits is linear over GF(2) too: bit j of its input is
// bit 31 - j of Sobol's index, whose column is v[1][31 - j], read reversed.
constexpr SobolReversedTables make_sobol1_reversed_tables() {
  SobolReversedTables tables{};
  auto v = make_sobol_matrices();
  for (int byte = 0; byte < 4; ++byte)
    for (uint32_t x = 0; x < 256; ++x) {
      uint32_t r = 0;
      for (int bit = 0; bit < 8; ++bit)
        if ((x >> bit) & 1u) r ^= reverse_bits_constexpr(v[1][31 - (byte * 8 + bit)]);
      tables.t[byte][x] = r;
    }
  return tables;
}

}  // namespace

constexpr SobolReversedTables kSobol1ReversedTables = make_sobol1_reversed_tables();

uint32_t sobol_u32(uint32_t index, int dimension) {
  const auto& t = kSobolTables.t[dimension];
  return t[0][index & 0xffu] ^ t[1][(index >> 8) & 0xffu] ^ t[2][(index >> 16) & 0xffu] ^
         t[3][index >> 24];
}

Distribution2D::Distribution2D(int width, int height, const std::vector<float>& values)
    : width_(width), height_(height) {
  if (width <= 0 || height <= 0 || values.size() != size_t(width) * height)
    throw Error("emission density: texel count does not match width x height");
  double total = 0;
  for (float x : values) {
    if (!(x >= 0) || !std::isfinite(x))
      throw Error("emission density: texels must be finite and >= 0");
    total += x;
  }
  if (total <= 0) throw Error("emission density: all texels are zero");
  float scale = float(double(width) * height / total);
  values_.resize(values.size());
  for (size_t i = 0; i < values.size(); ++i) values_[i] = values[i] * scale;
  col_cdf_.assign(size_t(height) * (width + 1), 0.f);
  row_cdf_.assign(height + 1, 0.f);
  std::vector<double> row_sum(height, 0.0);
  for (int j = 0; j < height; ++j) {
    double acc = 0;
    float* cdf = &col_cdf_[size_t(j) * (width + 1)];
    for (int i = 0; i < width; ++i) {
      acc += values_[size_t(j) * width + i];
      cdf[i + 1] = float(acc);
    }
    row_sum[j] = acc;
    for (int i = 1; i <= width; ++i) cdf[i] = acc > 0 ? float(cdf[i] / acc) : float(i) / width;
    cdf[width] = 1.f;
  }
  double acc = 0;
  for (int j = 0; j < height; ++j) {
    acc += row_sum[j];
    row_cdf_[j + 1] = float(acc);
  }
  for (int j = 1; j <= height; ++j) row_cdf_[j] = float(row_cdf_[j] / acc);
  row_cdf_[height] = 1.f;
}

namespace {
// Index i with cdf[i] <= u < cdf[i+1], skipping empty intervals; cdf has n + 1 entries.
int find_interval(const float* cdf, int n, float u) {
  int i = int(std::upper_bound(cdf, cdf + n + 1, u) - cdf) - 1;
  i = std::clamp(i, 0, n - 1);
  while (i < n - 1 && cdf[i + 1] <= cdf[i]) ++i;  // zero-width interval: move to a non-empty one
  return i;
}
}  // namespace

glm::vec2 Distribution2D::sample(glm::vec2 u, float* pdf) const {
  int j = find_interval(row_cdf_.data(), height_, u.y);
  float r0 = row_cdf_[j], r1 = row_cdf_[j + 1];
  float dv = r1 > r0 ? (u.y - r0) / (r1 - r0) : 0.5f;
  const float* cdf = &col_cdf_[size_t(j) * (width_ + 1)];
  int i = find_interval(cdf, width_, u.x);
  float c0 = cdf[i], c1 = cdf[i + 1];
  float du = c1 > c0 ? (u.x - c0) / (c1 - c0) : 0.5f;
  if (pdf) *pdf = values_[size_t(j) * width_ + i];
  glm::vec2 uv{(i + std::clamp(du, 0.f, 1.f)) / width_, (j + std::clamp(dv, 0.f, 1.f)) / height_};
  return glm::min(uv, glm::vec2(kOneMinusEpsilon));
}

float Distribution2D::pdf(glm::vec2 uv) const {
  int i = std::clamp(int(uv.x * width_), 0, width_ - 1);
  int j = std::clamp(int(uv.y * height_), 0, height_ - 1);
  return values_[size_t(j) * width_ + i];
}

}  // namespace pb::trace
