#include "screen_caustics.h"

#include <algorithm>

namespace sc {

float radical_inverse(uint32_t base, uint64_t i) {
  double inverse = 1.0 / base, scale = inverse, out = 0;
  for (; i > 0; i /= base, scale *= inverse) out += double(i % base) * scale;
  return float(std::min(out, 0.99999994));
}

void HaltonEmission::configure(std::vector<std::optional<pb::trace::EmissionDensity>> densities,
                               uint32_t photons, uint32_t slices) {
  photons_ = photons;
  slices_ = std::max<uint32_t>(1, slices);
  aims_.assign(densities.size(), std::nullopt);
  for (size_t l = 0; l < densities.size(); ++l) {
    if (!densities[l]) continue;
    const pb::trace::EmissionDensity& d = *densities[l];
    Aim a;
    a.width = d.width;
    a.height = d.height;
    a.texels = d.texels;
    a.column_cdf.assign(size_t(d.height) * (d.width + 1), 0.f);
    a.row_cdf.assign(size_t(d.height) + 1, 0.f);
    double total = 0;
    for (int j = 0; j < d.height; ++j) {
      float* cdf = &a.column_cdf[size_t(j) * (d.width + 1)];
      for (int i = 0; i < d.width; ++i) cdf[i + 1] = cdf[i] + d.texels[size_t(j) * d.width + i];
      total += cdf[d.width];
      a.row_cdf[j + 1] = float(total);
    }
    if (total <= 0) continue;
    a.mean = float(total / (double(d.width) * d.height));
    aims_[l] = std::move(a);
  }
}

uint32_t HaltonEmission::slice_size(uint32_t slice) const {
  return slice < photons_ % slices_ ? photons_ / slices_ + 1 : photons_ / slices_;
}

uint64_t HaltonEmission::prepare(const pb::trace::EmissionFrame& frame) {
  // Knuth's multiplicative hash, its top 20 bits: up to a million points further on.
  start_ = frame.seed_scramble ? uint32_t((*frame.seed_scramble + 1u) * 2654435761u) >> 12 : 0;
  light_cdf_.assign(frame.emitters.size() + 1, 0.f);
  double total = 0;
  for (size_t l = 0; l < frame.emitters.size(); ++l) {
    const glm::vec3 p = frame.emitters[l].power;
    // A light the aimed emission found no specular object from sends no caustic photon.
    const bool aimed = l < aims_.size() && aims_[l].has_value();
    const bool area = frame.emitters[l].kind == pb::trace::EmitterKind::quad ||
                      frame.emitters[l].kind == pb::trace::EmitterKind::disc ||
                      frame.emitters[l].kind == pb::trace::EmitterKind::mesh;
    total += (aimed || area) ? double(p.x + p.y + p.z) : 0.0;
    light_cdf_[l + 1] = float(total);
  }
  if (total <= 0) return 0;
  for (float& c : light_cdf_) c = float(c / total);
  return slice_size(slice_ % slices_);
}

pb::trace::EmissionPoint HaltonEmission::emission(uint64_t k) const {
  const uint64_t i = uint64_t(slice_ % slices_) + k * slices_;
  pb::trace::EmissionPoint e;
  e.id = uint32_t(i);
  const uint64_t h = start_ + i;  // the Halton index
  // The light, by power (radical inverse in base 11).
  const float pick = radical_inverse(11, h);
  const auto at = std::upper_bound(light_cdf_.begin() + 1, light_cdf_.end(), pick);
  e.light =
      uint32_t(std::min<ptrdiff_t>(at - light_cdf_.begin() - 1, ptrdiff_t(light_cdf_.size()) - 2));
  const float light_share = light_cdf_[e.light + 1] - light_cdf_[e.light];
  glm::vec2 uv{radical_inverse(2, h), radical_inverse(3, h)};
  e.direction = {radical_inverse(5, h), radical_inverse(7, h)};
  float pdf = 1;
  if (e.light < aims_.size() && aims_[e.light]) {
    // Warp the Halton point into the aimed texels: a row by v, a texel of it by u, the rest of
    // each coordinate placed inside the texel, so the points stay stratified within the aim.
    const Aim& a = *aims_[e.light];
    const float row_total = a.row_cdf.back();
    const float v = uv.y * row_total;
    int j =
        int(std::upper_bound(a.row_cdf.begin() + 1, a.row_cdf.end(), v) - a.row_cdf.begin()) - 1;
    j = std::clamp(j, 0, a.height - 1);
    while (j > 0 && a.row_cdf[j + 1] - a.row_cdf[j] <= 0) --j;
    const float row_mass = a.row_cdf[j + 1] - a.row_cdf[j];
    const float fv =
        row_mass > 0 ? std::clamp((v - a.row_cdf[j]) / row_mass, 0.f, 0.99999994f) : 0.5f;
    const float* cdf = &a.column_cdf[size_t(j) * (a.width + 1)];
    const float u = uv.x * cdf[a.width];
    int i_col = int(std::upper_bound(cdf + 1, cdf + a.width + 1, u) - cdf) - 1;
    i_col = std::clamp(i_col, 0, a.width - 1);
    while (i_col > 0 && cdf[i_col + 1] - cdf[i_col] <= 0) --i_col;
    const float texel = cdf[i_col + 1] - cdf[i_col];
    const float fu = texel > 0 ? std::clamp((u - cdf[i_col]) / texel, 0.f, 0.99999994f) : 0.5f;
    uv = {(float(i_col) + fu) / float(a.width), (float(j) + fv) / float(a.height)};
    pdf = a.texels[size_t(j) * a.width + i_col] / a.mean;
  }
  e.uv = uv;
  e.photon_density = float(photons_) * light_share * pdf;
  return e;
}

}  // namespace sc
