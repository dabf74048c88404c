// Quadtree, mesh rewrite and warm starts of AMRC (see amrc.hpp).
#include "kernels/amrc.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "kernels/element_geometry.hpp"
#include "kernels/ghost_nodes.hpp"
#include "kernels/loop_runner.hpp"

namespace clothbench::kernels {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// AdaptiveMesh::carried_ per element id: the old triple's moment is recorded (triple_scratch),
// the old edge starting here is recorded (edge_scratch) with log2 of its span in the bits above.
constexpr std::uint8_t kCarriedTriple = 1;
constexpr std::uint8_t kCarriedEdge = 2;
constexpr int kSpanShift = 2;
// The largest turning angle at a slot is kept at triple_breakpoints[kAngleStride * slot], the
// first of the slot's own four breakpoints.
constexpr std::int64_t kAngleStride = 4;

/// How a grid point relates to the leaves around it.
struct PointKind {
  bool node = false;   ///< a corner of at least one leaf
  bool ghost = false;  ///< ... and inside a side of another (coarser) leaf
  int ghost_direction = -1;
};

/// The tree views a grid point: the up to four finest cells around (i, j).
template <class Leaf>
PointKind classify(const Leaf& leaf, int cells_i, int cells_j, int i, int j) {
  PointKind kind;
  bool all_corners = true;
  for (int fi = i - 1; fi <= i; ++fi) {
    for (int fj = j - 1; fj <= j; ++fj) {
      if (fi < 0 || fj < 0 || fi >= cells_i || fj >= cells_j) continue;
      const int mask = (1 << leaf(fi, fj)) - 1;
      const bool on_row = (i & mask) == 0, on_column = (j & mask) == 0;
      if (on_row && on_column) {
        kind.node = true;
      } else {
        all_corners = false;
        // Inside a side of this leaf: a row side (constant i) runs along j (d = 1).
        if (on_row) kind.ghost_direction = 1;
        if (on_column) kind.ghost_direction = 0;
      }
    }
  }
  kind.ghost = kind.node && !all_corners;
  if (!kind.ghost) kind.ghost_direction = -1;
  return kind;
}

}  // namespace

AdaptiveMesh::AdaptiveMesh(const ClothMesh& mesh, int levels)
    : levels_(levels), cells_i_(mesh.size_i() - 1), cells_j_(mesh.size_j() - 1) {
  const int stride = 1 << std::max(levels, 0);
  if (levels < 1 || levels > 16 || cells_i_ % stride != 0 || cells_j_ % stride != 0) {
    throw std::invalid_argument("AdaptiveMesh: " + std::to_string(mesh.size_i()) + " x " +
                                std::to_string(mesh.size_j()) + " particles is not 2^" +
                                std::to_string(levels) + " n + 1 with 1 <= L <= 16");
  }
  leaf_.assign(static_cast<std::size_t>(cells_i_) * cells_j_, 0);
  old_leaf_.assign(leaf_.size(), 0);
  carried_.assign(2 * static_cast<std::size_t>(mesh.slot_count()), 0);
}

bool AdaptiveMesh::is_leaf(const TreeCell& c) const {
  const int fi = c.ci << c.level, fj = c.cj << c.level;
  if (c.level < 0 || c.level > levels_ || fi < 0 || fj < 0 || fi >= cells_i_ || fj >= cells_j_) {
    return false;
  }
  return leaf_level(fi, fj) == c.level;
}

void AdaptiveMesh::set_cell(const TreeCell& c, int level) {
  const int size = 1 << c.level;
  for (int fi = c.ci * size; fi < (c.ci + 1) * size; ++fi) {
    std::fill_n(leaf_.begin() + static_cast<std::ptrdiff_t>(fi) * cells_j_ + c.cj * size, size,
                static_cast<std::uint8_t>(level));
  }
}

