// The element-lane kernels (element_lanes_impl.hpp) for avx2+fma; this file alone is compiled
// with the instruction set's flags (kernels/CMakeLists.txt).
#include "kernels/vector/element_lanes_impl.hpp"

namespace clothbench::kernels::vector {

ElementLanesKernels element_lanes_avx2() { return lanes_kernels<xsimd::fma3<xsimd::avx2>>("avx2+fma"); }

}  // namespace clothbench::kernels::vector
