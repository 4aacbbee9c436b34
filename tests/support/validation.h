// Whether a test runs with Vulkan's validation layers, for the devices it creates and the runs it
// starts.
#pragma once

#include <cstdlib>

namespace pb::testing {

// CTest sets PB_VALIDATION for every test of a build configured with PB_TEST_VALIDATION
// (tests/CMakeLists.txt; on, except in the sanitized pass). The tests' own devices and the runs
// they start follow it, and so do their checks of a cell record's "validation".
inline bool validation_on() { return std::getenv("PB_VALIDATION") != nullptr; }

}  // namespace pb::testing
