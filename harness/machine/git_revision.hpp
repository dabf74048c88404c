// The source revision a clothbench binary was built from (harness/cmake/git_revision.cmake).
#pragma once

namespace clothbench::harness {

/// 12 hex digits of the source tree's HEAD when this binary was built, with "-dirty" appended
/// when tracked files differed from HEAD then; "unknown" when built outside a git checkout.
/// Taken at every build, not at configure time, so results never name a stale revision.
const char* git_revision();

}  // namespace clothbench::harness
