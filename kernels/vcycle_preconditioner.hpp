// Multigrid V-cycle preconditioner of Newton's inner PCG on the AMRC tree (MODEL-NOTES.md,
// "V-cycle").
//
// Levels. Level 0 is the assembled model Hessian over the free particles. Level k+1 keeps the
// nodes of level k whose grid coordinates both lie on the lines of spacing 2^(k+1) (or on the
// grid's last line); every other node follows the kept nodes around it by the bilinear rule
// the AMRC warm start and the ghost midpoints use (linear weights by grid distance). So a level
// is the same quadtree with every leaf clamped to at least that level: in a coarse region of
// the cloth nothing changes until the level reaches its leaves. On level 0 a corner that is a
// ghost follows its parents; a pinned corner drops out (its correction is zero); a node whose
// corners are not all nodes is kept as a node of the next level, so every prolongation P_k
// holds an identity row per coarse node and has full column rank. The coarse operators are
// Galerkin products A_(k+1) = P_k^T A_k P_k, so they see the contact stiffness k n n^T that the
// model holds for particles in contact. The hierarchy stops when a level has at most
// kCoarsestNodes nodes (64) or nothing coarser exists; that level is solved directly (sparse
// LDL^T).
//
// Smoother. Alternating-direction line Gauss-Seidel: along each grid direction the nodes of a
// level form lines, and a line update solves the level's operator restricted to the line
// (its exact principal submatrix, banded: the bending triples couple nodes two apart) for the
// line's residual. Lines are coloured greedily in line order so that no two lines of a colour
// are coupled; the lines of a colour are updated in parallel, which is then the same as in any
// order. Before the coarse correction the sweep runs direction 0 then 1, colours ascending;
// after it the exact reverse. Each line update is an A-orthogonal projection, so the cycle
// with x = 0 to start is symmetric positive definite for any SPD model: a valid CG
// preconditioner on crumpled states in contact, where a Jacobi-type line smoother was not
// (multigrid_preconditioner.hpp).
//
// Every loop of the cycle and of its values (level 0 by rows, Galerkin rows, line
// factorisations, line updates, residuals, restriction, prolongation) goes through the
// LoopRunner and writes only its own entries; the hierarchy's structure (made again only when
// the topology changes) and the coarsest solve run on one thread. The result has the same bits
// on every scheduler and thread count.
#pragma once

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cstdint>
#include <memory>
#include <new>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "kernels/band_lines.hpp"
#include "kernels/loop_runner.hpp"
#include "kernels/model_hessian.hpp"
#include "kernels/step_context.hpp"
#include "kernels/topology_key.hpp"

namespace clothbench::kernels {

class VcyclePreconditioner {
 public:
  /// Slots a block of factor()'s check of the structure against the model (blocks run in
  /// parallel).
  static constexpr std::int64_t kCheckSlots = TopologyKey::kChunkSlots;

  /// A level this small (nodes) is solved directly.
  static constexpr std::int64_t kCoarsestNodes = 64;

  /// The size below which a level is solved directly (tests use small values to get several
  /// levels on small meshes); takes effect at the next factor().
  void set_coarsest_nodes(std::int64_t nodes) { coarsest_nodes_ = nodes; }

  /// Lines of one colour a smoothing task takes: 2 (the default: their band solves
  /// interleaved, kernels/band_lines.hpp) or 1. The bits are the same either way; the sweeps
  /// hand the scheduler twice as many, half as long tasks with 1 (clothbench-micro's
  /// `newton_operator/vcycle_apply_one_line` measures the two in one run). Throws
  /// std::invalid_argument for any other value.
  void set_lines_per_task(int lines) {
    if (lines != 1 && lines != 2) {
      throw std::invalid_argument("V-cycle lines per task must be 1 or 2, got " +
                                  std::to_string(lines));
    }
    lines_per_task_ = lines;
  }
  [[nodiscard]] int lines_per_task() const { return lines_per_task_; }

  /// Builds the hierarchy for the current model, then factorises every line of every level.
  /// The hierarchy's structure (level 0's nodes and pattern, the coarser levels and their
  /// prolongations, the Galerkin patterns, the lines and their colours, the coarsest level's
  /// ordering) depends only on the mesh's topology and on which triples have bending stiffness
  /// in the model: it is made again only when one of them differs from the last factor() (an
  /// AMRC event, a released pin, a triple leaving its plateau), else only the values are. The
  /// check (by blocks of slots), level 0's pattern (by rows, ModelHessian::row_pattern) and
  /// values (ModelHessian::sum_row), the Galerkin products and the placing of their columns
  /// (by coarse rows) and the line factorisations run through the LoopRunner; the coarser
  /// levels' nodes and prolongations, the lines and their colours, the row offsets and the
  /// coarsest factorisation on one thread. Every thread of the region calls it.
  void factor(LoopRunner& run, const StepContext& ctx, const ModelHessian& hessian);
  /// out = B r on the free particles (0 elsewhere): one V(1,1) cycle from zero. Every thread
  /// calls it; ends after a barrier.
  void apply(LoopRunner& run, const StepContext& ctx, std::span<const double> r,
             std::span<double> out);

