// Set-up of the V-cycle (see vcycle_preconditioner.hpp): the check of the structure, level 0
// from the model's blocks, the coarser levels and their prolongations, the Galerkin products,
// and factor(), which runs them with the lines (vcycle_lines.cpp) and the coarsest solve. The
// cycle itself is in vcycle_preconditioner.cpp.
#include <omp.h>

#include <algorithm>
#include <numeric>
#include <utility>

#include "kernels/vcycle_preconditioner.hpp"

#include "kernels/vcycle_loop_bytes.hpp"

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

}  // namespace

VcyclePreconditioner::Coarsening VcyclePreconditioner::coarsen(const StepContext& ctx, int k, int s,
                                                               std::vector<std::int32_t>& node_at) {
  const ClothMesh& mesh = ctx.mesh;
  const int ni = mesh.size_i(), nj = mesh.size_j();
  Level& fine = levels_[static_cast<std::size_t>(k)];
  const std::int64_t n = static_cast<std::int64_t>(fine.i.size());
  if (n <= coarsest_nodes_ || s >= 2 * std::max(ni, nj)) return Coarsening::coarsest;
  auto grid = [&](int i, int j) { return static_cast<std::size_t>(i) * nj + j; };
  for (std::int64_t a = 0; a < n; ++a) {
    node_at[grid(fine.i[a], fine.j[a])] = static_cast<std::int32_t>(a);
  }
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
        const auto [pi, pj] = mesh.grid_of(parent);
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
  Level next = take_level();
  for (std::int64_t a = 0; a < n; ++a) {
    const bool lattice = on_lattice(fine.i[a], s, ni) && on_lattice(fine.j[a], s, nj);
    if (lattice || !corners(a)) {
      coarse[a] = static_cast<std::int64_t>(next.i.size());
      next.i.push_back(fine.i[a]);
      next.j.push_back(fine.j[a]);
    }
  }
  const std::int64_t m = static_cast<std::int64_t>(next.i.size());
  auto clear = [&] {
    for (std::int64_t a = 0; a < n; ++a) node_at[grid(fine.i[a], fine.j[a])] = -1;
  };
  if (m == 0 || 5 * m > 4 * n) {  // none: the coarsest; too few: the next lattice from here
    clear();
    spare_levels_.push_back(std::move(next));  // take_level empties it
    return m == 0 ? Coarsening::coarsest : Coarsening::too_few;
  }
  // P by fine node (the corners of an interpolated node are lattice nodes, hence coarse
  // nodes), then P^T by coarse node in fine node order.
  Weights& p = fine.p;
  p.start.assign(1, 0);
  p.node.clear();
  p.weight.clear();
  for (std::int64_t a = 0; a < n; ++a) {
    if (coarse[a] >= 0) {
      p.node.push_back(coarse[a]);
      p.weight.push_back(1.0);
    } else {
      corners(a);
      for (const auto& [b, w] : list) {
        p.node.push_back(coarse[b]);
        p.weight.push_back(w);
      }
    }
    p.start.push_back(static_cast<std::int64_t>(p.node.size()));
  }
  clear();
  Weights& r = fine.r;
  r.start.assign(static_cast<std::size_t>(m) + 1, 0);
  for (const std::int64_t c : p.node) ++r.start[c + 1];
  for (std::int64_t c = 0; c < m; ++c) r.start[c + 1] += r.start[c];
  r.node.assign(p.node.size(), 0);
  r.weight.assign(p.node.size(), 0.0);
  std::vector<std::int64_t> fill(r.start.begin(), r.start.end() - 1);
  for (std::int64_t a = 0; a < n; ++a) {
    for (std::int64_t e = p.start[a]; e < p.start[a + 1]; ++e) {
      const std::int64_t at = fill[p.node[e]]++;
      r.node[at] = a;
      r.weight[at] = p.weight[e];
    }
  }
  levels_.push_back(std::move(next));
  return Coarsening::level;
}

