// Wall-clock seconds between two points of a run, for the progress lines and the time records
// (reference renders, photon traces, cell processes).
#pragma once

#include <chrono>

namespace pb::io {

inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace pb::io
