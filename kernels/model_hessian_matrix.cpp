// The model Hessian as an explicit sparse matrix (see model_hessian.hpp): the same terms as
// ModelHessian::apply, assembled element by element into 3x3 blocks between nodes, each node
// expanded to the unknowns it follows (a free particle: itself; a ghost: half of each parent,
// recursively; a pinned particle: nothing, its entries of v are zero).
#include <Eigen/SparseCore>
#include <algorithm>
#include <utility>
#include <vector>

#include "kernels/ghost_nodes.hpp"
#include "kernels/model_hessian.hpp"
#include "kernels/potential_elements.hpp"

namespace clothbench::kernels {

namespace {

/// (unknown, weight) pairs a node's value follows.
void expand(const ClothMesh& mesh, const std::vector<std::int64_t>& unknown_of_slot,
            std::int64_t node, double weight, std::vector<std::pair<std::int64_t, double>>& out) {
  const int d = ghost_direction(mesh.flags[node]);
  if (d >= 0) {
    const std::int64_t id = element_id(node, d);
    expand(mesh, unknown_of_slot, mesh.prev[id], 0.5 * weight, out);
    expand(mesh, unknown_of_slot, mesh.next[id], 0.5 * weight, out);
    return;
  }
  if (unknown_of_slot[node] >= 0) out.emplace_back(unknown_of_slot[node], weight);
}

/// The unknowns a node's value follows (expand() without the weights), appended to `out`.
void expand_unknowns(const ClothMesh& mesh, const std::vector<std::int64_t>& unknown_of_slot,
                     std::int64_t node, std::vector<std::int64_t>& out) {
  const int d = ghost_direction(mesh.flags[node]);
  if (d >= 0) {
    const std::int64_t id = element_id(node, d);
    expand_unknowns(mesh, unknown_of_slot, mesh.prev[id], out);
    expand_unknowns(mesh, unknown_of_slot, mesh.next[id], out);
    return;
  }
  if (unknown_of_slot[node] >= 0) out.push_back(unknown_of_slot[node]);
}

/// K_e = alpha u u^T + beta (I - u u^T) of edge id at the current positions; false for an
/// edge of zero length.
bool edge_stiffness(const ClothMesh& mesh, const ClothState& st, std::int64_t id, double alpha,
                    double beta, Eigen::Matrix3d& k) {
  const Eigen::Vector3d e = vec3(st.position, mesh.next[id]) - vec3(st.position, element_slot(id));
  const double l = e.norm();
  if (!(l > 0.0)) return false;
  const Eigen::Vector3d u = e / l;
  k = beta * Eigen::Matrix3d::Identity() + (alpha - beta) * u * u.transpose();
  return true;
}

/// What a triple's blocks need (ModelHessian::bending_block): the turning vector's Jacobians
/// by the triple's nodes (previous, centre, next), the nodes, and the unit turning vector.
struct TripleJacobians {
  Eigen::Matrix3d j[3];
  std::int64_t node[3];
  Eigen::Vector3d turning;  ///< (e2/|e2| - e1/|e1|) normalised; unset at a straight triple
  bool straight = true;     ///< the arms are parallel: the turning vector has no direction
  [[nodiscard]] const Eigen::Vector3d* turning_or_null() const {
    return straight ? nullptr : &turning;
  }
};

/// Fills `t` for triple id; false when an arm has zero length.
bool triple_jacobians(const ClothMesh& mesh, const ClothState& st, std::int64_t id,
                      TripleJacobians& t) {
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  t.node[0] = mesh.prev[id];
  t.node[1] = element_slot(id);
  t.node[2] = mesh.next[id];
  const Eigen::Vector3d e1 = vec3(st.position, t.node[1]) - vec3(st.position, t.node[0]);
  const Eigen::Vector3d e2 = vec3(st.position, t.node[2]) - vec3(st.position, t.node[1]);
  const double n1 = e1.norm(), n2 = e2.norm();
  if (!(n1 > 0.0 && n2 > 0.0)) return false;
  const Eigen::Vector3d u1 = e1 / n1, u2 = e2 / n2;
  t.j[0] = (identity - u1 * u1.transpose()) / n1;
  t.j[2] = (identity - u2 * u2.transpose()) / n2;
  t.j[1] = -(t.j[0] + t.j[2]);
  t.turning = u2 - u1;
  const double length = t.turning.norm();
  t.straight = !(length > 0.0);
  if (!t.straight) t.turning /= length;
  return true;
}

/// Calls edge(r, w, id) and triple(r, w, id) for every element touching node r, then for
/// every ghost hanging on r, recursively, at half the weight w: the terms of node r's row
/// (ModelHessian::sum_row, ModelHessian::row_pattern).
template <class Edge, class Triple>
void for_each_row_element(const ClothMesh& mesh, std::int64_t r, double w, const Edge& edge,
                          const Triple& triple) {
  for_each_element_at(
      mesh, r, [&](std::int64_t id) { edge(r, w, id); },
      [&](std::int64_t id) { triple(r, w, id); });
  for_each_ghost_child(mesh, r, [&](std::int64_t child) {
    for_each_row_element(mesh, child, 0.5 * w, edge, triple);
  });
}

}  // namespace

std::vector<std::int64_t> free_unknowns(const StepContext& ctx, std::int64_t* count) {
  std::vector<std::int64_t> index(static_cast<std::size_t>(ctx.mesh.slot_count()), -1);
  std::int64_t n = 0;
  ctx.mesh.for_each_slot_in_grid_rows([&](std::int64_t s) {
    if (ctx.is_free(s)) index[s] = n++;
  });
  if (count != nullptr) *count = n;
  return index;
}

Eigen::SparseMatrix<double> ModelHessian::matrix(const StepContext& ctx,
                                                 const std::vector<std::int64_t>& unknown_of_slot,
                                                 std::int64_t unknowns) const {
  std::vector<Eigen::Triplet<double>> triplets;
  for_each_unknown_block(ctx, unknown_of_slot,
                         [&](std::int64_t row, std::int64_t col, const double* block) {
                           for (int r = 0; r < 3; ++r) {
                             for (int c = 0; c < 3; ++c) {
                               const double value = block[3 * r + c];
                               if (value != 0.0)
                                 triplets.emplace_back(3 * row + r, 3 * col + c, value);
                             }
                           }
                         });
  Eigen::SparseMatrix<double> m(3 * unknowns, 3 * unknowns);
  m.setFromTriplets(triplets.begin(), triplets.end());
  return m;
}

void ModelHessian::for_each_unknown_block(const StepContext& ctx,
                                          const std::vector<std::int64_t>& unknown_of_slot,
                                          const BlockVisitor& visit, bool structure) const {
  const ClothMesh& mesh = ctx.mesh;
  const ClothState& st = ctx.state;
  std::vector<std::pair<std::int64_t, double>> rows, cols;
  double scaled[9];
  // Block B between nodes r and s, expanded to the unknowns on both sides.
  auto add = [&](std::int64_t r, std::int64_t s, const Eigen::Matrix3d& block) {
    rows.clear();
    cols.clear();
    expand(mesh, unknown_of_slot, r, 1.0, rows);
    expand(mesh, unknown_of_slot, s, 1.0, cols);
    for (const auto& [i, wi] : rows) {
      for (const auto& [j, wj] : cols) {
        for (int a = 0; a < 3; ++a) {
          for (int c = 0; c < 3; ++c) scaled[3 * a + c] = wi * wj * block(a, c);
        }
        visit(i, j, scaled);
      }
    }
  };
  if (structure) {
    const Eigen::Matrix3d zero = Eigen::Matrix3d::Zero();
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      if (unknown_of_slot[s] >= 0) add(s, s, zero);
    }
    for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
      if (mesh.edge_active[id]) {
        const std::int64_t node[2] = {element_slot(id), mesh.next[id]};
        for (const std::int64_t r : node) {
          for (const std::int64_t q : node) add(r, q, zero);
        }
      }
      if (mesh.triple_active[id] && bending_[id] > 0.0) {
        const std::int64_t node[3] = {mesh.prev[id], element_slot(id), mesh.next[id]};
        for (const std::int64_t r : node) {
          for (const std::int64_t q : node) add(r, q, zero);
        }
      }
    }
    return;
  }
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    if (unknown_of_slot[s] >= 0) add(s, s, particle_block(ctx, s));
  }
  const std::int64_t ids = 2 * mesh.slot_count();
  Eigen::Matrix3d k;
  TripleJacobians t;
  for (std::int64_t id = 0; id < ids; ++id) {
    if (mesh.edge_active[id] &&
        edge_stiffness(mesh, st, id, edge_[2 * id], edge_[2 * id + 1], k)) {
      const std::int64_t a = element_slot(id), b = mesh.next[id];
      add(a, a, k);
      add(b, b, k);
      add(a, b, -k);
      add(b, a, -k);
    }
    if (mesh.triple_active[id] && bending_[id] > 0.0 && triple_jacobians(mesh, st, id, t)) {
      const Eigen::Vector3d* turning = t.turning_or_null();
      for (int r = 0; r < 3; ++r) {
        for (int q = 0; q < 3; ++q) {
          add(t.node[r], t.node[q], bending_block(id, t.j[r], t.j[q], turning));
        }
      }
    }
  }
}

