# Sourced by scripts/test.sh --sanitize: how the sanitized build reports. Every report stops the
# process with a non-zero exit and a stack trace, so the test that caused it fails.
#
# detect_leaks=0: every process that opens Vulkan reports the same leak at exit (128 bytes from
# realloc, in a cell also two 56-byte callocs), and each stack has no frame of ours: the
# interceptor, then "<unknown module>", a library unloaded before the report (the Vulkan loader
# closes the lavapipe driver in vkDestroyInstance), or a bare libc frame where the fast unwinder
# stopped in uninstrumented code. LeakSanitizer suppressions match frames by module or function,
# and an unloaded module has neither, so leak checking is off for the suite; address errors and
# undefined behaviour still stop the process.
#
# handle_segv=0: a segmentation fault kills the process with SIGSEGV, as it does unsanitized, rather
# than ASan's report and exit 1; the runner must report a crashing cell as "crashed with signal 11"
# (tests/plugins/crash_on_frame.cpp, e2e.cell_isolation), and a crash still fails any test.
sanitizers_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
export ASAN_OPTIONS="halt_on_error=1:handle_segv=0:detect_leaks=0:strict_string_checks=1:check_initialization_order=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$sanitizers_dir/ubsan.supp"
