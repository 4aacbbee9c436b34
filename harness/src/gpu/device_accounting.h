// What only the runner sees of a Device: the memory it attributes to each cell, and the devices a
// machine has (`photonbench list devices`). Kept out of the public headers (photonbench/gpu.h) so a
// technique cannot depend on the harness's bookkeeping.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "photonbench/gpu.h"

namespace pb::gpu {

struct DeviceAccounting {
  // Bytes in live buffers and images made through `device`.
  static uint64_t allocated_bytes(const Device& device) { return device.allocated_bytes_; }
};

// Every Vulkan device of this machine: "name (Vulkan 1.3, Cpu)".
std::vector<std::string> list_devices();

}  // namespace pb::gpu