std::int64_t AdaptiveMesh::refine(const TreeCell& c) {
  if (c.level < 1 || !is_leaf(c)) return 0;
  set_cell(c, c.level - 1);
  std::int64_t split = 1;
  // The children (level k - 1) tolerate neighbours up to level k: split coarser ones. A
  // coarser neighbour covers a whole side, so one finest cell per side identifies it.
  const int k = c.level, size = 1 << k;
  const int fi0 = c.ci * size, fj0 = c.cj * size;
  const int probes[4][2] = {{fi0 - 1, fj0}, {fi0 + size, fj0}, {fi0, fj0 - 1}, {fi0, fj0 + size}};
  for (const auto& p : probes) {
    if (p[0] < 0 || p[1] < 0 || p[0] >= cells_i_ || p[1] >= cells_j_) continue;
    const int level = leaf_level(p[0], p[1]);
    if (level > k) split += refine(TreeCell{level, p[0] >> level, p[1] >> level});
  }
  return split;
}

bool AdaptiveMesh::coarsen(const TreeCell& c, const ClothMesh& mesh) {
  if (c.level < 1 || c.level > levels_) return false;
  const int k = c.level, size = 1 << k, half = size / 2;
  const int fi0 = c.ci * size, fj0 = c.cj * size;
  if (fi0 + size > cells_i_ || fj0 + size > cells_j_) return false;
  for (int a = 0; a < 2; ++a) {
    for (int b = 0; b < 2; ++b) {
      if (!is_leaf(TreeCell{k - 1, 2 * c.ci + a, 2 * c.cj + b})) return false;
    }
  }
  // 2:1 balance after the merge: every leaf across a side must be of level >= k - 1.
  for (int t = 0; t < size; ++t) {
    const int probes[4][2] = {
        {fi0 - 1, fj0 + t}, {fi0 + size, fj0 + t}, {fi0 + t, fj0 - 1}, {fi0 + t, fj0 + size}};
    for (const auto& p : probes) {
      if (p[0] < 0 || p[1] < 0 || p[0] >= cells_i_ || p[1] >= cells_j_) continue;
      if (leaf_level(p[0], p[1]) < k - 1) return false;
    }
  }
  // A pinned or forced particle must stay active: the centre and side midpoints would not.
  const int points[5][2] = {{fi0 + half, fj0 + half},
                            {fi0, fj0 + half},
                            {fi0 + size, fj0 + half},
                            {fi0 + half, fj0},
                            {fi0 + half, fj0 + size}};
  for (const auto& p : points) {
    if (mesh.flags[mesh.slot(p[0], p[1])] & (kParticlePinned | kParticleForced)) return false;
  }
  set_cell(c, k);
  return true;
}

std::int64_t AdaptiveMesh::refine_to_particle(int i, int j) {
  std::int64_t split = 0;
  for (bool changed = true; changed;) {
    changed = false;
    for (int fi = i - 1; fi <= i; ++fi) {
      for (int fj = j - 1; fj <= j; ++fj) {
        if (fi < 0 || fj < 0 || fi >= cells_i_ || fj >= cells_j_) continue;
        const int level = leaf_level(fi, fj), mask = (1 << level) - 1;
        if ((i & mask) == 0 && (j & mask) == 0) continue;  // (i, j) is a corner of this leaf
        split += refine(TreeCell{level, fi >> level, fj >> level});
        changed = true;
      }
    }
  }
  return split;
}

bool AdaptiveMesh::balanced() const {
  for (int fi = 0; fi < cells_i_; ++fi) {
    for (int fj = 0; fj < cells_j_; ++fj) {
      const int level = leaf_level(fi, fj);
      if (fi + 1 < cells_i_ && std::abs(level - leaf_level(fi + 1, fj)) > 1) return false;
      if (fj + 1 < cells_j_ && std::abs(level - leaf_level(fi, fj + 1)) > 1) return false;
    }
  }
  return true;
}

std::vector<TreeCell> AdaptiveMesh::leaves() const {
  std::vector<TreeCell> out;
  for (int k = levels_; k >= 0; --k) {
    for (int ci = 0; ci < (cells_i_ >> k); ++ci) {
      for (int cj = 0; cj < (cells_j_ >> k); ++cj) {
        if (is_leaf(TreeCell{k, ci, cj})) out.push_back(TreeCell{k, ci, cj});
      }
    }
  }
  return out;
}

