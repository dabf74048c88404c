// Multigrid V-cycle preconditioner of Newton's inner PCG (see vcycle_preconditioner.hpp).
#include "kernels/vcycle_preconditioner.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <type_traits>
#include <utility>

#include "kernels/vcycle_loop_bytes.hpp"

namespace clothbench::kernels {

namespace {

/// out[0..2] = b - (A x) for node a's row of 3x3 blocks.
CLOTHBENCH_SCALAR_LOOPS inline void block_residual(const std::int64_t* start,
                                                   const std::int64_t* col, const float* value,
                                                   std::int64_t a, const double* x, const double* b,
                                                   double* out) {
  double r0 = b[3 * a], r1 = b[3 * a + 1], r2 = b[3 * a + 2];
  for (std::int64_t blk = start[a]; blk < start[a + 1]; ++blk) {
    const float* m = value + 9 * blk;
    const double* xb = x + 3 * col[blk];
    r0 -= m[0] * xb[0] + m[1] * xb[1] + m[2] * xb[2];
    r1 -= m[3] * xb[0] + m[4] * xb[1] + m[5] * xb[2];
    r2 -= m[6] * xb[0] + m[7] * xb[1] + m[8] * xb[2];
  }
  out[0] = r0;
  out[1] = r1;
  out[2] = r2;
}

}  // namespace

CLOTHBENCH_SCALAR_LOOPS void VcyclePreconditioner::line_residual(Level& level, int d,
                                                                 std::int64_t line) {
  const Lines& l = level.lines[d];
  const std::int64_t first = l.start[line];
  const std::int64_t last = l.start[line + 1];
  double* rhs = level.scratch.data() + 3 * first;
  const BlockRows& a = level.a;
  for (std::int64_t e = first; e < last; ++e) {
    if (e + kPrefetchAhead < last) prefetch_row(a, l.order[e + kPrefetchAhead]);
    block_residual(a.start.data(), a.col.data(), a.value.data(), l.order[e], level.x.data(),
                   level.b.data(), rhs + 3 * (e - first));
  }
}

CLOTHBENCH_SCALAR_LOOPS void VcyclePreconditioner::line_correct(Level& level, int d,
                                                                std::int64_t line) {
  const Lines& l = level.lines[d];
  const std::int64_t first = l.start[line];
  const double* rhs = level.scratch.data() + 3 * first;
  for (std::int64_t e = first; e < l.start[line + 1]; ++e) {
    const std::int64_t node = l.order[e];
    for (int c = 0; c < 3; ++c) level.x[3 * node + c] += rhs[3 * (e - first) + c];
  }
}

void VcyclePreconditioner::update_lines(Level& level, int d, std::int64_t line_a,
                                        std::int64_t line_b) {
  const Lines& l = level.lines[d];
  const bool a = l.ok[line_a] != 0;
  const bool b = line_b >= 0 && l.ok[line_b] != 0;
  auto rows = [&](std::int64_t line) { return 3 * (l.start[line + 1] - l.start[line]); };
  auto band = [&](std::int64_t line) { return l.band.data() + l.band_start[line]; };
  auto rhs = [&](std::int64_t line) { return level.scratch.data() + 3 * l.start[line]; };
  if (a) line_residual(level, d, line_a);
  if (b) line_residual(level, d, line_b);
  if (a && b) {
    band::solve_pair(band(line_a), rows(line_a), l.width[line_a], rhs(line_a), band(line_b),
                     rows(line_b), l.width[line_b], rhs(line_b));
  } else if (a || b) {
    const std::int64_t line = a ? line_a : line_b;
    band::solve(band(line), rows(line), l.width[line], rhs(line));
  }
  if (a) line_correct(level, d, line_a);
  if (b) line_correct(level, d, line_b);
}

void VcyclePreconditioner::smooth(LoopRunner& run, Level& level, bool forward) {
  auto sweep = [&](int d, int colour) {
    const Lines& l = level.lines[d];
    // A colour's lines are independent (none reads another's nodes): task k takes the
    // colour's lines per k and per k + 1 (per = lines_per_task_, 1 or 2) whatever the
    // schedule; the bits are the same for either per.
    const std::int64_t b = l.colour_start[colour];
    const std::int64_t count = l.colour_start[colour + 1] - b;
    const int per = lines_per_task_;
    run.for_index((count + per - 1) / per, vcycle_bytes::line_sweep(level, d, per),
                  [&](std::int64_t k) {
                    const std::int64_t first = b + per * k;
                    const bool pair = per == 2 && per * k + 1 < count;
                    update_lines(level, d, l.by_colour[first], pair ? l.by_colour[first + 1] : -1);
                  });
  };
  if (forward) {
    for (int d = 0; d < 2; ++d) {
      const int colours = static_cast<int>(level.lines[d].colour_start.size()) - 1;
      for (int c = 0; c < colours; ++c) sweep(d, c);
    }
  } else {
    for (int d = 1; d >= 0; --d) {
      const int colours = static_cast<int>(level.lines[d].colour_start.size()) - 1;
      for (int c = colours - 1; c >= 0; --c) sweep(d, c);
    }
  }
}

void VcyclePreconditioner::cycle(LoopRunner& run, std::size_t k) {
  Level& level = levels_[k];
  const std::int64_t nodes = static_cast<std::int64_t>(level.i.size());
  if (k + 1 == levels_.size()) {
    // The coarsest level: a direct solve on one thread.
#pragma omp single
    {
      if (direct_ready_) {
        coarse_b_ = Eigen::Map<const Eigen::VectorXd>(level.b.data(), 3 * nodes);
        coarse_x_ = direct_.solve(coarse_b_);
        std::copy(coarse_x_.data(), coarse_x_.data() + 3 * nodes, level.x.begin());
      } else {
        std::fill(level.x.begin(), level.x.end(), 0.0);
      }
    }
    return;
  }
  run.for_index(nodes, LoopBytes{.written = bytes::kVector3}, [&](std::int64_t a) {
    for (int c = 0; c < 3; ++c) level.x[3 * a + c] = 0.0;
  });
  smooth(run, level, true);
  const BlockRows& a = level.a;
  run.for_index(nodes, vcycle_bytes::residual(level), [&](std::int64_t node) {
    block_residual(a.start.data(), a.col.data(), a.value.data(), node, level.x.data(),
                   level.b.data(), level.res.data() + 3 * node);
  });
  Level& coarse = levels_[k + 1];
  const LoopBytes restrict_bytes =
      vcycle_bytes::transfer(level.r, level.i.size(), coarse.i.size(), false);
  run.for_index(static_cast<std::int64_t>(coarse.i.size()), restrict_bytes, [&](std::int64_t c) {
    double sum[3] = {0.0, 0.0, 0.0};
    for (std::int64_t e = level.r.start[c]; e < level.r.start[c + 1]; ++e) {
      const double w = level.r.weight[e];
      const double* res = level.res.data() + 3 * level.r.node[e];
      for (int q = 0; q < 3; ++q) sum[q] += w * res[q];
    }
    for (int q = 0; q < 3; ++q) coarse.b[3 * c + q] = sum[q];
  });
  cycle(run, k + 1);
  const LoopBytes prolong_bytes =
      vcycle_bytes::transfer(level.p, coarse.i.size(), level.i.size(), true);
  run.for_index(nodes, prolong_bytes, [&](std::int64_t node) {
    double sum[3] = {0.0, 0.0, 0.0};
    for (std::int64_t e = level.p.start[node]; e < level.p.start[node + 1]; ++e) {
      const double w = level.p.weight[e];
      const double* xc = coarse.x.data() + 3 * level.p.node[e];
      for (int q = 0; q < 3; ++q) sum[q] += w * xc[q];
    }
    for (int q = 0; q < 3; ++q) level.x[3 * node + q] += sum[q];
  });
  smooth(run, level, false);
}

void VcyclePreconditioner::apply(LoopRunner& run, const StepContext& ctx, std::span<const double> r,
                                 std::span<double> out) {
  Level& fine = levels_.front();
  const std::int64_t nodes = static_cast<std::int64_t>(fine.i.size());
  // The node's slot and one vector read, the other written.
  const LoopBytes copy{.read = vcycle_bytes::kOffset + bytes::kVector3, .written = bytes::kVector3};
  run.for_index(nodes, copy, [&](std::int64_t a) {
    const std::int64_t s = slot_of_node_[a];
    for (int c = 0; c < 3; ++c) fine.b[3 * a + c] = r[3 * s + c];
  });
  cycle(run, 0);
  run.for_each(ElementKind::particles, LoopBytes{.written = bytes::kVector3}, [&](std::int64_t s) {
    for (int c = 0; c < 3; ++c) out[3 * s + c] = 0.0;
  });
  run.for_index(nodes, copy, [&](std::int64_t a) {
    const std::int64_t s = slot_of_node_[a];
    for (int c = 0; c < 3; ++c) out[3 * s + c] = fine.x[3 * a + c];
  });
  (void)ctx;
}

Eigen::SparseMatrix<double> VcyclePreconditioner::level_operator(int k) const {
  const BlockRows& a = levels_[static_cast<std::size_t>(k)].a;
  const std::int64_t n = static_cast<std::int64_t>(a.start.size()) - 1;
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(9 * a.col.size());
  for (std::int64_t row = 0; row < n; ++row) {
    for (std::int64_t blk = a.start[row]; blk < a.start[row + 1]; ++blk) {
      for (int q = 0; q < 9; ++q) {
        triplets.emplace_back(3 * row + q / 3, 3 * a.col[blk] + q % 3, a.value[9 * blk + q]);
      }
    }
  }
  Eigen::SparseMatrix<double> m(3 * n, 3 * n);
  m.setFromTriplets(triplets.begin(), triplets.end());
  return m;
}

Eigen::SparseMatrix<double> VcyclePreconditioner::prolongation(int k) const {
  const Weights& p = levels_[static_cast<std::size_t>(k)].p;
  const std::int64_t n = static_cast<std::int64_t>(p.start.size()) - 1;
  const std::int64_t m =
      static_cast<std::int64_t>(levels_[static_cast<std::size_t>(k) + 1].i.size());
  std::vector<Eigen::Triplet<double>> triplets;
  for (std::int64_t a = 0; a < n; ++a) {
    for (std::int64_t e = p.start[a]; e < p.start[a + 1]; ++e) {
      for (int c = 0; c < 3; ++c) triplets.emplace_back(3 * a + c, 3 * p.node[e] + c, p.weight[e]);
    }
  }
  Eigen::SparseMatrix<double> out(3 * n, 3 * m);
  out.setFromTriplets(triplets.begin(), triplets.end());
  return out;
}

std::size_t VcyclePreconditioner::memory_bytes() const {
  std::size_t bytes = (slot_of_node_.capacity() + unknown_.capacity()) * sizeof(std::int64_t) +
                      node_at_.capacity() * sizeof(std::int32_t) + topology_.memory_bytes() +
                      (bending_.capacity() + bending_now_.capacity()) * sizeof(std::uint64_t) +
                      changed_.capacity() +
                      row_cols_.capacity() * sizeof(std::vector<std::int64_t>) +
                      row_source_.capacity() * sizeof(RowSource);
  for (const std::vector<std::int64_t>& arena : arenas_) {
    bytes += arena.capacity() * sizeof(std::int64_t);
  }
  for (const Accumulator& acc : accumulators_) {
    bytes += (acc.slot_of.capacity() + acc.cols.capacity() + acc.order.capacity()) *
                 sizeof(std::int64_t) +
             acc.values.capacity() * sizeof(double);
  }
  for (const std::vector<std::int64_t>& cols : row_cols_) {
    bytes += cols.capacity() * sizeof(std::int64_t);
  }
  for (const Level& level : levels_) {
    Level::for_each_vector(level, [&bytes](const auto& v) {
      bytes += v.capacity() * sizeof(typename std::decay_t<decltype(v)>::value_type);
    });
  }
  if (direct_ready_) {
    const auto& l = direct_.matrixL().nestedExpression();
    bytes += static_cast<std::size_t>(l.nonZeros()) * (sizeof(double) + sizeof(int));
  }
  return bytes;
}

}  // namespace clothbench::kernels
