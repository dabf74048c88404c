// Run-time choice of the element-lane kernels (element_lanes.hpp): the widest instruction set
// the CPU reports (CPUID through xsimd), falling back to SSE2, which every x86-64 has.
#include "kernels/vector/element_lanes.hpp"

#include <xsimd/config/xsimd_cpuid.hpp>

namespace clothbench::kernels::vector {

// Defined in element_lanes_<isa>.cpp, each compiled for its instruction set.
ElementLanesKernels element_lanes_avx512f();
ElementLanesKernels element_lanes_avx2();
ElementLanesKernels element_lanes_sse2();

int supported_element_lanes_kernels(const ElementLanesKernels** out, int capacity) {
  static const ElementLanesKernels kAvx512 = element_lanes_avx512f();
  static const ElementLanesKernels kAvx2 = element_lanes_avx2();
  static const ElementLanesKernels kSse2 = element_lanes_sse2();
  const auto cpu = xsimd::available_architectures();
  int n = 0;
  if (cpu.avx512f && n < capacity) out[n++] = &kAvx512;
  if (cpu.fma3_avx2 && n < capacity) out[n++] = &kAvx2;
  if (n < capacity) out[n++] = &kSse2;
  return n;
}

const ElementLanesKernels& element_lanes_kernels() {
  static const ElementLanesKernels* const best = [] {
    const ElementLanesKernels* first = nullptr;
    supported_element_lanes_kernels(&first, 1);
    return first;
  }();
  return *best;
}

}  // namespace clothbench::kernels::vector