void AdaptiveMesh::write_mesh(ClothMesh& mesh) const {
  const int size_i = mesh.size_i(), size_j = mesh.size_j();
  auto leaf = [&](int fi, int fj) { return static_cast<int>(leaf_level(fi, fj)); };

  // 1. Node flags (pinned and forced bits are kept: coarsen() never deactivates such a
  // particle, and refinement never turns a particle into a ghost).
  std::int64_t ghosts = 0;
#pragma omp parallel for schedule(static) reduction(+ : ghosts)
  for (int i = 0; i < size_i; ++i) {
    for (int j = 0; j < size_j; ++j) {
      const std::int32_t s = mesh.slot(i, j);
      const PointKind kind = classify(leaf, cells_i_, cells_j_, i, j);
      std::uint8_t f = mesh.flags[s] & (kParticlePinned | kParticleForced);
      if (kind.ghost) {
        f = static_cast<std::uint8_t>(kParticleGhost |
                                      (kind.ghost_direction == 0 ? kGhostAlongI : kGhostAlongJ));
        ++ghosts;
      } else if (kind.node) {
        f |= kParticleActive;
      }
      mesh.flags[s] = f;
    }
  }
  mesh.set_ghost_count(ghosts);

  // 2. Neighbours and edges. A segment from a node along d is an edge when its grid line is a
  // side of a leaf next to the segment's first finest step; the edge runs to the next node.
  // Its width is half of each adjacent leaf's size across the line.
  const double h[2] = {mesh.spacing(0), mesh.spacing(1)};
#pragma omp parallel for schedule(static)
  for (int i = 0; i < size_i; ++i) {
    for (int j = 0; j < size_j; ++j) {
      const std::int32_t s = mesh.slot(i, j);
      const bool node = is_node(mesh.flags[s]);
      for (int d = 0; d < 2; ++d) {
        const std::int64_t id = element_id(s, d);
        mesh.next[id] = -1;
        mesh.prev[id] = -1;
        mesh.edge_active[id] = 0;
        mesh.edge_rest[id] = mesh.edge_width[id] = 0.0f;
        if (!node) continue;
        const int along = d == 0 ? i : j, across = d == 0 ? j : i;
        const int length = d == 0 ? size_i : size_j, cells_across = d == 0 ? cells_j_ : cells_i_;
        auto point = [&](int a) { return d == 0 ? mesh.slot(a, across) : mesh.slot(across, a); };
        auto cell_level = [&](int a, int c) { return d == 0 ? leaf(a, c) : leaf(c, a); };
        // Leaves beside the finest segment [a, a+1] of the line: widths they give (in cells).
        auto line_width = [&](int a, double* width) {
          bool on_line = false;
          double w = 0.0;
          for (int c = across - 1; c <= across; ++c) {
            if (c < 0 || c >= cells_across) continue;
            const int level = cell_level(a, c);
            if ((across & ((1 << level) - 1)) == 0) {
              on_line = true;
              w += 0.5 * (1 << level);
            }
          }
          if (width != nullptr) *width = w;
          return on_line;
        };
        double width = 0.0;
        if (along + 1 < length && line_width(along, &width)) {
          int a = along + 1;
          while (a + 1 < length && !is_node(mesh.flags[point(a)])) ++a;
          mesh.next[id] = point(a);
          mesh.edge_active[id] = 1;
          mesh.edge_rest[id] = static_cast<float>((a - along) * h[d]);
          mesh.edge_width[id] = static_cast<float>(width * h[1 - d]);
        }
        if (along > 0 && line_width(along - 1, nullptr)) {
          int a = along - 1;
          while (a > 0 && !is_node(mesh.flags[point(a)])) --a;
          mesh.prev[id] = point(a);
        }
      }
    }
  }

  // 3. Triples (centred on active particles with a node on both sides) and masses: each
  // leaf's area in quarters to its corners, a ghost's share handed half to each parent.
  const double cell_area = h[0] * h[1] * mesh.areal_density();
#pragma omp parallel for schedule(static)
  for (int i = 0; i < size_i; ++i) {
    for (int j = 0; j < size_j; ++j) {
      const std::int32_t s = mesh.slot(i, j);
      const bool active = (mesh.flags[s] & kParticleActive) != 0;
      for (int d = 0; d < 2; ++d) {
        const std::int64_t id = element_id(s, d);
        const std::int32_t n = mesh.next[id], p = mesh.prev[id];
        const bool triple = active && n >= 0 && p >= 0;
        mesh.triple_active[id] = triple ? 1 : 0;  // its rest spacing and width follow its edges
      }
      if (!active) {
        mesh.mass[s] = 0.0;
        continue;
      }
      auto own_quarters = [&](std::int64_t k) {
        const auto [pi, pj] = mesh.grid_of(k);
        double area = 0.0;
        for (int fi = pi - 1; fi <= pi; ++fi) {
          for (int fj = pj - 1; fj <= pj; ++fj) {
            if (fi < 0 || fj < 0 || fi >= cells_i_ || fj >= cells_j_) continue;
            const int level = leaf(fi, fj), mask = (1 << level) - 1;
            if ((pi & mask) == 0 && (pj & mask) == 0) area += 0.25 * double(1 << level) * (1 << level);
          }
        }
        return Eigen::Vector3d(area, 0.0, 0.0);
      };
      mesh.mass[s] = cell_area * with_ghost_children(mesh, s, own_quarters).x();
    }
  }
}

