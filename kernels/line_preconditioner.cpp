// Line-solve preconditioner (see the header).
#include "kernels/line_preconditioner.hpp"

#include <Eigen/LU>

namespace clothbench::kernels {

namespace {

/// Symmetric 3x3 block stored as 6 doubles (xx xy xz yy yz zz) at `p`.
Eigen::Matrix3d load(const double* p) {
  Eigen::Matrix3d m;
  m << p[0], p[1], p[2], p[1], p[3], p[4], p[2], p[4], p[5];
  return m;
}
}  // namespace

LinePreconditioner::LinePreconditioner(const ClothMesh& mesh) {
  const auto slots = static_cast<std::size_t>(mesh.slot_count());
  diagonal_block.assign(6 * slots, 0.0);
  edge_block.assign(12 * slots, 0.0);
  pivot_inverse_.assign(12 * slots, 0.0);
  line_value_.assign(6 * slots, 0.0);
}

template <class F>
void LinePreconditioner::walk_line(const StepContext& ctx, int d, int line, F&& f) const {
  const ClothMesh& mesh = ctx.mesh;
  const int length = d == 0 ? mesh.size_i() : mesh.size_j();
  std::int64_t previous = -1;
  for (int p = 0; p < length; ++p) {
    const std::int64_t s = d == 0 ? mesh.slot(p, line) : mesh.slot(line, p);
    if (!ctx.is_free(s)) {
      if (is_node(mesh.flags[s])) previous = -1;  // a pin or a ghost breaks the line
      continue;
    }
    bool linked = false;
    if (previous >= 0) {
      const std::int64_t id = element_id(previous, d);
      linked = mesh.edge_active[id] != 0 && mesh.next[id] == s;
    }
    f(s, linked, previous);
    previous = s;
  }
}

namespace {
/// What walk_line reads per grid point: its slot, flags, and the link from the previous node
/// (its edge's flag and next).
constexpr double kWalkRead = 2 * bytes::kIndex + 2 * bytes::kFlag;
/// LoopBytes per grid line of direction d (loop_bytes.hpp): `per_node` for each of its points.
LoopBytes per_line(const ClothMesh& mesh, int d, LoopBytes per_node) {
  const double length = d == 0 ? mesh.size_i() : mesh.size_j();
  return {.read = length * per_node.read, .written = length * per_node.written};
}
}  // namespace

void LinePreconditioner::factor(LoopRunner& run, const StepContext& ctx) {
  const ClothMesh& mesh = ctx.mesh;
  for (int d = 0; d < 2; ++d) {
    // Per node: the walk, its diagonal block and the link's edge block read; its pivot
    // inverse written.
    const LoopBytes line_bytes =
        per_line(mesh, d, {.read = kWalkRead + 2 * bytes::kBlockD, .written = bytes::kBlockD});
    run.for_index(d == 0 ? mesh.size_j() : mesh.size_i(), line_bytes, [&](std::int64_t line) {
      Eigen::Matrix3d inverse = Eigen::Matrix3d::Zero();  // of the previous pivot
      walk_line(ctx, d, static_cast<int>(line), [&](std::int64_t s, bool linked,
                                                    std::int64_t previous) {
        Eigen::Matrix3d pivot = load(&diagonal_block[6 * s]);
        if (linked) {
          const Eigen::Matrix3d k = load(&edge_block[6 * element_id(previous, d)]);
          pivot -= k * inverse * k;
        }
        inverse = pivot.inverse();
        store_symmetric(pivot_inverse_, 2 * s + d, inverse);  // 6 per (slot, direction)
      });
    });
  }
}

void LinePreconditioner::apply(LoopRunner& run, const StepContext& ctx, std::span<const double> g,
                               std::span<double> out) {
  const ClothMesh& mesh = ctx.mesh;
  for (int d = 0; d < 2; ++d) {
    // Per node: the walk, g, the edge block and the pivot inverse read; the line's value
    // written (and read back within the line, from cache).
    const LoopBytes line_bytes = per_line(
        mesh, d,
        {.read = kWalkRead + bytes::kVector3 + 2 * bytes::kBlockD, .written = bytes::kVector3});
    run.for_index(d == 0 ? mesh.size_j() : mesh.size_i(), line_bytes, [&](std::int64_t line) {
      thread_local std::vector<std::int64_t> order;
      thread_local std::vector<char> linked_to_previous;
      order.clear();
      linked_to_previous.clear();
      // Forward elimination: y_s = g_s + K (P_prev^-1 y_prev) along linked runs.
      Eigen::Vector3d carried = Eigen::Vector3d::Zero();
      walk_line(ctx, d, static_cast<int>(line), [&](std::int64_t s, bool linked,
                                                    std::int64_t previous) {
        Eigen::Vector3d y = vec3(g, s);
        if (linked) {
          y += load(&edge_block[6 * element_id(previous, d)]) *
               (load(&pivot_inverse_[12 * previous + 6 * d]) * carried);
        }
        carried = y;
        Eigen::Map<Eigen::Vector3d> value(&line_value_[6 * s + 3 * d]);
        value = y;
        order.push_back(s);
        linked_to_previous.push_back(linked ? 1 : 0);
      });
      // Back substitution: x_s = P_s^-1 (y_s + K x_next) along linked runs.
      Eigen::Vector3d x_next = Eigen::Vector3d::Zero();
      for (std::size_t k = order.size(); k-- > 0;) {
        const std::int64_t s = order[k];
        Eigen::Map<Eigen::Vector3d> value(&line_value_[6 * s + 3 * d]);
        Eigen::Vector3d rhs = value;
        if (k + 1 < order.size() && linked_to_previous[k + 1] != 0) {
          rhs += load(&edge_block[6 * element_id(s, d)]) * x_next;
        }
        x_next = load(&pivot_inverse_[12 * s + 6 * d]) * rhs;
        value = x_next;
      }
    });
  }
  // Flags and both directions' values read, z written.
  const LoopBytes mean_bytes{.read = bytes::kFlag + 2 * bytes::kVector3,
                             .written = bytes::kVector3};
  run.for_each(ElementKind::particles, mean_bytes, [&](std::int64_t s) {
    auto z = vec3(out, s);
    if (!ctx.is_free(s)) {
      z.setZero();
      return;
    }
    z = 0.5 * (Eigen::Map<const Eigen::Vector3d>(&line_value_[6 * s]) +
               Eigen::Map<const Eigen::Vector3d>(&line_value_[6 * s + 3]));
  });
}

std::size_t LinePreconditioner::memory_bytes() const {
  return (diagonal_block.capacity() + edge_block.capacity() + pivot_inverse_.capacity() +
          line_value_.capacity()) *
         sizeof(double);
}

}  // namespace clothbench::kernels
