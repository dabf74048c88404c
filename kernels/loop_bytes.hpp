// The bytes a parallel loop must move per element, declared at every LoopRunner call beside
// the loop it describes and recorded with each loop instance of a trace (issue 17: the
// predictor's memory-bandwidth ceiling, harness/predict/bandwidth_model.hpp).
//
// The rule every figure follows, counted from the loop's code:
//  - every array entry the body reads or writes, at its type's size; a read-modify-write is a
//    read and a write; no write-allocate traffic (STREAM's convention: its triad
//    a[i] = b[i] + s c[i] counts 24 B per iteration, and the predictor divides by it);
//  - each entry once per loop, where it is owned: a value the body gathers from a neighbour
//    (the next node's position, the previous slot's edge force) is fetched from memory once
//    while neighbouring tiles run, so it counts where it is owned. An edge or triple loop (two
//    ids per slot) therefore counts a slot's 3-vector as 24 B / 2 per id (kSlotShare), and a
//    particle loop counts the values of its slot's two edges or triples (kIdsPerSlot);
//  - not counted: what the LoopRunner reads to find the elements (live flags, Active-List
//    entries), the per-tile partial sums, data every element shares (material bands,
//    obstacles), and the work of ghosts hanging on a particle (a few per AMRC border);
//  - a for_index loop counts per index; where an index's data varies (rows of a sparse level,
//    grid lines), the figure is the instance's average: the level's total over its indices.
// So a figure is the least traffic the loop can cause, and bytes / bandwidth a time no
// schedule can beat.
#pragma once

namespace clothbench::kernels {

/// Unavoidable bytes per element (or per index of a for_index loop); rule above.
struct LoopBytes {
  double read = 0.0;
  double written = 0.0;
  [[nodiscard]] constexpr double per_element() const { return read + written; }
};

/// Sizes of what loop bodies touch, for LoopBytes figures.
namespace bytes {
inline constexpr double kDouble = 8.0;
inline constexpr double kFloat = 4.0;
inline constexpr double kIndex = 4.0;     ///< std::int32_t (neighbours, list entries)
inline constexpr double kFlag = 1.0;      ///< std::uint8_t (particle flags, element flags)
inline constexpr double kVector3 = 24.0;  ///< a slot's xyz in an interleaved double array
inline constexpr double kBlockF = 24.0;   ///< a symmetric 3x3 block stored as 6 floats
inline constexpr double kBlockD = 48.0;   ///< a symmetric 3x3 block stored as 6 doubles
/// The share of a slot's value each of its two edges or triples counts.
inline constexpr double kSlotShare = 0.5;
/// Edge or triple ids per slot: what a particle loop counts of per-element arrays.
inline constexpr double kIdsPerSlot = 2.0;
}  // namespace bytes

}  // namespace clothbench::kernels