  [[nodiscard]] int levels() const { return static_cast<int>(levels_.size()); }
  /// Nodes of level k (level 0: the free particles).
  [[nodiscard]] std::int64_t level_nodes(int k) const {
    return static_cast<std::int64_t>(levels_[static_cast<std::size_t>(k)].i.size());
  }
  /// Grid coordinates of the nodes of level k.
  [[nodiscard]] const std::vector<int>& node_i(int k) const {
    return levels_[static_cast<std::size_t>(k)].i;
  }
  [[nodiscard]] const std::vector<int>& node_j(int k) const {
    return levels_[static_cast<std::size_t>(k)].j;
  }
  /// Line colours of level k along direction d.
  [[nodiscard]] int colours(int k, int d) const {
    return static_cast<int>(levels_[static_cast<std::size_t>(k)].lines[d].colour_start.size()) - 1;
  }
  /// Operator of level k and the prolongation from level k+1 to k as scalar sparse matrices
  /// (3 rows and columns per node; tests).
  [[nodiscard]] Eigen::SparseMatrix<double> level_operator(int k) const;
  [[nodiscard]] Eigen::SparseMatrix<double> prolongation(int k) const;
  [[nodiscard]] std::int64_t factorisations() const { return factorisations_; }
  /// factor() calls that made the structure anew (the first, and one after every change of
  /// the mesh's topology).
  [[nodiscard]] std::int64_t structures() const { return structures_; }
  /// Wall time factor() spent on one thread (structures, the coarsest factorisation): the
  /// V-cycle's sequential share of a run.
  [[nodiscard]] double sequential_seconds() const { return sequential_seconds_; }
  /// Line or coarsest factorisations that found a non-positive pivot (the model was not SPD;
  /// the failing line or level is then left out of the cycle).
  [[nodiscard]] std::int64_t failures() const { return failures_; }

  [[nodiscard]] std::size_t memory_bytes() const;
  /// Bytes per slot (memory estimates): level 0's blocks (9 a row of 36 B + 8 B index, and
  /// its pattern while it is made), the line factors (two directions, 3 rows of 9 band
  /// entries) and line maps, four vectors, coordinates, P and P^T (4 weights a row); the
  /// coarser levels add about two thirds of that (a Galerkin row has up to 25 blocks;
  /// 2.37 kB a slot measured on a 129^2 sheet).
  /// Plus, a slot of the mesh, the unknown and the coarsening's node of every slot (the
  /// topology key and the bending digests take 8 bytes per kCheckSlots slots).
  static constexpr std::size_t kBytesPerSlot =
      (9 * 44 + 16 * 8 + 2 * 3 * 9 * 8 + 6 * 8 + 4 * 3 * 8 + 8 + 2 * (4 * 16 + 8)) * 5 / 3 + 8 + 4;