void ModelHessian::sum_row(const StepContext& ctx, const std::vector<std::int64_t>& unknown_of_slot,
                           std::int64_t s, const std::int64_t* cols, std::int64_t count,
                           double* values) const {
  const ClothMesh& mesh = ctx.mesh;
  const ClothState& st = ctx.state;
  thread_local std::vector<std::pair<std::int64_t, double>> expanded;
  std::fill(values, values + 9 * count, 0.0);
  // Block B from row node r (weight wr in this row) to node q, q expanded to its unknowns.
  auto add = [&](double wr, std::int64_t q, const Eigen::Matrix3d& block) {
    expanded.clear();
    expand(mesh, unknown_of_slot, q, 1.0, expanded);
    for (const auto& [j, wj] : expanded) {
      double* out = values + 9 * (std::lower_bound(cols, cols + count, j) - cols);
      const double w = wr * wj;
      for (int a = 0; a < 3; ++a) {
        for (int c = 0; c < 3; ++c) out[3 * a + c] += w * block(a, c);
      }
    }
  };
  add(1.0, s, particle_block(ctx, s));
  for_each_row_element(
      mesh, s, 1.0,
      [&](std::int64_t r, double wr, std::int64_t id) {
        Eigen::Matrix3d k;
        if (!edge_stiffness(mesh, st, id, edge_[2 * id], edge_[2 * id + 1], k)) return;
        add(wr, r, k);
        add(wr, r == element_slot(id) ? mesh.next[id] : element_slot(id), -k);
      },
      [&](std::int64_t r, double wr, std::int64_t id) {
        TripleJacobians t;
        if (!(bending_[id] > 0.0) || !triple_jacobians(mesh, st, id, t)) return;
        const int i = r == t.node[0] ? 0 : (r == t.node[1] ? 1 : 2);
        const Eigen::Vector3d* k = t.turning_or_null();
        for (int q = 0; q < 3; ++q) add(wr, t.node[q], bending_block(id, t.j[i], t.j[q], k));
      });
}

std::int64_t ModelHessian::row_pattern(const StepContext& ctx,
                                       const std::vector<std::int64_t>& unknown_of_slot,
                                       std::int64_t s, std::vector<std::int64_t>& cols) const {
  const ClothMesh& mesh = ctx.mesh;
  const std::size_t begin = cols.size();
  auto add = [&](std::int64_t q) { expand_unknowns(mesh, unknown_of_slot, q, cols); };
  add(s);
  for_each_row_element(
      mesh, s, 1.0,
      [&](std::int64_t r, double, std::int64_t id) {
        add(r);
        add(r == element_slot(id) ? mesh.next[id] : element_slot(id));
      },
      [&](std::int64_t, double, std::int64_t id) {
        if (!(bending_[id] > 0.0)) return;
        add(mesh.prev[id]);
        add(element_slot(id));
        add(mesh.next[id]);
      });
  const auto first = cols.begin() + static_cast<std::ptrdiff_t>(begin);
  std::sort(first, cols.end());
  cols.erase(std::unique(first, cols.end()), cols.end());
  return static_cast<std::int64_t>(cols.size() - begin);
}

}  // namespace clothbench::kernels
