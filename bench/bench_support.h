// What the bench programs share: their source tree, "--name value" options, running an anchor
// program for its output, and the median of per-round figures.
#pragma once

#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pb::bench {

// The repository root: bench/ is one level below it (bench/CMakeLists.txt defines no
// PB_SOURCE_DIR).
inline std::filesystem::path source_dir() {
  return std::filesystem::path(__FILE__).parent_path().parent_path();
}

// "--name value" pairs over `defaults`; an unknown name prints `usage` and gives nothing.
inline std::optional<std::map<std::string, std::string>> parse_options(
    int argc, char** argv, std::map<std::string, std::string> defaults, const char* usage) {
  for (int i = 1; i < argc; i += 2) {
    if (!defaults.count(argv[i]) || i + 1 >= argc) {
      std::fprintf(stderr, "usage: %s\n", usage);
      return std::nullopt;
    }
    defaults[argv[i]] = argv[i + 1];
  }
  return defaults;
}

// Runs a shell command and returns what it printed on stdout.
inline std::string run_capture(const std::string& command) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return out;
  std::array<char, 4096> buffer;
  while (fgets(buffer.data(), int(buffer.size()), pipe)) out += buffer.data();
  pclose(pipe);
  return out;
}

// The vector extensions the CPU reports (CPUID, as GCC's __builtin_cpu_supports reads it), for the
// benches' headers: a ratio against an anchor vectorised another way (Embree's kernels, numpy's
// loops) holds for this kind of CPU only.
inline std::string vector_units() {
  std::string units;
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();
  const std::pair<bool, const char*> known[] = {{__builtin_cpu_supports("sse4.2"), "SSE4.2"},
                                                {__builtin_cpu_supports("avx"), "AVX"},
                                                {__builtin_cpu_supports("avx2"), "AVX2"},
                                                {__builtin_cpu_supports("fma"), "FMA"},
                                                {__builtin_cpu_supports("avx512f"), "AVX-512F"},
                                                {__builtin_cpu_supports("avx512bw"), "AVX-512BW"},
                                                {__builtin_cpu_supports("avx512vl"), "AVX-512VL"}};
  for (const auto& [has, name] : known)
    if (has) units += (units.empty() ? "" : " ") + std::string(name);
#endif
  return units.empty() ? "none known" : units;
}

// The CPU's model name (/proc/cpuinfo), for the benches' headers beside vector_units().
inline std::string cpu_model() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);)
    if (line.rfind("model name", 0) == 0 && line.find(':') != std::string::npos)
      return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

// CPU time of this process (user + system, all threads): what the work costs, whatever else runs
// on the machine.
inline double process_cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// The median (the mean of the middle two for an even count); NaN for none.
inline double median(std::vector<double> values) {
  if (values.empty()) return NAN;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace pb::bench
