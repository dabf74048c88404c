// LeakSanitizer's built-in suppressions for an AddressSanitizer build (CLOTHBENCH_SANITIZE with
// `address`; CMakeLists.txt compiles this file into every executable of such a build only).
// LLVM's OpenMP runtime (libomp, Clang's) keeps the descriptors of its worker threads until
// after LeakSanitizer's check at exit, which then reports them as leaks from inside
// libomp.so; GCC's libgomp does not. Only allocations whose stack is in libomp are suppressed:
// a leak in clothbench's own code is still reported and still ends the process with an error.
extern "C" const char* __lsan_default_suppressions();
extern "C" const char* __lsan_default_suppressions() { return "leak:libomp.so\n"; }