void AdaptiveMesh::node_angles(const ClothMesh& mesh, const ClothState& state,
                               std::vector<double>& angle) const {
  const std::int64_t slots = mesh.slot_count();
#pragma omp parallel for schedule(static)
  for (std::int64_t s = 0; s < slots; ++s) {
    double largest = 0.0;
    for (int d = 0; d < 2; ++d) {
      const std::int64_t id = element_id(s, d);
      if (!mesh.triple_active[id]) continue;
      const Eigen::Vector3d xc = vec3(state.position, s);
      const Eigen::Vector3d e1 = xc - vec3(state.position, mesh.prev[id]);
      const Eigen::Vector3d e2 = vec3(state.position, mesh.next[id]) - xc;
      largest = std::max(largest, turning_angle<double>(e1, e2).theta);
    }
    // Read before written: a slot with no triple keeps an unused slot's page handed back
    // (slot_pages.hpp) with the system, as reading it maps no memory.
    double& out = angle[static_cast<std::size_t>(kAngleStride * s)];
    if (largest != 0.0 || out != 0.0) out = largest;
  }
}

Eigen::Vector3d AdaptiveMesh::interpolate(const ClothMesh& mesh,
                                          const std::vector<std::uint8_t>& leaf,
                                          const std::vector<double>& values, int i, int j) const {
  const int fi = std::min(i, cells_i_ - 1), fj = std::min(j, cells_j_ - 1);
  const int level = leaf[static_cast<std::size_t>(fi) * cells_j_ + fj], size = 1 << level;
  const int oi = (fi >> level) << level, oj = (fj >> level) << level;
  const double u = double(i - oi) / size, v = double(j - oj) / size;
  auto corner = [&](int a, int b) { return node_value(mesh, values, mesh.slot(oi + a, oj + b)); };
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  if ((1 - u) * (1 - v) != 0.0) value += (1 - u) * (1 - v) * corner(0, 0);
  if (u * (1 - v) != 0.0) value += u * (1 - v) * corner(size, 0);
  if (u * v != 0.0) value += u * v * corner(size, size);
  if ((1 - u) * v != 0.0) value += (1 - u) * v * corner(0, size);
  return value;
}

