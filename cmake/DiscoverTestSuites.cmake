# Run by CMake (-P) after the test program is built, when PB_UNIT_TEST_PROCESS is `suite`
# (tests/CMakeLists.txt): lists the GoogleTest suites that hold tests TEST_FILTER selects and writes
# CTEST_FILE, one CTest test per suite, each running that suite's selected tests in one process.
# Inputs: TEST_EXECUTABLE, TEST_FILTER (a GoogleTest filter of the form -PATTERN:PATTERN...),
# WORKING_DIRECTORY, LABEL, ENVIRONMENT (NAME=VALUE, or empty for none), CTEST_FILE.
execute_process(COMMAND "${TEST_EXECUTABLE}" --gtest_list_tests "--gtest_filter=${TEST_FILTER}"
  WORKING_DIRECTORY "${WORKING_DIRECTORY}" OUTPUT_VARIABLE listing RESULT_VARIABLE status
  TIMEOUT 120)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${TEST_EXECUTABLE} --gtest_list_tests failed (${status}):\n${listing}")
endif()
if(NOT TEST_FILTER MATCHES "^-")
  message(FATAL_ERROR "DiscoverTestSuites: TEST_FILTER must be a negative filter, got '${TEST_FILTER}'")
endif()
set(environment_property "")
if(NOT ENVIRONMENT STREQUAL "")
  set(environment_property "ENVIRONMENT [==[${ENVIRONMENT}]==] ")
endif()
string(REPLACE "\n" ";" lines "${listing}")
set(script "")
foreach(line IN LISTS lines)
  # A suite's line is its name and a dot, then (typed suites) a comment; test lines are indented.
  if(line MATCHES "^([A-Za-z_][A-Za-z0-9_/]*)\\.( |$)")
    set(suite "${CMAKE_MATCH_1}")
    string(APPEND script
      "add_test([==[${suite}]==] [==[${TEST_EXECUTABLE}]==] [==[--gtest_filter=${suite}.*${TEST_FILTER}]==])\n"
      "set_tests_properties([==[${suite}]==] PROPERTIES LABELS ${LABEL} "
      "${environment_property}WORKING_DIRECTORY [==[${WORKING_DIRECTORY}]==])\n")
  endif()
endforeach()
if(script STREQUAL "")
  message(FATAL_ERROR "DiscoverTestSuites: no suite found in the listing of ${TEST_EXECUTABLE}")
endif()
file(WRITE "${CTEST_FILE}" "${script}")
