// The element-lane kernels (element_lanes_impl.hpp) for sse2; this file alone is compiled
// with the instruction set's flags (kernels/CMakeLists.txt).
#include "kernels/vector/element_lanes_impl.hpp"

namespace clothbench::kernels::vector {

ElementLanesKernels element_lanes_sse2() { return lanes_kernels<xsimd::sse2>("sse2"); }

}  // namespace clothbench::kernels::vector
