// Two-level preconditioner of Newton's inner PCG (see multigrid_preconditioner.hpp).
#include "kernels/multigrid_preconditioner.hpp"

#include <utility>

namespace clothbench::kernels {

namespace {

using Follow = std::vector<std::pair<std::int64_t, double>>;

/// Appends the free particles (with weights) that node t's value follows: itself, a ghost's
/// parents by halves, nothing for a pinned particle. False when t is not a node of the mesh.
bool follow(const ClothMesh& mesh, std::int64_t t, double weight, Follow& out) {
  const std::uint8_t f = mesh.flags[t];
  if ((f & kParticleGhost) != 0) {
    const int d = ghost_direction(f);
    if (d < 0) return false;
    const std::int64_t id = element_id(t, d);
    if (mesh.prev[id] < 0 || mesh.next[id] < 0) return false;
    return follow(mesh, mesh.prev[id], 0.5 * weight, out) &&
           follow(mesh, mesh.next[id], 0.5 * weight, out);
  }
  if ((f & kParticleActive) == 0) return false;
  if ((f & kParticlePinned) == 0) out.emplace_back(t, weight);
  return true;
}

/// Grid lines of the coarse grid: every other line and the last one.
bool coarse_line(int index, int lines) { return index % 2 == 0 || index == lines - 1; }

/// The coarse lines around `index` with their bilinear weights (one line of weight 1 on a
/// coarse line; otherwise the two neighbours, which are coarse lines, by halves).
int around(int index, int lines, int out[2], double weight[2]) {
  if (coarse_line(index, lines)) {
    out[0] = index;
    weight[0] = 1.0;
    return 1;
  }
  out[0] = index - 1;
  out[1] = index + 1;
  weight[0] = weight[1] = 0.5;
  return 2;
}

}  // namespace

void MultigridPreconditioner::build_prolongation(const StepContext& ctx) {
  const ClothMesh& mesh = ctx.mesh;
  const std::int64_t slots = mesh.slot_count();
  const int ni = mesh.size_i(), nj = mesh.size_j();
  auto lattice = [&](std::int64_t s) {
    const auto [i, j] = mesh.grid_of(s);
    return coarse_line(i, ni) && coarse_line(j, nj);
  };
  // The free particles a fine particle follows, or false when it must be a coarse node.
  Follow list;
  auto corners = [&](std::int64_t s) {
    list.clear();
    int ci[2], cj[2];
    double wi[2], wj[2];
    const auto [i, j] = mesh.grid_of(s);
    const int n_i = around(i, ni, ci, wi);
    const int n_j = around(j, nj, cj, wj);
    for (int a = 0; a < n_i; ++a) {
      for (int b = 0; b < n_j; ++b) {
        if (!follow(mesh, mesh.slot(ci[a], cj[b]), wi[a] * wj[b], list)) return false;
      }
    }
    for (const auto& [t, w] : list) {
      if (!lattice(t)) return false;
    }
    return true;
  };
  std::vector<std::int64_t> coarse(static_cast<std::size_t>(slots), -1);
  std::int64_t nodes = 0;
  for (std::int64_t s = 0; s < slots; ++s) {
    if (ctx.is_free(s) && (lattice(s) || !corners(s))) coarse[s] = nodes++;
  }
  std::vector<Eigen::Triplet<double>> triplets;
  for (std::int64_t s = 0; s < slots; ++s) {
    if (!ctx.is_free(s)) continue;
    if (coarse[s] >= 0) {
      for (int k = 0; k < 3; ++k) triplets.emplace_back(3 * s + k, 3 * coarse[s] + k, 1.0);
      continue;
    }
    corners(s);
    for (const auto& [t, w] : list) {
      for (int k = 0; k < 3; ++k) triplets.emplace_back(3 * s + k, 3 * coarse[t] + k, w);
    }
  }
  prolongation_.resize(3 * slots, 3 * nodes);
  prolongation_.setFromTriplets(triplets.begin(), triplets.end());
  restriction_ = prolongation_.transpose();
  coarse_nodes_ = nodes;
}

void MultigridPreconditioner::factor(LoopRunner& /*run*/, const StepContext& ctx,
                                     const ModelHessian& hessian) {
#pragma omp single
  {
    ++factorisations_;
    build_prolongation(ctx);
    const std::int64_t slots = ctx.mesh.slot_count();
    std::vector<std::int64_t> unknown(static_cast<std::size_t>(slots), -1);
    for (std::int64_t s = 0; s < slots; ++s) {
      if (ctx.is_free(s)) unknown[s] = s;
    }
    const Eigen::SparseMatrix<double> fine = hessian.matrix(ctx, unknown, slots);
    coarse_ = Eigen::SparseMatrix<double>(restriction_ * fine) * prolongation_;
    coarse_r_.setZero(coarse_.rows());
    coarse_x_.setZero(coarse_.rows());
    coarse_ready_ = false;
    if (coarse_.rows() > 0) {
      direct_.compute(coarse_);
      coarse_ready_ = direct_.info() == Eigen::Success;
      if (!coarse_ready_) ++coarse_failures_;
    }
  }  // the single's closing barrier publishes the hierarchy
}

void MultigridPreconditioner::apply(LoopRunner& run, const StepContext& ctx,
                                    LinePreconditioner& lines, std::span<const double> r,
                                    std::span<double> out) {
  // out = L^-1 r + P A_c^-1 P^T r: the line solves, the restriction's rows, the coarse solve
  // on one thread, then each particle adds its prolonged correction.
  lines.apply(run, ctx, r, out);
  if (!coarse_ready_) return;
  // Per restriction row: its entries (value and column) and start, every entry of r once;
  // the coarse entry written. Per particle: flags, its three prolongation rows, every coarse
  // entry once, out read and written.
  const auto per = [](double total, double count) { return count > 0.0 ? total / count : 0.0; };
  const double entry = bytes::kDouble + bytes::kIndex;
  const auto rows = static_cast<double>(restriction_.rows());
  const LoopBytes restrict_bytes{
      .read = bytes::kIndex + per(entry * static_cast<double>(restriction_.nonZeros()) +
                                      bytes::kDouble * static_cast<double>(r.size()),
                                  rows),
      .written = bytes::kDouble};
  const LoopBytes prolong_bytes{
      .read = bytes::kFlag + 3 * bytes::kIndex + bytes::kVector3 +
              per(entry * static_cast<double>(prolongation_.nonZeros()) + bytes::kDouble * rows,
                  static_cast<double>(ctx.mesh.slot_count())),
      .written = bytes::kVector3};
  run.for_index(restriction_.rows(), restrict_bytes, [&](std::int64_t row) {
    double sum = 0.0;
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(restriction_, row); it;
         ++it) {
      sum += it.value() * r[static_cast<std::size_t>(it.col())];
    }
    coarse_r_[row] = sum;
  });
#pragma omp single
  coarse_x_ = direct_.solve(coarse_r_);
  run.for_each(ElementKind::particles, prolong_bytes, [&](std::int64_t s) {
    if (!ctx.is_free(s)) return;
    for (int k = 0; k < 3; ++k) {
      double sum = 0.0;
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(prolongation_, 3 * s + k);
           it; ++it) {
        sum += it.value() * coarse_x_[it.col()];
      }
      out[3 * static_cast<std::size_t>(s) + k] += sum;
    }
  });
}

std::size_t MultigridPreconditioner::memory_bytes() const {
  auto sparse = [](auto nonzeros, auto outer) {
    return static_cast<std::size_t>(nonzeros) * (sizeof(double) + sizeof(int)) +
           static_cast<std::size_t>(outer + 1) * sizeof(int);
  };
  std::size_t bytes =
      static_cast<std::size_t>(coarse_r_.size() + coarse_x_.size()) * sizeof(double) +
      sparse(prolongation_.nonZeros(), prolongation_.outerSize()) +
      sparse(restriction_.nonZeros(), restriction_.outerSize()) +
      sparse(coarse_.nonZeros(), coarse_.outerSize());
  if (coarse_ready_) {
    const auto& l = direct_.matrixL().nestedExpression();
    bytes += sparse(l.nonZeros(), l.outerSize());
  }
  return bytes;
}

}  // namespace clothbench::kernels
