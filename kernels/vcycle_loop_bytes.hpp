// The LoopBytes of the V-cycle's loops (loop_bytes.hpp), from a level's sizes: its loops run
// over nodes, coarse rows and grid lines whose data varies, so each figure is the level's
// total over the loop's indices (an average per index). Templates over the preconditioner's
// private Level and BlockRows (vcycle_preconditioner.hpp) so both of its sources share them.
#pragma once

#include <cstddef>

#include "kernels/loop_bytes.hpp"

namespace clothbench::kernels::vcycle_bytes {

/// An index array entry of the V-cycle (std::int64_t).
inline constexpr double kOffset = 8.0;

/// Bytes of one stored entry of a vector (an operator's values are floats, the line factors
/// doubles: vcycle_preconditioner.hpp).
template <class Vector>
constexpr double entry_bytes(const Vector&) {
  return static_cast<double>(sizeof(typename Vector::value_type));
}

/// `total` bytes over `count` indices (0 for an empty loop).
inline double per_index(double total, std::size_t count) {
  return count == 0 ? 0.0 : total / static_cast<double>(count);
}

/// Reading an operator once: every row's start and, per block, its column and 9 values.
template <class BlockRows>
double operator_read(const BlockRows& a) {
  return kOffset * static_cast<double>(a.start.size()) +
         (kOffset + 9 * entry_bytes(a.value)) * static_cast<double>(a.col.size());
}

/// Reading a transfer's weights once: row starts and, per entry, its node and weight.
template <class Weights>
double weights_read(const Weights& w) {
  return kOffset * static_cast<double>(w.start.size()) +
         (kOffset + bytes::kDouble) * static_cast<double>(w.node.size());
}

/// Per node, r = b - A x: the operator's rows, x and b read; r written.
template <class Level>
LoopBytes residual(const Level& level) {
  return {.read = per_index(operator_read(level.a), level.i.size()) + 2 * bytes::kVector3,
          .written = bytes::kVector3};
}

/// Per row of a transfer from `sources` 3-vectors to `rows` rows: the weights and every source
/// once, and the row's own value when it accumulates; the row's value written.
template <class Weights>
LoopBytes transfer(const Weights& w, std::size_t sources, std::size_t rows, bool accumulate) {
  const double read = weights_read(w) + bytes::kVector3 * static_cast<double>(sources);
  return {.read = per_index(read, rows) + (accumulate ? bytes::kVector3 : 0.0),
          .written = bytes::kVector3};
}

/// Per `per` lines of direction d (a loop index of the smoothing sweep), a smoothing sweep: the
/// operator's rows of their nodes, their order, b and x, the line factors and per-line ranges
/// read; the lines' scratch and x written.
template <class Level>
LoopBytes line_sweep(const Level& level, int d, int per) {
  const auto& l = level.lines[d];
  const auto nodes = static_cast<double>(l.order.size());
  const double read = operator_read(level.a) + nodes * (kOffset + 2 * bytes::kVector3) +
                      entry_bytes(l.band) * static_cast<double>(l.band.size()) +
                      (3 * kOffset + bytes::kFlag) * static_cast<double>(l.width.size());
  const std::size_t lines = l.width.size();
  return {.read = per * per_index(read, lines),
          .written = per * per_index(2 * bytes::kVector3 * nodes, lines)};
}

/// Per line of direction d, its factorisation: the operator's rows of its nodes with each
/// column's line and position, the node order and the per-line ranges read; the band factor
/// and the line's flag written.
template <class Level>
LoopBytes line_factor(const Level& level, int d) {
  const auto& l = level.lines[d];
  const std::size_t lines = l.width.size();
  const double read =
      operator_read(level.a) + 2 * kOffset * static_cast<double>(level.a.col.size()) +
      2 * kOffset * static_cast<double>(l.order.size()) + 3 * kOffset * static_cast<double>(lines);
  const double written = entry_bytes(l.band) * static_cast<double>(l.band.size()) +
                         bytes::kFlag * static_cast<double>(lines);
  return {.read = per_index(read, lines), .written = per_index(written, lines)};
}

/// Per line of direction d, its couplings (a new structure): the operator's columns of its
/// nodes with each column's line and position, the node order and the line's range read; the
/// line's width and the lines before it it couples to written (about one a node).
template <class Level>
LoopBytes line_couplings(const Level& level, int d) {
  const auto& l = level.lines[d];
  const std::size_t lines = l.width.size();
  const double read = kOffset * static_cast<double>(level.a.start.size()) +
                      3 * kOffset * static_cast<double>(level.a.col.size()) +
                      2 * kOffset * static_cast<double>(l.order.size()) +
                      2 * kOffset * static_cast<double>(lines);
  const double written =
      bytes::kFlag * static_cast<double>(lines) + kOffset * static_cast<double>(l.order.size());
  return {.read = per_index(read, lines), .written = per_index(written, lines)};
}

/// Per coarse row of P^T A P: the fine operator, R and P once each read; the row's blocks
/// written when `values` (a new structure's first pass makes the columns only).
template <class Level>
LoopBytes galerkin(const Level& fine, const Level& coarse, bool values) {
  const std::size_t rows = coarse.i.size();
  const double read = operator_read(fine.a) + weights_read(fine.r) + weights_read(fine.p);
  const double written =
      values ? 9 * entry_bytes(coarse.a.value) * static_cast<double>(coarse.a.col.size()) : 0.0;
  return {.read = per_index(read, rows), .written = per_index(written, rows)};
}

}  // namespace clothbench::kernels::vcycle_bytes
