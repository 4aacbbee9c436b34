# Sourced by scripts/test.sh --sanitize: how the sanitized build reports. Every report stops the
# process with a non-zero exit and a stack trace, so the test that caused it fails.
#
# Leak checking is on. Every process that opens Vulkan used to report the same leak at exit (128
# bytes from realloc under a pthread_once in the lavapipe driver; in a cell also two 56-byte
# callocs), each stack "<unknown module>": the Vulkan loader unloads the driver in
# vkDestroyInstance, and with it the driver's static data that still pointed to those blocks, so
# LeakSanitizer found them unreferenced. With the driver kept mapped (LD_PRELOAD of it, or linked
# into the executable as scripts/test.sh --sanitize does) the same program reports nothing: the
# blocks are reachable, not leaked. Debian's loader (1.3.239) predates
# VK_LOADER_DISABLE_DYNAMIC_LIBRARY_UNLOADING, which would do the same.
#
# handle_segv=0: a segmentation fault kills the process with SIGSEGV, as it does unsanitized, rather
# than ASan's report and exit 1; the runner must report a crashing cell as "crashed with signal 11"
# (tests/plugins/crash_on_frame.cpp, e2e.cell_isolation), and a crash still fails any test.
#
# intercept_tls_get_addr=0: the sanitizer runtime (GCC's up to 13, LLVM's up to 16: clang-14's,
# which builds the sanitized tree, and GCC 12's, which built it before) takes a dynamic TLS
# block for one with a glibc 2.19 header when its address modulo 4096 happens to equal that
# header's size, and reads the two words before it as an address and a length; LeakSanitizer's
# tracer then dies at exit with "Tracer caught signal 11". Dynamic TLS is what libraries loaded by
# dlopen use, and the image codec module (OpenImageIO's 260 libraries) is one: every cell that had
# read or written an image crashed so at exit. Without the interceptor LeakSanitizer does not scan
# dynamic TLS blocks, so a block only they point to would be reported as a leak (a false report
# fails a test; none does).
sanitizers_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
export ASAN_OPTIONS="halt_on_error=1:handle_segv=0:detect_leaks=1:intercept_tls_get_addr=0:strict_string_checks=1:check_initialization_order=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$sanitizers_dir/ubsan.supp"