void VcyclePreconditioner::galerkin_row(std::size_t k, std::int64_t row, Accumulator& acc,
                                        bool pattern) {
  const Level& fine = levels_[k];
  const BlockRows& a = fine.a;
  acc.cols.clear();
  acc.values.clear();
  for (std::int64_t e = fine.r.start[row]; e < fine.r.start[row + 1]; ++e) {
    const std::int64_t i = fine.r.node[e];
    const double wi = fine.r.weight[e];
    for (std::int64_t blk = a.start[i]; blk < a.start[i + 1]; ++blk) {
      const std::int64_t j = a.col[blk];
      const float* block = a.value.data() + 9 * blk;
      for (std::int64_t f = fine.p.start[j]; f < fine.p.start[j + 1]; ++f) {
        const std::int64_t c = fine.p.node[f];
        std::int64_t at = acc.slot_of[c];
        if (at < 0) {
          at = static_cast<std::int64_t>(acc.cols.size());
          acc.slot_of[c] = at;
          acc.cols.push_back(c);
          if (!pattern) acc.values.resize(acc.values.size() + 9, 0.0);
        }
        if (pattern) continue;  // the columns only
        const double w = wi * fine.p.weight[f];
        double* out = acc.values.data() + 9 * at;
        for (int q = 0; q < 9; ++q) out[q] += w * block[q];
      }
    }
  }
  const std::size_t count = acc.cols.size();
  acc.order.resize(count);
  std::iota(acc.order.begin(), acc.order.end(), 0);
  std::sort(acc.order.begin(), acc.order.end(),
            [&](std::int64_t x, std::int64_t y) { return acc.cols[x] < acc.cols[y]; });
  if (pattern) {
    std::vector<std::int64_t>& cols = row_cols_[static_cast<std::size_t>(row)];
    cols.resize(count);
    for (std::size_t e = 0; e < count; ++e) cols[e] = acc.cols[acc.order[e]];
  } else {
    // The same products in the same order as when the pattern was made: only the values.
    BlockRows& coarse = levels_[k + 1].a;
    float* values = coarse.value.data() + 9 * coarse.start[row];
    for (std::size_t e = 0; e < count; ++e) {
      store_rounded(acc.values.data() + 9 * acc.order[e], 9, values + 9 * e);
    }
  }
  for (const std::int64_t c : acc.cols) acc.slot_of[c] = -1;
}

void VcyclePreconditioner::Level::clear() {
  for_each_vector(*this, [](auto& v) { v.clear(); });
}

VcyclePreconditioner::Level VcyclePreconditioner::take_level() {
  if (spare_levels_.empty()) return {};
  Level level = std::move(spare_levels_.back());
  spare_levels_.pop_back();
  level.clear();
  return level;
}

void VcyclePreconditioner::begin_structure(const StepContext& ctx) {
  const ClothMesh& mesh = ctx.mesh;
  ++structures_;
  // The levels become spares, the finest last: take_level hands out level 0's first.
  for (auto level = levels_.rbegin(); level != levels_.rend(); ++level) {
    spare_levels_.push_back(std::move(*level));
  }
  levels_.clear();
  // The free particles block by block, each block's rows in grid order (free_unknowns'
  // numbering; not slot order, whose rows are stored coarsest first: a line across the rows
  // would visit nodes far apart), in the kept buffers: a buffer of the whole mesh made anew
  // for every structure cost its page faults each time.
  unknown_.assign(static_cast<std::size_t>(mesh.slot_count()), -1);
  slot_of_node_.clear();
  Level fine = take_level();
  mesh.for_each_slot_in_grid_rows([&](std::int64_t s) {
    if (!ctx.is_free(s)) return;
    unknown_[s] = static_cast<std::int64_t>(slot_of_node_.size());
    slot_of_node_.push_back(s);
    const auto [i, j] = mesh.grid_of(s);
    fine.i.push_back(i);
    fine.j.push_back(j);
  });
  fine.a.start.assign(slot_of_node_.size() + 1, 0);
  levels_.push_back(std::move(fine));
  row_source_.resize(slot_of_node_.size());
  arenas_.resize(static_cast<std::size_t>(std::max(omp_get_num_threads(), omp_get_max_threads())));
}

