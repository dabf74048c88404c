// The element-lane kernels (element_lanes_impl.hpp) for avx512f; this file alone is compiled
// with the instruction set's flags (kernels/CMakeLists.txt).
#include "kernels/vector/element_lanes_impl.hpp"

namespace clothbench::kernels::vector {

ElementLanesKernels element_lanes_avx512f() { return lanes_kernels<xsimd::avx512f>("avx512f"); }

}  // namespace clothbench::kernels::vector