void AdaptiveMesh::interpolate_inactive(const ClothMesh& mesh, std::vector<double>& values) const {
  const int size_i = mesh.size_i(), size_j = mesh.size_j();
#pragma omp parallel for schedule(static)
  for (int i = 0; i < size_i; ++i) {
    for (int j = 0; j < size_j; ++j) {
      const std::int32_t s = mesh.slot(i, j);
      if (mesh.flags[s] & kParticleActive) continue;
      vec3(values, s) = interpolate(mesh, leaf_, values, i, j);
    }
  }
}

void AdaptiveMesh::carry_forces(const ClothMesh& mesh, ClothState& state) const {
  // What begin_change recorded before the mesh changed: at the id of each old edge its force
  // (edge_scratch) and span, at the id of each old triple its moment (triple_scratch); marked
  // in carried_. The old edge field of a finest segment (the segment from grid point (i, j)
  // to the next along d) is the force of the old edge that covers it - the nearest recorded
  // edge start behind it on the same line, if its span reaches - and NaN where there was none
  // (inside an old coarse cell); likewise the triple field is NaN where no old triple was.
  // Forces are per unit width, so merged elements take the mean and split ones inherit. An
  // element that is not active on the new mesh keeps a force of zero (written only over a
  // value that is not zero: its page, handed back while unused, stays with the system).
  // Nothing reads it there; the state is then the same whether pages went back or not.
  const std::vector<double>& edge_forces = state.edge_scratch;
  const std::vector<double>& triple_moments = state.triple_scratch;
  const int size_i = mesh.size_i(), size_j = mesh.size_j();
  const int reach = 1 << levels_;
  const auto edge_field = [&](int i, int j, int d) {
    const int di = d == 0 ? 1 : 0, dj = 1 - di;
    for (int t = 0; t < reach; ++t) {
      const int si = i - t * di, sj = j - t * dj;
      if (si < 0 || sj < 0) break;
      const std::int64_t id = element_id(mesh.slot(si, sj), d);
      const std::uint8_t mark = carried_[id];
      if (mark & kCarriedEdge) return t < (1 << (mark >> kSpanShift)) ? edge_forces[id] : kNaN;
    }
    return kNaN;
  };
  const auto triple_field = [&](std::int64_t id) {
    return carried_[id] & kCarriedTriple ? triple_moments[id] : kNaN;
  };
#pragma omp parallel for schedule(static)
  for (int i = 0; i < size_i; ++i) {
    for (int j = 0; j < size_j; ++j) {
      const std::int32_t s = mesh.slot(i, j);
      for (int d = 0; d < 2; ++d) {
        const std::int64_t id = element_id(s, d);
        const int di = d == 0 ? 1 : 0, dj = 1 - di;
        if (mesh.edge_active[id]) {
          const int span = d == 0 ? mesh.grid_i(mesh.next[id]) - i : mesh.grid_j(mesh.next[id]) - j;
          // Mean over the segments, looking further out on parallel lines for a segment that
          // was inside a coarse cell (no edge there before).
          double sum = 0.0, first = kNaN;
          int count = 0;
          bool uniform = true;
          for (int r = 0; r <= reach && count == 0; ++r) {
            for (int side = (r == 0 ? 1 : -1); side <= 1; side += 2) {
              const int ci = i + side * r * dj, cj = j + side * r * di;  // offset across the line
              if (ci < 0 || cj < 0 || ci >= size_i || cj >= size_j) continue;
              for (int t = 0; t < span; ++t) {
                const double f = edge_field(ci + t * di, cj + t * dj, d);
                if (std::isnan(f)) continue;
                if (count == 0) first = f;
                uniform = uniform && f == first;
                sum += f;
                ++count;
              }
            }
          }
          state.edge_force[id] = count == 0 ? 0.0 : uniform ? first : sum / count;
        } else if (state.edge_force[id] != 0.0) {
          state.edge_force[id] = 0.0;  // an element that is gone keeps no force (see above)
        }
        if (!mesh.triple_active[id] && state.triple_moment[id] != 0.0) {
          state.triple_moment[id] = 0.0;
        }
        if (mesh.triple_active[id]) {
          const double own = triple_field(id);
          if (!std::isnan(own)) {
            state.triple_moment[id] = own;
            continue;
          }
          // Linear between the nearest old triples on the same line, else the mean of the
          // nearest parallel lines' values at the same point.
          double value = 0.0;
          bool found = false;
          double near[2] = {kNaN, kNaN};
          int distance[2] = {0, 0};
          for (int side = 0; side < 2; ++side) {
            const int step = side == 0 ? -1 : 1;
            for (int t = 1; t <= reach; ++t) {
              const int pi = i + step * t * di, pj = j + step * t * dj;
              if (pi < 0 || pj < 0 || pi >= size_i || pj >= size_j) break;
              const double f = triple_field(element_id(mesh.slot(pi, pj), d));
              if (!std::isnan(f)) {
                near[side] = f;
                distance[side] = t;
                break;
              }
            }
          }
          if (!std::isnan(near[0]) && !std::isnan(near[1])) {
            value = (near[0] * distance[1] + near[1] * distance[0]) / (distance[0] + distance[1]);
            found = true;
          } else if (!std::isnan(near[0]) || !std::isnan(near[1])) {
            value = std::isnan(near[0]) ? near[1] : near[0];
            found = true;
          }
          for (int r = 1; r <= reach && !found; ++r) {
            double sum = 0.0;
            int count = 0;
            for (int side = -1; side <= 1; side += 2) {
              const int pi = i + side * r * dj, pj = j + side * r * di;
              if (pi < 0 || pj < 0 || pi >= size_i || pj >= size_j) continue;
              const double f = triple_field(element_id(mesh.slot(pi, pj), d));
              if (!std::isnan(f)) {
                sum += f;
                ++count;
              }
            }
            if (count > 0) {
              value = sum / count;
              found = true;
            }
          }
          state.triple_moment[id] = value;
        }
      }
    }
  }
}