void VcyclePreconditioner::level0_pattern(LoopRunner& run, const StepContext& ctx,
                                          const ModelHessian& hessian) {
  // Level 0's pattern: the columns of every row (sorted, distinct) that any model on this
  // topology can fill, by rows into the thread's arena, then, with the rows' offsets known,
  // into place.
  BlockRows& a = levels_.front().a;
  const auto rows = static_cast<std::int64_t>(slot_of_node_.size());
  const LoopBytes row_bytes{.read = 2 * vcycle_bytes::kOffset + ModelHessian::kRowRead,
                            .written = 3 * vcycle_bytes::kOffset};
  run.for_index(rows, row_bytes, [&](std::int64_t row) {
    const int thread = omp_get_thread_num();
    std::vector<std::int64_t>& arena = arenas_[static_cast<std::size_t>(thread)];
    row_source_[row] = {thread, static_cast<std::int64_t>(arena.size())};
    a.start[row + 1] = hessian.row_pattern(ctx, unknown_, slot_of_node_[row], arena);
  });
#pragma omp single
  {
    const double started = omp_get_wtime();
    std::partial_sum(a.start.begin(), a.start.end(), a.start.begin());
    a.col.resize(static_cast<std::size_t>(a.start.back()));
    sequential_seconds_ += omp_get_wtime() - started;
  }
  const double per_row = vcycle_bytes::per_index(
      vcycle_bytes::kOffset * static_cast<double>(a.col.size()), static_cast<std::size_t>(rows));
  run.for_index(rows, {.read = per_row + 3 * vcycle_bytes::kOffset, .written = per_row},
                [&](std::int64_t row) {
                  const RowSource& from = row_source_[row];
                  std::copy_n(arenas_[static_cast<std::size_t>(from.thread)].data() + from.at,
                              a.start[row + 1] - a.start[row], a.col.data() + a.start[row]);
                });
}

void VcyclePreconditioner::size_accumulators() {
  const int threads = std::max(omp_get_num_threads(), omp_get_max_threads());
  if (accumulators_.size() < static_cast<std::size_t>(threads)) {
    accumulators_.resize(static_cast<std::size_t>(threads));
    for (Accumulator& acc : accumulators_) acc.slot_of.resize(widest_, -1);
  }
}

void VcyclePreconditioner::finish_structure(const StepContext& ctx) {
  const ClothMesh& mesh = ctx.mesh;
  // Sized, not zeroed: the level's values are all written by factor()'s row pass.
  levels_.front().a.value.resize(9 * levels_.front().a.col.size());
  // Lattice spacings 2, 4, 8, ...: a spacing that would remove less than a fifth of a
  // level's nodes (a coarse region's leaves are coarser) makes no level; the next one is
  // tried from the same level.
  if (node_at_.size() != static_cast<std::size_t>(mesh.slot_count())) {
    node_at_.assign(static_cast<std::size_t>(mesh.slot_count()), -1);
  }
  int k = 0;
  for (int s = 2;; s *= 2) {
    const Coarsening made = coarsen(ctx, k, s, node_at_);
    if (made == Coarsening::coarsest) break;
    if (made == Coarsening::level) ++k;
  }
  widest_ = 0;
  for (std::size_t l = 0; l < levels_.size(); ++l) {
    Level& level = levels_[l];
    const std::size_t rows = 3 * level.i.size();
    level.x.assign(rows, 0.0);
    level.b.assign(rows, 0.0);
    level.res.assign(rows, 0.0);
    level.scratch.assign(rows, 0.0);
    if (l > 0) widest_ = std::max(widest_, level.i.size());
  }
  accumulators_.clear();
  spare_levels_.clear();  // levels this structure does not have
  for (std::vector<std::int64_t>& arena : arenas_) std::vector<std::int64_t>().swap(arena);
  topology_.take(mesh);
  bending_.swap(bending_now_);
  structure_coarsest_ = coarsest_nodes_;
}

