// Multigrid V-cycle preconditioner of Newton's inner PCG (see vcycle_preconditioner.hpp).
#include "kernels/vcycle_preconditioner.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

namespace clothbench::kernels {

namespace {

using Follow = std::vector<std::pair<std::int64_t, double>>;

/// A grid line index on the lattice of spacing `s` (or the grid's last line).
bool on_lattice(int index, int s, int lines) { return index % s == 0 || index == lines - 1; }

/// The lattice lines around `index` with their linear weights: the line itself (weight 1) on
/// the lattice, else the lattice lines below and above by grid distance.
int around(int index, int s, int lines, int out[2], double weight[2]) {
  if (on_lattice(index, s, lines)) {
    out[0] = index;
    weight[0] = 1.0;
    return 1;
  }
  const int lo = (index / s) * s;
  const int hi = std::min(lo + s, lines - 1);
  out[0] = lo;
  out[1] = hi;
  weight[0] = static_cast<double>(hi - index) / (hi - lo);
  weight[1] = static_cast<double>(index - lo) / (hi - lo);
  return 2;
}

/// Lower band of a symmetric positive definite band matrix (half-bandwidth w, row-major rows
/// of w + 1 entries, entry (r, c) for r - w <= c <= r at r * (w + 1) + c - r + w) overwritten
/// by its Cholesky factor L. False on a non-positive pivot.
bool band_cholesky(double* band, std::int64_t n, int w) {
  const std::int64_t row = w + 1;
  for (std::int64_t r = 0; r < n; ++r) {
    const std::int64_t first = std::max<std::int64_t>(0, r - w);
    for (std::int64_t c = first; c <= r; ++c) {
      double sum = band[r * row + c - r + w];
      const std::int64_t from = std::max(first, c - w);
      for (std::int64_t k = from; k < c; ++k) sum -= band[r * row + k - r + w] * band[c * row + k - c + w];
      if (c == r) {
        if (!(sum > 0.0) || !std::isfinite(sum)) return false;
        band[r * row + w] = std::sqrt(sum);
      } else {
        band[r * row + c - r + w] = sum / band[c * row + w];
      }
    }
  }
  return true;
}

/// Solves L L^T x = b in place with the factor of band_cholesky.
void band_solve(const double* band, std::int64_t n, int w, double* x) {
  const std::int64_t row = w + 1;
  for (std::int64_t r = 0; r < n; ++r) {
    double sum = x[r];
    for (std::int64_t k = std::max<std::int64_t>(0, r - w); k < r; ++k) sum -= band[r * row + k - r + w] * x[k];
    x[r] = sum / band[r * row + w];
  }
  for (std::int64_t r = n - 1; r >= 0; --r) {
    double sum = x[r];
    const std::int64_t last = std::min<std::int64_t>(n - 1, r + w);
    for (std::int64_t k = r + 1; k <= last; ++k) sum -= band[k * row + r - k + w] * x[k];
    x[r] = sum / band[r * row + w];
  }
}

}  // namespace

VcyclePreconditioner::Coarsening VcyclePreconditioner::coarsen(
    const StepContext& ctx, int k, int s, std::vector<std::int64_t>& node_at) {
  const ClothMesh& mesh = ctx.mesh;
  const int ni = mesh.size_i(), nj = mesh.size_j();
  Level& fine = levels_[static_cast<std::size_t>(k)];
  const std::int64_t n = static_cast<std::int64_t>(fine.i.size());
  if (n <= coarsest_nodes_ || s >= 2 * std::max(ni, nj)) return Coarsening::coarsest;
  auto grid = [&](int i, int j) { return static_cast<std::size_t>(i) * nj + j; };
  for (std::int64_t a = 0; a < n; ++a) node_at[grid(fine.i[a], fine.j[a])] = a;
  // The nodes of level k that node (i, j)'s value follows, with weights, or false.
  Follow list;
  auto corner = [&](int i, int j, double w) {
    const std::int64_t a = node_at[grid(i, j)];
    if (a >= 0) {
      list.emplace_back(a, w);
      return true;
    }
    const std::int32_t slot = mesh.slot(i, j);
    const std::uint8_t f = mesh.flags[slot];
    if ((f & kParticleActive) != 0 && (f & kParticlePinned) != 0) return true;  // zero
    if (k == 0 && (f & kParticleGhost) != 0) {
      // A ghost follows its parents by halves; they must be nodes on the coarse lattice.
      const int d = ghost_direction(f);
      if (d < 0) return false;
      const std::int64_t id = element_id(slot, d);
      for (const std::int64_t parent : {mesh.prev[id], mesh.next[id]}) {
        if (parent < 0) return false;
        const int pi = mesh.grid_i(parent), pj = mesh.grid_j(parent);
        const std::int64_t b = node_at[grid(pi, pj)];
        const std::uint8_t pf = mesh.flags[parent];
        if (b >= 0) {
          if (!on_lattice(pi, s, ni) || !on_lattice(pj, s, nj)) return false;
          list.emplace_back(b, 0.5 * w);
        } else if ((pf & kParticleActive) == 0 || (pf & kParticlePinned) == 0) {
          return false;
        }
      }
      return true;
    }
    return false;
  };
  auto corners = [&](std::int64_t a) {
    list.clear();
    int ci[2], cj[2];
    double wi[2], wj[2];
    const int n_i = around(fine.i[a], s, ni, ci, wi);
    const int n_j = around(fine.j[a], s, nj, cj, wj);
    for (int x = 0; x < n_i; ++x) {
      for (int y = 0; y < n_j; ++y) {
        if (!corner(ci[x], cj[y], wi[x] * wj[y])) return false;
      }
    }
    return true;
  };
  std::vector<std::int64_t> coarse(static_cast<std::size_t>(n), -1);
  Level next;
  for (std::int64_t a = 0; a < n; ++a) {
    const bool lattice = on_lattice(fine.i[a], s, ni) && on_lattice(fine.j[a], s, nj);
    if (lattice || !corners(a)) {
      coarse[a] = static_cast<std::int64_t>(next.i.size());
      next.i.push_back(fine.i[a]);
      next.j.push_back(fine.j[a]);
    }
  }
  const std::int64_t m = static_cast<std::int64_t>(next.i.size());
  for (std::int64_t a = 0; a < n; ++a) node_at[grid(fine.i[a], fine.j[a])] = -1;
  if (m == 0) return Coarsening::coarsest;
  if (5 * m > 4 * n) return Coarsening::too_few;  // try the next lattice from this level
  // The corners of an interpolated node are lattice nodes, hence coarse nodes.
  for (std::int64_t a = 0; a < n; ++a) node_at[grid(fine.i[a], fine.j[a])] = a;
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(static_cast<std::size_t>(3 * n * 2));
  for (std::int64_t a = 0; a < n; ++a) {
    if (coarse[a] >= 0) {
      for (int c = 0; c < 3; ++c) triplets.emplace_back(3 * a + c, 3 * coarse[a] + c, 1.0);
      continue;
    }
    corners(a);
    for (const auto& [b, w] : list) {
      for (int c = 0; c < 3; ++c) triplets.emplace_back(3 * a + c, 3 * coarse[b] + c, w);
    }
  }
  for (std::int64_t a = 0; a < n; ++a) node_at[grid(fine.i[a], fine.j[a])] = -1;
  fine.p.resize(3 * n, 3 * m);
  fine.p.setFromTriplets(triplets.begin(), triplets.end());
  fine.r = fine.p.transpose();
  const RowMatrix ap = fine.a * fine.p;
  next.a = fine.r * ap;
  levels_.push_back(std::move(next));
  return Coarsening::level;
}

void VcyclePreconditioner::build_lines(Level& level, int d) {
  Lines& l = level.lines[d];
  const std::int64_t n = static_cast<std::int64_t>(level.i.size());
  // Direction 0: lines of constant j along i; direction 1: constant i along j.
  const std::vector<int>& key = d == 0 ? level.j : level.i;
  const std::vector<int>& along = d == 0 ? level.i : level.j;
  // Counting sort by (key, along): nodes are in slot or coarsening order, not grid order.
  l.order.resize(static_cast<std::size_t>(n));
  std::iota(l.order.begin(), l.order.end(), 0);
  std::stable_sort(l.order.begin(), l.order.end(), [&](std::int64_t a, std::int64_t b) {
    return key[a] != key[b] ? key[a] < key[b] : along[a] < along[b];
  });
  l.start.clear();
  l.line_of.assign(static_cast<std::size_t>(n), -1);
  l.position.assign(static_cast<std::size_t>(n), -1);
  int current = -1;
  for (std::int64_t e = 0; e < n; ++e) {
    const std::int64_t a = l.order[e];
    if (key[a] != current) {
      current = key[a];
      l.start.push_back(e);
    }
    l.line_of[a] = static_cast<std::int64_t>(l.start.size()) - 1;
    l.position[a] = e - l.start.back();
  }
  const std::int64_t lines = static_cast<std::int64_t>(l.start.size());
  l.start.push_back(n);
  // Widths and couplings between lines; greedy colours in line order.
  l.width.assign(static_cast<std::size_t>(lines), 0);
  std::vector<int> colour(static_cast<std::size_t>(lines), -1);
  int colours = 0;
  for (std::int64_t line = 0; line < lines; ++line) {
    std::vector<char> used(static_cast<std::size_t>(colours) + 1, 0);
    int width = 0;
    for (std::int64_t e = l.start[line]; e < l.start[line + 1]; ++e) {
      const std::int64_t a = l.order[e];
      for (int c = 0; c < 3; ++c) {
        for (RowMatrix::InnerIterator it(level.a, 3 * a + c); it; ++it) {
          const std::int64_t b = it.col() / 3;
          const std::int64_t other = l.line_of[b];
          if (other == line) {
            const std::int64_t dist =
                std::abs(3 * (l.position[a] - l.position[b]) + c - static_cast<std::int64_t>(it.col() % 3));
            width = std::max(width, static_cast<int>(dist));
          } else if (colour[other] >= 0) {
            used[colour[other]] = 1;
          }
        }
      }
    }
    int pick = 0;
    while (pick < colours && used[pick] != 0) ++pick;
    colour[line] = pick;
    colours = std::max(colours, pick + 1);
    l.width[line] = width;
  }
  l.colour_start.assign(static_cast<std::size_t>(colours) + 1, 0);
  for (std::int64_t line = 0; line < lines; ++line) ++l.colour_start[colour[line] + 1];
  for (int c = 0; c < colours; ++c) l.colour_start[c + 1] += l.colour_start[c];
  l.by_colour.assign(static_cast<std::size_t>(lines), 0);
  std::vector<std::int64_t> fill(l.colour_start.begin(), l.colour_start.end() - 1);
  for (std::int64_t line = 0; line < lines; ++line) l.by_colour[fill[colour[line]]++] = line;
  l.band_start.assign(static_cast<std::size_t>(lines) + 1, 0);
  for (std::int64_t line = 0; line < lines; ++line) {
    l.band_start[line + 1] =
        l.band_start[line] + 3 * (l.start[line + 1] - l.start[line]) * (l.width[line] + 1);
  }
  l.band.assign(static_cast<std::size_t>(l.band_start.back()), 0.0);
  l.ok.assign(static_cast<std::size_t>(lines), 0);
}

void VcyclePreconditioner::factor_line(Level& level, int d, std::int64_t line) {
  Lines& l = level.lines[d];
  const int w = l.width[line];
  double* band = l.band.data() + l.band_start[line];
  const std::int64_t rows = 3 * (l.start[line + 1] - l.start[line]);
  std::fill(band, band + rows * (w + 1), 0.0);
  for (std::int64_t e = l.start[line]; e < l.start[line + 1]; ++e) {
    const std::int64_t a = l.order[e];
    for (int c = 0; c < 3; ++c) {
      const std::int64_t lr = 3 * l.position[a] + c;
      for (RowMatrix::InnerIterator it(level.a, 3 * a + c); it; ++it) {
        const std::int64_t b = it.col() / 3;
        if (l.line_of[b] != line) continue;
        const std::int64_t lc = 3 * l.position[b] + it.col() % 3;
        if (lc <= lr) band[lr * (w + 1) + lc - lr + w] += it.value();
      }
    }
  }
  l.ok[line] = band_cholesky(band, rows, w) ? 1 : 0;
}

void VcyclePreconditioner::update_line(Level& level, int d, std::int64_t line) {
  Lines& l = level.lines[d];
  if (l.ok[line] == 0) return;
  const std::int64_t first = l.start[line];
  const std::int64_t rows = 3 * (l.start[line + 1] - first);
  double* rhs = level.scratch.data() + 3 * first;
  for (std::int64_t e = first; e < l.start[line + 1]; ++e) {
    const std::int64_t a = l.order[e];
    for (int c = 0; c < 3; ++c) {
      double sum = level.b[3 * a + c];
      for (RowMatrix::InnerIterator it(level.a, 3 * a + c); it; ++it) {
        sum -= it.value() * level.x[it.col()];
      }
      rhs[3 * (e - first) + c] = sum;
    }
  }
  band_solve(l.band.data() + l.band_start[line], rows, l.width[line], rhs);
  for (std::int64_t e = first; e < l.start[line + 1]; ++e) {
    const std::int64_t a = l.order[e];
    for (int c = 0; c < 3; ++c) level.x[3 * a + c] += rhs[3 * (e - first) + c];
  }
}

void VcyclePreconditioner::smooth(LoopRunner& run, Level& level, bool forward) {
  auto sweep = [&](int d, int colour) {
    const Lines& l = level.lines[d];
    const std::int64_t b = l.colour_start[colour];
    run.for_index(l.colour_start[colour + 1] - b,
                  [&](std::int64_t k) { update_line(level, d, l.by_colour[b + k]); });
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
  const std::int64_t rows = static_cast<std::int64_t>(level.x.size());
  if (k + 1 == levels_.size()) {
    // The coarsest level: a direct solve on one thread.
#pragma omp single
    {
      if (direct_ready_) {
        coarse_b_ = Eigen::Map<const Eigen::VectorXd>(level.b.data(), rows);
        coarse_x_ = direct_.solve(coarse_b_);
        std::copy(coarse_x_.data(), coarse_x_.data() + rows, level.x.begin());
      } else {
        std::fill(level.x.begin(), level.x.end(), 0.0);
      }
    }
    return;
  }
  run.for_index(rows, [&](std::int64_t row) { level.x[row] = 0.0; });
  smooth(run, level, true);
  run.for_index(rows, [&](std::int64_t row) {
    double sum = level.b[row];
    for (RowMatrix::InnerIterator it(level.a, row); it; ++it) sum -= it.value() * level.x[it.col()];
    level.res[row] = sum;
  });
  Level& coarse = levels_[k + 1];
  run.for_index(level.r.rows(), [&](std::int64_t row) {
    double sum = 0.0;
    for (RowMatrix::InnerIterator it(level.r, row); it; ++it) sum += it.value() * level.res[it.col()];
    coarse.b[row] = sum;
  });
  cycle(run, k + 1);
  run.for_index(rows, [&](std::int64_t row) {
    double sum = 0.0;
    for (RowMatrix::InnerIterator it(level.p, row); it; ++it) sum += it.value() * coarse.x[it.col()];
    level.x[row] += sum;
  });
  smooth(run, level, false);
}

void VcyclePreconditioner::factor(LoopRunner& run, const StepContext& ctx,
                                  const ModelHessian& hessian) {
#pragma omp single
  {
    ++factorisations_;
    const ClothMesh& mesh = ctx.mesh;
    levels_.clear();
    std::int64_t count = 0;
    const std::vector<std::int64_t> unknown = free_unknowns(ctx, &count);
    slot_of_node_.assign(static_cast<std::size_t>(count), -1);
    Level fine;
    fine.i.resize(static_cast<std::size_t>(count));
    fine.j.resize(static_cast<std::size_t>(count));
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      if (unknown[s] < 0) continue;
      slot_of_node_[unknown[s]] = s;
      fine.i[unknown[s]] = mesh.grid_i(s);
      fine.j[unknown[s]] = mesh.grid_j(s);
    }
    {
      // The model is symmetric: its compressed columns are its compressed rows.
      const Eigen::SparseMatrix<double> a = hessian.matrix(ctx, unknown, count);
      fine.a = Eigen::Map<const RowMatrix>(a.rows(), a.cols(), a.nonZeros(), a.outerIndexPtr(),
                                           a.innerIndexPtr(), a.valuePtr());
    }
    levels_.push_back(std::move(fine));
    std::vector<std::int64_t> node_at(static_cast<std::size_t>(mesh.slot_count()), -1);
    // Lattice spacings 2, 4, 8, ...: a spacing that would remove less than a fifth of a
    // level's nodes (a coarse region's leaves are coarser) makes no level; the next one is
    // tried from the same level.
    int k = 0;
    for (int s = 2;; s *= 2) {
      const Coarsening made = coarsen(ctx, k, s, node_at);
      if (made == Coarsening::coarsest) break;
      if (made == Coarsening::level) ++k;
    }
    for (std::size_t k = 0; k < levels_.size(); ++k) {
      Level& level = levels_[k];
      const std::size_t rows = 3 * level.i.size();
      level.x.assign(rows, 0.0);
      level.b.assign(rows, 0.0);
      level.res.assign(rows, 0.0);
      level.scratch.assign(rows, 0.0);
      if (k + 1 < levels_.size()) {
        for (int d = 0; d < 2; ++d) build_lines(level, d);
      }
    }
    const Level& last = levels_.back();
    direct_ready_ = false;
    if (last.a.rows() > 0) {
      const Eigen::SparseMatrix<double> coarsest = last.a;
      direct_.compute(coarsest);
      direct_ready_ = direct_.info() == Eigen::Success;
      if (!direct_ready_) ++failures_;
    }
  }  // the single's barrier publishes the hierarchy
  // Every line of every smoothed level, one loop.
  std::vector<std::pair<std::size_t, std::int64_t>> all;  // (level * 2 + d, line)
  for (std::size_t k = 0; k + 1 < levels_.size(); ++k) {
    for (int d = 0; d < 2; ++d) {
      const std::int64_t lines = static_cast<std::int64_t>(levels_[k].lines[d].start.size()) - 1;
      for (std::int64_t line = 0; line < lines; ++line) all.emplace_back(2 * k + d, line);
    }
  }
  run.for_index(static_cast<std::int64_t>(all.size()), [&](std::int64_t e) {
    const auto [kd, line] = all[static_cast<std::size_t>(e)];
    factor_line(levels_[kd / 2], static_cast<int>(kd % 2), line);
  });
#pragma omp single
  {
    for (std::size_t k = 0; k + 1 < levels_.size(); ++k) {
      for (const Lines& l : levels_[k].lines) {
        for (const std::uint8_t ok : l.ok) failures_ += ok == 0 ? 1 : 0;
      }
    }
  }
}

void VcyclePreconditioner::apply(LoopRunner& run, const StepContext& ctx,
                                 const std::vector<double>& r, std::vector<double>& out) {
  Level& fine = levels_.front();
  const std::int64_t nodes = static_cast<std::int64_t>(fine.i.size());
  run.for_index(nodes, [&](std::int64_t a) {
    const std::int64_t s = slot_of_node_[a];
    for (int c = 0; c < 3; ++c) fine.b[3 * a + c] = r[3 * s + c];
  });
  cycle(run, 0);
  run.for_each(ElementKind::particles, [&](std::int64_t s) {
    for (int c = 0; c < 3; ++c) out[3 * s + c] = 0.0;
  });
  run.for_index(nodes, [&](std::int64_t a) {
    const std::int64_t s = slot_of_node_[a];
    for (int c = 0; c < 3; ++c) out[3 * s + c] = fine.x[3 * a + c];
  });
  (void)ctx;
}

std::size_t VcyclePreconditioner::memory_bytes() const {
  auto sparse = [](const RowMatrix& m) {
    return static_cast<std::size_t>(m.nonZeros()) * (sizeof(double) + sizeof(int)) +
           static_cast<std::size_t>(m.outerSize() + 1) * sizeof(int);
  };
  std::size_t bytes = slot_of_node_.capacity() * sizeof(std::int64_t);
  for (const Level& level : levels_) {
    bytes += sparse(level.a) + sparse(level.p) + sparse(level.r) +
             (level.i.capacity() + level.j.capacity()) * sizeof(int) +
             (level.x.capacity() + level.b.capacity() + level.res.capacity() +
              level.scratch.capacity()) *
                 sizeof(double);
    for (const Lines& l : level.lines) {
      bytes += l.band.capacity() * sizeof(double) +
               (l.order.capacity() + l.start.capacity() + l.by_colour.capacity() +
                l.colour_start.capacity() + l.band_start.capacity() + l.line_of.capacity() +
                l.position.capacity()) *
                   sizeof(std::int64_t) +
               l.width.capacity() * sizeof(int) + l.ok.capacity();
    }
  }
  if (direct_ready_) {
    const auto& l = direct_.matrixL().nestedExpression();
    bytes += static_cast<std::size_t>(l.nonZeros()) * (sizeof(double) + sizeof(int));
  }
  return bytes;
}

}  // namespace clothbench::kernels