void AdaptiveMesh::begin_change(const ClothMesh& mesh, ClothState& state) {
  // Fields of the old forces (see carry_forces) and the old tree.
  std::copy(leaf_.begin(), leaf_.end(), old_leaf_.begin());
  const std::int64_t slots = mesh.slot_count();
  // Written only at the ids of active elements (see carried_).
#pragma omp parallel for schedule(static)
  for (std::int64_t id = 0; id < 2 * slots; ++id) {
    std::uint8_t mark = 0;
    if (mesh.triple_active[id]) {
      state.triple_scratch[id] = state.triple_moment[id];
      mark |= kCarriedTriple;
    }
    if (mesh.edge_active[id]) {
      const std::int64_t s = element_slot(id);
      const std::int32_t n = mesh.next[id];
      const int span = element_direction(id) == 0 ? mesh.grid_i(n) - mesh.grid_i(s)
                                                  : mesh.grid_j(n) - mesh.grid_j(s);
      int log_span = 0;
      while ((1 << log_span) < span) ++log_span;
      state.edge_scratch[id] = state.edge_force[id];
      mark |= kCarriedEdge | static_cast<std::uint8_t>(log_span << kSpanShift);
    }
    carried_[id] = mark;
  }
}

void AdaptiveMesh::finish_change(ClothMesh& mesh, ClothState& state) {
  const std::int64_t slots = mesh.slot_count();
  // New particles and new ghosts start on the old interpolated surface, with the old
  // surface's interpolated velocity (x^n and x~ interpolated alike). Reads the old mesh.
  const int size_i = mesh.size_i(), size_j = mesh.size_j();
  auto new_leaf = [&](int fi, int fj) { return static_cast<int>(leaf_level(fi, fj)); };
#pragma omp parallel for schedule(static)
  for (int i = 0; i < size_i; ++i) {
    for (int j = 0; j < size_j; ++j) {
      const std::int32_t s = mesh.slot(i, j);
      if (mesh.flags[s] & kParticleActive) continue;
      if (!classify(new_leaf, cells_i_, cells_j_, i, j).node) continue;
      for (auto* v : {&state.position, &state.step_start, &state.target}) {
        vec3(*v, s) = interpolate(mesh, old_leaf_, *v, i, j);
      }
    }
  }
  write_mesh(mesh);
  carry_forces(mesh, state);
  // Ghosts (old and new) on the midpoints of their parents.
#pragma omp parallel for schedule(static)
  for (std::int64_t s = 0; s < slots; ++s) {
    if (!(mesh.flags[s] & kParticleGhost)) continue;
    for (auto* v : {&state.position, &state.step_start, &state.target}) {
      vec3(*v, s) = node_value(mesh, *v, s);
    }
  }
}