void VcyclePreconditioner::factor(LoopRunner& run, const StepContext& ctx,
                                  const ModelHessian& hessian) {
  // Is the structure still this model's? Which triples bend, and the mesh's topology against
  // the structure's, compared block by block of slots in parallel.
  const ClothMesh& mesh = ctx.mesh;
  const std::int64_t check_blocks = (mesh.slot_count() + kCheckSlots - 1) / kCheckSlots;
#pragma omp single
  {
    const double started = omp_get_wtime();
    ++factorisations_;
    bending_now_.resize(static_cast<std::size_t>(check_blocks));
    changed_.assign(static_cast<std::size_t>(check_blocks), 0);
    comparable_ = topology_.same_extent(mesh) && structure_coarsest_ == coarsest_nodes_ &&
                  bending_.size() == bending_now_.size();
    sequential_seconds_ += omp_get_wtime() - started;
  }
  // Per slot: the mesh's topology bytes, and per element id the model's bending coefficient;
  // per block two digests read and one written.
  const LoopBytes check_bytes{
      .read = kCheckSlots * (TopologyKey::kMeshBytesPerSlot + 2 * bytes::kFloat) + 16.0,
      .written = 9.0};
  run.for_index(check_blocks, check_bytes, [&](std::int64_t block) {
    const std::int64_t begin = block * kCheckSlots;
    const std::int64_t end = std::min(mesh.slot_count(), begin + kCheckSlots);
    // Which of the block's triples bend, as one byte per element id, digested.
    thread_local std::vector<std::uint8_t> bends;
    bends.resize(static_cast<std::size_t>(2 * (end - begin)));
    for (std::int64_t id = 2 * begin; id < 2 * end; ++id) {
      bends[static_cast<std::size_t>(id - 2 * begin)] = hessian.bends(id) ? 1 : 0;
    }
    const auto b = static_cast<std::size_t>(block);
    bending_now_[b] = digest_bytes(bends.data(), bends.size(), static_cast<std::uint64_t>(block));
    const bool changed = comparable_ && bending_[b] != bending_now_[b];
    changed_[block] = changed || !comparable_ || !topology_.matches_slots(mesh, begin, end);
  });
#pragma omp single
  {
    const double started = omp_get_wtime();
    new_structure_ = std::find(changed_.begin(), changed_.end(), 1) != changed_.end();
    if (new_structure_) {
      begin_structure(ctx);
    } else {
      size_accumulators();
    }
    sequential_seconds_ += omp_get_wtime() - started;
  }  // the single's barrier publishes the levels and new_structure_
  if (new_structure_) {
    level0_pattern(run, ctx, hessian);
#pragma omp single
    {
      const double started = omp_get_wtime();
      finish_structure(ctx);
      size_accumulators();
      sequential_seconds_ += omp_get_wtime() - started;
    }
  }
  const bool pattern = new_structure_;
  // Level 0's values, row by row (ModelHessian::sum_row).
  {
    BlockRows& a = levels_.front().a;
    const std::size_t rows = a.start.size() - 1;
    // Per row: its slot and unknown, the particle's model data (ModelHessian::kRowRead) and
    // the row's columns read; its blocks written.
    const auto blocks = static_cast<double>(a.col.size());
    const LoopBytes row_bytes{
        .read = 2 * vcycle_bytes::kOffset + ModelHessian::kRowRead +
                vcycle_bytes::per_index(vcycle_bytes::kOffset * blocks, rows),
        .written = vcycle_bytes::per_index(9 * vcycle_bytes::entry_bytes(a.value) * blocks, rows)};
    run.for_index(static_cast<std::int64_t>(rows), row_bytes, [&](std::int64_t row) {
      // Summed in double, stored rounded to float.
      thread_local std::vector<double> sums;
      const std::int64_t count = a.start[row + 1] - a.start[row];
      sums.resize(static_cast<std::size_t>(9 * count));
      hessian.sum_row(ctx, unknown_, slot_of_node_[row], a.col.data() + a.start[row], count,
                      sums.data());
      store_rounded(sums.data(), 9 * count, a.value.data() + 9 * a.start[row]);
    });
  }
  // The Galerkin products level by level, each coarse row on its own.
  for (std::size_t k = 0; k + 1 < levels_.size(); ++k) {
    const std::int64_t rows = static_cast<std::int64_t>(levels_[k + 1].i.size());
    if (pattern) {
#pragma omp single
      row_cols_.resize(static_cast<std::size_t>(rows));
    }
    auto rows_of = [&](bool columns) {
      const LoopBytes row_bytes = vcycle_bytes::galerkin(levels_[k], levels_[k + 1], !columns);
      run.for_index(rows, row_bytes, [&](std::int64_t row) {
        galerkin_row(k, row, accumulators_[static_cast<std::size_t>(omp_get_thread_num())],
                     columns);
      });
    };
    if (pattern) {
      // A new structure: the rows' columns first, then the values in place (no copy of the
      // values outside the level: at 1001^2 that copy was a quarter of the peak memory).
      rows_of(true);
      BlockRows& a = levels_[k + 1].a;
#pragma omp single
      {
        const double started = omp_get_wtime();
        a.start.assign(static_cast<std::size_t>(rows) + 1, 0);
        for (std::int64_t row = 0; row < rows; ++row) {
          a.start[row + 1] = a.start[row] + static_cast<std::int64_t>(row_cols_[row].size());
        }
        a.col.resize(static_cast<std::size_t>(a.start.back()));
        a.value.resize(9 * a.col.size());
        sequential_seconds_ += omp_get_wtime() - started;
      }
      // Each row's columns into place (the row's values are written by the pass below).
      run.for_index(rows,
                    {.read = vcycle_bytes::per_index(
                         vcycle_bytes::kOffset * static_cast<double>(a.col.size()),
                         static_cast<std::size_t>(rows)),
                     .written = vcycle_bytes::per_index(
                         vcycle_bytes::kOffset * static_cast<double>(a.col.size()),
                         static_cast<std::size_t>(rows))},
                    [&](std::int64_t row) {
                      std::vector<std::int64_t>& cols = row_cols_[row];
                      std::copy(cols.begin(), cols.end(), a.col.begin() + a.start[row]);
                      std::vector<std::int64_t>().swap(cols);
                    });
    }
    rows_of(false);
  }
  if (pattern) {
    // The lines of every smoothed level: their nodes in order on one thread, then each line's
    // width and the lines before it that it couples to, by lines (colour_lines below).
#pragma omp single
    {
      const double started = omp_get_wtime();
      for (std::size_t k = 0; k + 1 < levels_.size(); ++k) {
        for (int d = 0; d < 2; ++d) order_lines(levels_[k], d);
      }
      sequential_seconds_ += omp_get_wtime() - started;
    }
    for (std::size_t k = 0; k + 1 < levels_.size(); ++k) {
      for (int d = 0; d < 2; ++d) {
        Level& level = levels_[k];
        run.for_index(static_cast<std::int64_t>(level.lines[d].width.size()),
                      vcycle_bytes::line_couplings(level, d),
                      [&](std::int64_t line) { couple_line(level, d, line); });
      }
    }
  }
#pragma omp single
  {
    const double started = omp_get_wtime();
    if (pattern) {
      for (std::size_t k = 0; k + 1 < levels_.size(); ++k) {
        for (int d = 0; d < 2; ++d) colour_lines(levels_[k], d);
      }
    }
    direct_ready_ = false;
    if (!levels_.back().i.empty()) {
      // The coarsest pattern holds every block the topology allows (zeros included), so its
      // ordering is made once a structure.
      const Eigen::SparseMatrix<double> coarsest =
          level_operator(static_cast<int>(levels_.size()) - 1);
      if (pattern) direct_.analyzePattern(coarsest);
      direct_.factorize(coarsest);
      direct_ready_ = direct_.info() == Eigen::Success;
      if (!direct_ready_) ++failures_;
    }
    sequential_seconds_ += omp_get_wtime() - started;
  }
  // Every line of every smoothed level, a loop per level and direction.
  for (std::size_t k = 0; k + 1 < levels_.size(); ++k) {
    for (int d = 0; d < 2; ++d) {
      Level& level = levels_[k];
      run.for_index(static_cast<std::int64_t>(level.lines[d].start.size()) - 1,
                    vcycle_bytes::line_factor(level, d),
                    [&](std::int64_t line) { factor_line(level, d, line); });
    }
  }
#pragma omp single
  {
    for (std::size_t k = 0; k + 1 < levels_.size(); ++k) {
      for (const Lines& l : levels_[k].lines) {
        for (const std::uint8_t ok : l.ok) failures_ += ok == 0 ? 1 : 0;
      }
    }
  }
}

}  // namespace clothbench::kernels
