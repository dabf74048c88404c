// Nonlinear block Gauss-Seidel smoothing of the potential formulation's step (see
// PotentialObjective::smooth and MODEL-NOTES.md, Newton, "Nonlinear smoothing").
//
// Each free particle in turn takes one Newton step on Phi restricted to the terms that
// involve it (local_energy), with its 3x3 stiffness block, and keeps it only if that local
// energy decreased (halving up to eight times): every accepted move lowers Phi itself. The
// particles are coloured so that no element touches two particles of one colour (through
// their ghost children too); a colour's particles then move independently, in parallel, and
// each reads only the positions of other colours. The colouring is greedy in slot order and
// the sweeps go colour by colour, so the result has the same bits on every scheduler and
// thread count.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "kernels/potential_elements.hpp"
#include "kernels/potential_objective.hpp"

namespace clothbench::kernels {

namespace {

/// Calls f(k) for every active particle whose move changes a term of local_energy(s): the
/// nodes of every element touching s or a ghost hanging on it (for_each_element_at, the
/// enumeration local_energy sums over), ghosts resolved into the particles that move them.
template <class F>
void for_each_footprint(const ClothMesh& mesh, std::int64_t s, F&& f) {
  auto owners = [&](auto&& self, std::int64_t k) -> void {
    const int d = ghost_direction(mesh.flags[k]);
    if (d < 0) {
      f(k);
      return;
    }
    const std::int64_t id = element_id(k, d);
    self(self, mesh.prev[id]);
    self(self, mesh.next[id]);
  };
  auto around = [&](auto&& self, std::int64_t m) -> void {
    for_each_element_at(
        mesh, m,
        [&](std::int64_t id) {
          owners(owners, element_slot(id));
          owners(owners, mesh.next[id]);
        },
        [&](std::int64_t id) {
          owners(owners, mesh.prev[id]);
          owners(owners, element_slot(id));
          owners(owners, mesh.next[id]);
        });
    for_each_ghost_child(mesh, m, [&](std::int64_t child) { self(self, child); });
  };
  f(s);
  around(around, s);
}

}  // namespace

void PotentialObjective::colour_for_smoothing(LoopRunner& /*run*/) {
#pragma omp single
  if (!smoothing_topology_.matches(ctx_.mesh)) {
    const ClothMesh& mesh = ctx_.mesh;
    const std::int64_t slots = mesh.slot_count();
    smoothing_colour_.assign(static_cast<std::size_t>(slots), -1);
    // Colours first, then each colour's list at its exact size (no growth slack: this runs
    // while every slot of the finest mesh may be free).
    std::vector<std::int64_t> counts;
    std::vector<char> used;
    for (std::int64_t s = 0; s < slots; ++s) {
      if (!ctx_.is_free(s)) continue;
      used.assign(counts.size() + 1, 0);
      for_each_footprint(mesh, s, [&](std::int64_t k) {
        const int c = smoothing_colour_[k];
        if (k != s && c >= 0) used[c] = 1;
      });
      const auto colour = static_cast<std::size_t>(std::find(used.begin(), used.end(), 0) - used.begin());
      if (colour == counts.size()) {
        if (colour > static_cast<std::size_t>(std::numeric_limits<std::int16_t>::max())) {
          throw std::logic_error("colour_for_smoothing: more colours than int16 holds");
        }
        counts.push_back(0);
      }
      ++counts[colour];
      smoothing_colour_[s] = static_cast<std::int16_t>(colour);
    }
    smoothing_lists_.assign(counts.size(), {});
    for (std::size_t c = 0; c < counts.size(); ++c) {
      smoothing_lists_[c].reserve(static_cast<std::size_t>(counts[c]));
    }
    for (std::int64_t s = 0; s < slots; ++s) {
      const int c = smoothing_colour_[s];
      if (c >= 0)
        smoothing_lists_[static_cast<std::size_t>(c)].push_back(static_cast<std::int32_t>(s));
    }
    // Each colour's ghosts: those hanging, directly or through other ghosts, on its slots.
    smoothing_ghosts_.assign(smoothing_lists_.size(), {});
    for (std::size_t c = 0; c < smoothing_lists_.size(); ++c) {
      std::vector<std::int64_t>& ghosts = smoothing_ghosts_[c];
      auto collect = [&](auto&& self, std::int64_t node) -> void {
        for_each_ghost_child(mesh, node, [&](std::int64_t child) {
          ghosts.push_back(child);
          self(self, child);
        });
      };
      for (const std::int32_t s : smoothing_lists_[c]) collect(collect, s);
      std::sort(ghosts.begin(), ghosts.end());
      ghosts.erase(std::unique(ghosts.begin(), ghosts.end()), ghosts.end());
    }
    smoothing_moved_.assign(static_cast<std::size_t>(slots), 0);
    smoothing_topology_.take(mesh);
  }  // the single's closing barrier publishes the colouring
}

Eigen::Vector3d PotentialObjective::local_gradient(std::int64_t s, LocalTerms* terms) const {
  if (ctx_.config.solver.gradient == GradientMode::numeric) return numeric_gradient(s);
  const ClothState& st = ctx_.state;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  const Eigen::Vector3d xs = x(s);
  Eigen::Vector3d g =
      own_gradient(s, xs, contact_penalty(ctx_, s, xs)) +
      gather_elastic(
          ctx_.mesh, s, x,
          [&](std::int64_t id) { return edge_term(ctx_, id, x, terms).force_density; },
          [&](std::int64_t id) {
            const TripleTerm t = triple_term(ctx_, id, x, terms);
            return Eigen::Vector3d(t.coefficient[0], t.coefficient[1], t.coefficient[2]);
          });
  if (ctx_.is_forced(s)) g -= ctx_.external_force(s);  // as evaluate subtracts it
  return g;
}

std::int64_t PotentialObjective::smooth(LoopRunner& run, int sweeps, double threshold) {
  if (sweeps <= 0) return 0;
  ClothState& st = ctx_.state;
  const ClothMesh& mesh = ctx_.mesh;
  const double g_ref = ctx_.gravity_reference();
  constexpr double kMark = sizeof(std::uint16_t);  // smoothing_moved_'s entry
  run.for_each(ElementKind::particles, LoopBytes{.written = kMark},
               [&](std::int64_t s) { smoothing_moved_[s] = 0; });
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    // What every particle of a colour reads before it may leave: its slot, mass, and its last
    // gradient (first sweep) or its own mark (later sweeps; its footprint's marks count where
    // owned). One that moves also reads its neighbourhood's element data: the figure is the
    // least.
    const LoopBytes colour_bytes{.read =
                                     2 * bytes::kDouble + (sweep == 0 ? bytes::kVector3 : kMark)};
    for (std::size_t c = 0; c < smoothing_lists_.size(); ++c) {
      const std::vector<std::int32_t>& colour = smoothing_lists_[c];
      run.for_index(static_cast<std::int64_t>(colour.size()), colour_bytes, [&](std::int64_t k) {
        const std::int64_t s = colour[k];
        const double weight = mesh.mass[s] * g_ref;
        if (sweep == 0) {
          // First sweep: the particles whose residual at the last evaluation is large.
          if (vec3(st.gradient, s).norm() < threshold * weight) return;
        } else {
          // Later sweeps: the particles that a move of the previous or this sweep touched.
          bool touched = false;
          for_each_footprint(mesh, s, [&](std::int64_t p) {
            touched = touched || smoothing_moved_[p] >= sweep;
          });
          if (!touched) return;
        }
        // The element terms at the stored positions are computed once for the gradient, the
        // block and the starting energy.
        thread_local LocalTerms terms;
        terms.clear();
        const Eigen::Vector3d g = local_gradient(s, &terms);
        if (!(g.norm() >= threshold * weight)) return;
        const Eigen::Vector3d xs = vec3(st.position, s);
        const Eigen::Vector3d step = -diagonal_block(s, kEveryObstacle, &terms).ldlt().solve(g);
        const double slope = g.dot(step);
        if (!(slope < 0.0)) return;
        const double before = local_energy(s, xs, &terms);
        double alpha = 1.0;
        for (int halving = 0; halving <= 8; ++halving, alpha *= 0.5) {
          const Eigen::Vector3d trial = xs + alpha * step;
          if (local_energy(s, trial) <= before + 1e-4 * alpha * slope) {
            vec3(st.position, s) = trial;
            smoothing_moved_[s] = static_cast<std::uint16_t>(sweep + 1);
            return;
          }
        }
      });
      // Only the ghosts on this colour's slots can have moved.
      refresh_listed_ghosts(run, mesh, smoothing_ghosts_[c], st.position);
    }
  }
  run.for_each<ScalarSum>(ElementKind::particles, &scalar_partials_, LoopBytes{.read = kMark},
                          [&](std::int64_t s, ScalarSum& acc) {
                            if (smoothing_moved_[s] > 0) acc.value += 1.0;
                          });
  return static_cast<std::int64_t>(run.reduce(scalar_partials_).value);
}

}  // namespace clothbench::kernels
