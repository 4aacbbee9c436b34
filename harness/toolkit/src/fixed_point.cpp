// FluxScale (photonbench/toolkit/fixed_point.h).
#include "photonbench/toolkit/fixed_point.h"

#include <algorithm>
#include <cmath>

namespace pb::toolkit {

FluxScale FluxScale::for_largest(glm::vec3 largest) {
  FluxScale s;
  const float units = float(1u << PB_FLUX_UNIT_BITS);
  for (int c = 0; c < 3; ++c) {
    if (largest[c] > 0 && std::isfinite(largest[c])) {
      s.units_per_watt[c] = units / largest[c];
      s.watts_per_unit[c] = largest[c] / units;
    }
  }
  return s;
}

FluxScale FluxScale::for_photons(std::span<const trace::PhotonRecord> photons) {
  glm::vec3 largest(0.0f);
  for (const auto& p : photons) largest = glm::max(largest, p.power);
  return for_largest(largest);
}

uint32_t FluxScale::units(float watts, int channel) const {
  return uint32_t(std::nearbyint(std::max(watts, 0.0f) * units_per_watt[channel]));
}

double FluxScale::error_bound(uint64_t n, double sum, double largest) const {
  return double(n) * 0.5 * largest / double(1u << PB_FLUX_UNIT_BITS) + std::ldexp(sum, -22);
}

}  // namespace pb::toolkit