 private:
  /// A square matrix of 3x3 blocks by node: per row its blocks in column order.
  /// The blocks' entries are summed in double and stored rounded to float (each once): the
  /// cycle computes in double from them, so it is the symmetric V-cycle of the rounded
  /// operators, and a level's values take half the bytes (kernels/MODEL-NOTES.md, V-cycle,
  /// "Operators stored in single precision").
  /// std::allocator whose resize leaves new entries unset (default-initialised, not zeroed):
  /// for the arrays that a parallel pass fills entirely after they are sized (a level's
  /// columns and values), where a zeroing pass on one thread was the larger part of a new
  /// structure's sequential time.
  template <class T>
  struct UnsetAllocator : std::allocator<T> {
    using value_type = T;
    template <class U>
    struct rebind {
      using other = UnsetAllocator<U>;
    };
    UnsetAllocator() = default;
    template <class U>
    explicit UnsetAllocator(const UnsetAllocator<U>& /*other*/) noexcept {}
    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
      ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
      ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
  };
  template <class T>
  using UnsetVector = std::vector<T, UnsetAllocator<T>>;
  struct BlockRows {
    std::vector<std::int64_t> start;  ///< per row: first block (+ end)
    UnsetVector<std::int64_t> col;    ///< per block: its column node (placed by a parallel pass)
    UnsetVector<float> value;         ///< per block: 9 entries, row-major (summed in parallel)
  };
  /// Interpolation weights by node: per row the (node, weight) pairs it follows.
  struct Weights {
    std::vector<std::int64_t> start;
    std::vector<std::int64_t> node;
    std::vector<double> weight;
  };
  /// Nodes of one grid direction's lines: node order by (line, position), line ranges,
  /// line colours, band factor offsets and widths.
  struct Lines {
    std::vector<std::int64_t> order;         ///< node indices, line by line, in grid order
    std::vector<std::int64_t> start;         ///< per line: first entry of `order` (+ end)
    std::vector<std::int64_t> by_colour;     ///< line indices sorted by colour
    std::vector<std::int64_t> colour_start;  ///< per colour: first entry of `by_colour` (+ end)
    std::vector<std::int64_t> band_start;    ///< per line: offset into `band` (+ end)
    std::vector<int> width;                  ///< per line: scalar half-bandwidth
    std::vector<std::uint8_t> ok;            ///< per line: factorisation succeeded
    /// Lower band of each line's Cholesky factor, computed in double and stored rounded to
    /// float: the line solve L L^T of the rounded factor is still symmetric positive definite.
    std::vector<float> band;
    std::vector<std::int64_t> line_of;   ///< per node: its line
    std::vector<std::int64_t> position;  ///< per node: its position on the line
    /// While a structure is made: per line, the lines before it that it couples to.
    std::vector<std::vector<std::int64_t>> below;
  };
  struct Level {
    std::vector<int> i, j;  ///< grid coordinates of each node
    BlockRows a;            ///< the operator
    Weights p;              ///< per node of this level: the next level's nodes it follows
    Weights r;              ///< per node of the next level: this level's nodes (P^T)
    Lines lines[2];
    std::vector<double> x, b, res, scratch;  ///< 3 per node each
    /// Calls f on each of the level's vectors (Lines::below itself, not its inner vectors):
    /// the one list clear() and memory_bytes() both go through, so neither misses a member.
    template <class Self, class F>
    static void for_each_vector(Self& level, F&& f) {
      f(level.i);
      f(level.j);
      f(level.a.start);
      f(level.a.col);
      f(level.a.value);
      for (auto* w : {&level.p, &level.r}) {
        f(w->start);
        f(w->node);
        f(w->weight);
      }
      for (auto& l : level.lines) {
        f(l.order);
        f(l.start);
        f(l.by_colour);
        f(l.colour_start);
        f(l.band_start);
        f(l.width);
        f(l.ok);
        f(l.band);
        f(l.line_of);
        f(l.position);
        f(l.below);
      }
      f(level.x);
      f(level.b);
      f(level.res);
      f(level.scratch);
    }
    /// Empties every vector and keeps its capacity (a level taken from the spares).
    void clear();
  };
  /// Per thread: the Galerkin product's row accumulator.
  struct Accumulator {
    std::vector<std::int64_t> slot_of;  ///< per coarse node: its place in `cols`, or -1
    std::vector<std::int64_t> cols;
    std::vector<double> values;
    std::vector<std::int64_t> order;
  };

  /// Nodes ahead on a line whose rows the line kernels (line_residual, factor_line) prefetch: a
  /// row's blocks (up to 9 of 72 B at level 0, up to 25 on coarse levels) lie far from the
  /// last node's along a line of the second direction, and one node's work is too long for
  /// the out-of-order window to reach the next node's loads (kernels/MODEL-NOTES.md, "V-cycle",
  /// "Prefetching").
  static constexpr std::int64_t kPrefetchAhead = 2;
  /// Stores `count` entries summed in double as the float the levels keep (the one rounding of
  /// an operator entry or a line factor's entry).
  static void store_rounded(const double* sums, std::int64_t count, float* stored) {
    for (std::int64_t q = 0; q < count; ++q) stored[q] = static_cast<float>(sums[q]);
  }
  /// Asks the cache for the blocks of row `node` of `a` (no effect on results; prefetching its
  /// columns as well measured slower).
  static void prefetch_row(const BlockRows& a, std::int64_t node) {
    const std::int64_t first = a.start[node], count = a.start[node + 1] - first;
    const char* values = reinterpret_cast<const char*>(a.value.data() + 9 * first);
    constexpr std::int64_t kLine = 64;
    constexpr std::int64_t kBlock = 9 * sizeof(decltype(a.value)::value_type);
    for (std::int64_t at = 0; at < count * kBlock; at += kLine) __builtin_prefetch(values + at);
  }