AmrcEvent AdaptiveMesh::run_event(int step, const AmrcConfig& config, ClothMesh& mesh,
                                  ClothState& state) {
  AmrcEvent event;
  event.step = step;
  const double t0 = monotonic_seconds();

  // Criterion: the largest turning angle of the triples at each node (state.triple_breakpoints
  // is per-step work space, recomputed when the next step begins; a slot's angle is kept where
  // its own breakpoints are, so the event writes no page of an unused slot).
  std::vector<double>& angle = state.triple_breakpoints;
  node_angles(mesh, state, angle);
  auto angle_at = [&](int i, int j) {
    return angle[static_cast<std::size_t>(kAngleStride * mesh.slot(i, j))];
  };
  std::vector<TreeCell> refine_cells, coarsen_cells;
  for (int k = 1; k <= levels_; ++k) {
    const int size = 1 << k, half = size / 2;
    for (int ci = 0; ci < (cells_i_ >> k); ++ci) {
      for (int cj = 0; cj < (cells_j_ >> k); ++cj) {
        const int i0 = ci * size, j0 = cj * size;
        const TreeCell cell{k, ci, cj};
        if (leaf_level(i0, j0) == k) {
          const double m = std::max({angle_at(i0, j0), angle_at(i0 + size, j0),
                                     angle_at(i0, j0 + size), angle_at(i0 + size, j0 + size)});
          if (m > config.refine_threshold) refine_cells.push_back(cell);
          continue;
        }
        bool children_leaves = true;
        for (int a = 0; a < 2 && children_leaves; ++a) {
          for (int b = 0; b < 2; ++b) {
            if (leaf_level(i0 + a * half, j0 + b * half) != k - 1) children_leaves = false;
          }
        }
        if (!children_leaves) continue;
        double m = 0.0;
        for (int a = 0; a <= 2; ++a) {
          for (int b = 0; b <= 2; ++b) m = std::max(m, angle_at(i0 + a * half, j0 + b * half));
        }
        if (m < config.coarsen_threshold) coarsen_cells.push_back(cell);
      }
    }
  }
  const double t1 = monotonic_seconds();
  event.criterion_seconds = t1 - t0;
  if (!refine_cells.empty() || !coarsen_cells.empty()) {
    begin_change(mesh, state);
    for (const TreeCell& c : refine_cells) event.refined += refine(c);
    for (const TreeCell& c : coarsen_cells) event.coarsened += coarsen(c, mesh) ? 1 : 0;
    finish_change(mesh, state);
  }
  const std::int64_t slots = mesh.slot_count();
  std::int64_t particles = 0, edges = 0, triples = 0;
#pragma omp parallel for schedule(static) reduction(+ : particles, edges, triples)
  for (std::int64_t s = 0; s < slots; ++s) {
    particles += (mesh.flags[s] & kParticleActive) ? 1 : 0;
    edges += mesh.edge_active[2 * s] + mesh.edge_active[2 * s + 1];
    triples += mesh.triple_active[2 * s] + mesh.triple_active[2 * s + 1];
  }
  event.particles = particles;
  event.edges = edges;
  event.triples = triples;
  event.ghosts = mesh.ghost_count();
  event.update_seconds = monotonic_seconds() - t1;
  return event;
}

}  // namespace clothbench::kernels