  enum class Coarsening { level, too_few, coarsest };
  /// One thread: the nodes of level k on the lattice of spacing s (and those that cannot
  /// follow it) as level k + 1, with level k's prolongation; too_few when that would keep
  /// more than 4/5 of level k's nodes; coarsest when level k is small enough or nothing
  /// coarser exists.
  Coarsening coarsen(const StepContext& ctx, int k, int s, std::vector<std::int32_t>& node_at);
  /// A new structure in three parts. One thread: level 0's nodes (the free particles), its
  /// rows' offsets zeroed.
  void begin_structure(const StepContext& ctx);
  /// Every thread: level 0's pattern by rows (ModelHessian::row_pattern), each row's columns
  /// into its thread's arena, then, with the row offsets summed on one thread, into place.
  void level0_pattern(LoopRunner& run, const StepContext& ctx, const ModelHessian& hessian);
  /// One thread: the coarser levels and their prolongations, the levels' vectors; remembers
  /// the topology and bending triples they were made for.
  void finish_structure(const StepContext& ctx);
  /// One thread: a Galerkin accumulator per thread of the team, sized for the widest level.
  void size_accumulators();
  /// Row `row` of level k+1's operator P^T A P (one thread per row): its sorted columns into
  /// row_cols_ when `pattern` (a new structure), else its values into the level in place.
  void galerkin_row(std::size_t k, std::int64_t row, Accumulator& acc, bool pattern);
  /// The lines of a level along direction d in three parts. One thread: the nodes' order by
  /// line and position, the line ranges.
  void order_lines(Level& level, int d);
  /// One line (lines in parallel): its band width and the lines before it it couples to.
  void couple_line(Level& level, int d, std::int64_t line);
  /// One thread: greedy colours in line order, the band factor's offsets and storage.
  void colour_lines(Level& level, int d);
  /// A line's band from the operator's blocks between its nodes, factored (band::cholesky);
  /// its `ok` says whether it factored.
  void factor_line(Level& level, int d, std::int64_t line);
  /// The residual of a line's rows (the scratch's part of the line) at the current x.
  void line_residual(Level& level, int d, std::int64_t line);
  /// x += the line's solved correction (the scratch's part of the line).
  void line_correct(Level& level, int d, std::int64_t line);
  /// One block Gauss-Seidel update of two lines of one colour (line_b < 0: line_a alone),
  /// their band solves interleaved; a line whose factorisation failed is left as it is.
  void update_lines(Level& level, int d, std::int64_t line_a, std::int64_t line_b);
  void smooth(LoopRunner& run, Level& level, bool forward);
  void cycle(LoopRunner& run, std::size_t k);

  std::vector<Level> levels_;
  /// The last structure's levels, emptied with their capacity kept, handed out in level order
  /// to the next structure: buffers made anew for every structure cost their page faults
  /// each time (about 40 % of the set-up's time on paper/box-257, kernels/MODEL-NOTES.md).
  std::vector<Level> spare_levels_;
  /// An empty level: the next spare one (level k of the last structure when level k is
  /// made), or a new one.
  Level take_level();
  std::vector<std::int64_t> slot_of_node_;  ///< level 0 node -> slot
  std::vector<std::int64_t> unknown_;       ///< slot -> level 0 node, or -1
  std::vector<std::int32_t> node_at_;       ///< per grid point: coarsen()'s node there, -1 between
  TopologyKey topology_;                    ///< the mesh the structure was made for,
  /// Per check block, the digest of which of its triples have bending stiffness: the
  /// structure's, and the model's at the last check.
  std::vector<std::uint64_t> bending_, bending_now_;
  std::int64_t structure_coarsest_ = -1;             ///< and its coarsest size
  bool new_structure_ = false;                       ///< written in factor()'s check, read after it
  std::vector<std::uint8_t> changed_;      ///< per check block: the structure differs there
  bool comparable_ = false;                ///< a structure of this extent and coarsest size exists
  std::size_t widest_ = 0;                 ///< nodes of the largest coarse level (accumulators)
  std::vector<Accumulator> accumulators_;  ///< one per thread
  std::vector<std::vector<std::int64_t>> row_cols_;  ///< Galerkin columns before concatenation
  /// Level 0's pattern while it is made: per thread the columns of the rows it made, per row
  /// where they are.
  struct RowSource {
    int thread;
    std::int64_t at;
  };
  std::vector<std::vector<std::int64_t>> arenas_;
  std::vector<RowSource> row_source_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> direct_;
  bool direct_ready_ = false;
  Eigen::VectorXd coarse_b_, coarse_x_;
  std::int64_t coarsest_nodes_ = kCoarsestNodes;
  int lines_per_task_ = 2;
  std::int64_t factorisations_ = 0;
  std::int64_t structures_ = 0;
  double sequential_seconds_ = 0.0;
  std::int64_t failures_ = 0;
};

}  // namespace clothbench::kernels
