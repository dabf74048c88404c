// The potential formulation's Newton system (see potential_objective.hpp and model_hessian.hpp):
// assembly of the model Hessian with its preconditioner, and the inner linear PCG that solves
// H p = -g inexactly. Every loop runs through the LoopRunner with per-tile sums.
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "kernels/potential_elements.hpp"
#include "kernels/potential_objective.hpp"

namespace clothbench::kernels {

void PotentialObjective::assemble_newton(LoopRunner& run, bool new_step, bool floor_along) {
  ClothState& st = ctx_.state;
  LinePreconditioner* lines = lines_.get();
  const Preconditioner kind = ctx_.config.solver.preconditioner;
  // Without a preconditioner the unknowns are positions in units of the finest spacing h.
  const double h = std::min(ctx_.mesh.spacing(0), ctx_.mesh.spacing(1));
  newton_->hessian.assemble(
      run, ctx_,
      [&](std::int64_t s, const Eigen::Matrix3d& block) {
        if (lines != nullptr) store_symmetric(lines->diagonal_block, s, block);
        Eigen::Matrix3d inverse = Eigen::Matrix3d::Zero();
        if (ctx_.is_free(s)) {
          inverse = kind == Preconditioner::none
                        ? Eigen::Matrix3d(Eigen::Matrix3d::Identity() * (h * h))
                        : Eigen::Matrix3d(block.inverse());
        }
        store_symmetric(st.preconditioner, s, inverse);
      },
      new_step, bytes::kBlockF + (lines != nullptr ? bytes::kBlockD : 0.0), floor_along);
  if (vcycle_ != nullptr && vcycle_on_.load(std::memory_order_relaxed)) {
    vcycle_->factor(run, ctx_, newton_->hessian);
  }
  if (lines == nullptr) return;
  const ModelHessian& hessian = newton_->hessian;
  // x's share, next, alpha and beta read; the block written.
  const LoopBytes edge_bytes{
      .read = bytes::kSlotShare * bytes::kVector3 + bytes::kIndex + 2 * bytes::kDouble,
      .written = bytes::kBlockD};
  run.for_each(ElementKind::edges, edge_bytes, [&](std::int64_t id) {
    store_symmetric(lines->edge_block, id, hessian.edge_block(ctx_, id));
  });
  lines->factor(run, ctx_);
  if (multigrid_ != nullptr) multigrid_->factor(run, ctx_, hessian);
}

EdgeCensus PotentialObjective::edge_census(LoopRunner& run, bool compare) {
  const ClothMesh& mesh = ctx_.mesh;
  const ClothState& st = ctx_.state;
#pragma omp single
  if (edge_branch_.size() != static_cast<std::size_t>(2 * mesh.slot_count())) {
    edge_branch_.assign(static_cast<std::size_t>(2 * mesh.slot_count()), 0);
  }  // the single's barrier publishes the buffer
  // x's share, the previous force and the old branch read; the branch written.
  const LoopBytes census_bytes{.read = bytes::kSlotShare * bytes::kVector3 + bytes::kDouble + 1.0,
                               .written = 1.0};
  const bool tilted = tilted_plateau(ctx_.material);
  run.for_each<EdgeCensus>(
      ElementKind::edges, &census_partials_, census_bytes, [&](std::int64_t id, EdgeCensus& acc) {
        const Eigen::Vector3d e =
            vec3(st.position, mesh.next[id]) - vec3(st.position, element_slot(id));
        const double strain = e.norm() / mesh.edge_rest[id] - 1.0;
        BandBranch branch = BandBranch::slack;
        if (tilted) {  // the line inside the band counted as the plateau
          switch (tilted_piece(&st.edge_plateau[kTiltedPieceDoubles * id], strain)) {
            case TiltedPiece::slack: break;
            case TiltedPiece::unloading: branch = BandBranch::unloading; break;
            case TiltedPiece::line: branch = BandBranch::plateau; break;
            case TiltedPiece::loading: branch = BandBranch::loading; break;
          }
        } else if (strain > 0.0) {
          branch = band_branch(ctx_.material.tensile[element_direction(id)].curves(strain),
                               st.edge_force[id]);
        }
        switch (branch) {
          case BandBranch::slack: ++acc.slack; break;
          case BandBranch::loading: ++acc.loading; break;
          case BandBranch::plateau: ++acc.plateau; break;
          case BandBranch::unloading: ++acc.unloading; break;
        }
        const auto code = static_cast<std::uint8_t>(branch);
        if (compare && edge_branch_[id] != code) ++acc.changed;
        edge_branch_[id] = code;
      });
  return run.reduce(census_partials_);
}

LinearSolveReport PotentialObjective::solve_newton_direction(LoopRunner& run, double forcing,
                                                             int max_iterations) {
  ClothState& st = ctx_.state;
  NewtonSystem& ns = *newton_;
  const ClothMesh& mesh = ctx_.mesh;
  LinePreconditioner* lines = lines_.get();
  const double g_ref = ctx_.gravity_reference();
  auto weight = [&](std::int64_t s) {
    const double mg = mesh.mass[s] * g_ref;
    return 1.0 / (mg * mg);
  };
  LinearSolveReport report;

  // x = 0, r = -g on the free particles: flags and g read, x and r written.
  const LoopBytes start_bytes{.read = bytes::kFlag + bytes::kVector3,
                              .written = 2 * bytes::kVector3};
  run.for_each(ElementKind::particles, start_bytes, [&](std::int64_t s) {
    vec3(st.direction, s).setZero();
    vec3(ns.residual, s) = ctx_.is_free(s) ? Eigen::Vector3d(-vec3(st.gradient, s))
                                            : Eigen::Vector3d::Zero();
  });
  // z = M^-1 r (into `product`) with the sums r . z and |r|_W^2. Block Jacobi is computed in
  // the same loop as the sums; line solves first solve every line, the multigrids run a cycle.
  // Block Jacobi is applied inside the PCG's own loops; every other preconditioner has its own.
  // Under the V-cycle a step's solves run block Jacobi until one of them has taken
  // `vcycle_after` iterations without meeting its forcing term; that one builds the V-cycle
  // and restarts its search from the residual it has reached.
  bool use_vcycle = vcycle_ != nullptr && vcycle_on_.load(std::memory_order_relaxed);
  const int vcycle_after = ctx_.config.solver.vcycle_after;
  bool own_loops = lines != nullptr || use_vcycle;
  // Flags, mass, r, and z (own loops) or P^-1 read; z written when computed here.
  const auto sums_bytes = [&] {
    return LoopBytes{.read = bytes::kFlag + bytes::kDouble + 2 * bytes::kVector3,
                     .written = own_loops ? 0.0 : bytes::kVector3};
  };
  auto precondition_residual = [&]() {
    if (use_vcycle) {
      vcycle_->apply(run, ctx_, ns.residual, ns.product);
    } else if (multigrid_ != nullptr) {
      multigrid_->apply(run, ctx_, *lines, ns.residual, ns.product);
    } else if (lines != nullptr) {
      lines->apply(run, ctx_, ns.residual, ns.product);
    }
    run.for_each<PcgSums>(ElementKind::particles, &ns.partials, sums_bytes(),
                          [&](std::int64_t s, PcgSums& acc) {
                            auto z = vec3(ns.product, s);
                            if (!ctx_.is_free(s)) {
                              z.setZero();
                              return;
                            }
                            const Eigen::Vector3d r = vec3(ns.residual, s);
                            if (!own_loops) z = apply_symmetric(st.preconditioner, s, r);
                            acc.rz += r.dot(z);
                            acc.weighted += r.squaredNorm() * weight(s);
                          });
    return run.reduce(ns.partials);
  };
  PcgSums sums = precondition_residual();
  const double norm0 = std::sqrt(sums.weighted);
  if (!(norm0 > 0.0)) {
    report.converged = true;
    report.relative_residual = 0.0;
    return report;
  }
  const double target = forcing * norm0;
  double rz = sums.rz;
  const LoopBytes copy_bytes{.read = bytes::kVector3, .written = bytes::kVector3};
  const auto search_along_z = [&] {
    run.for_each(ElementKind::particles, copy_bytes,
                 [&](std::int64_t s) { vec3(ns.search, s) = vec3(ns.product, s); });
  };
  search_along_z();

  while (report.iterations < max_iterations) {
    const double pq = ns.hessian.apply(run, ctx_, ns.search, ns.product);  // product = H p
    if (!(pq > 0.0) || !std::isfinite(pq) || !(rz > 0.0)) {
      report.positive = false;
      break;
    }
    const double alpha = rz / pq;
    ++report.iterations;
    const bool fused = !own_loops;
    // Flags, mass, d, p, r, Hp (and P^-1) read; d, r (and z) written.
    const LoopBytes update_bytes{.read = bytes::kFlag + bytes::kDouble + 4 * bytes::kVector3 +
                                         (fused ? bytes::kBlockF : 0.0),
                                 .written = (fused ? 3 : 2) * bytes::kVector3};
    run.for_each<PcgSums>(ElementKind::particles, &ns.partials, update_bytes,
                          [&](std::int64_t s, PcgSums& acc) {
                            if (!ctx_.is_free(s)) return;
                            vec3(st.direction, s) += alpha * vec3(ns.search, s);
                            auto r = vec3(ns.residual, s);
                            r -= alpha * vec3(ns.product, s);
                            acc.weighted += r.squaredNorm() * weight(s);
                            if (fused) {
                              auto z = vec3(ns.product, s);
                              z = apply_symmetric(st.preconditioner, s, r);
                              acc.rz += r.dot(z);
                            }
                          });
    sums = run.reduce(ns.partials);
    report.relative_residual = std::sqrt(sums.weighted) / norm0;
    if (std::sqrt(sums.weighted) <= target) {
      report.converged = true;
      break;
    }
    if (report.iterations >= max_iterations) break;
    if (!use_vcycle && vcycle_ != nullptr && report.iterations >= vcycle_after) {
      // Block Jacobi was not enough: the V-cycle for this model and the step's later solves,
      // and a new search from the residual reached (the iterate p is kept).
      use_vcycle = own_loops = true;
      vcycle_on_.store(true, std::memory_order_relaxed);
#pragma omp master
      ++vcycle_steps_;
      vcycle_->factor(run, ctx_, ns.hessian);
      sums = precondition_residual();
      rz = sums.rz;
      search_along_z();
      continue;
    }
    if (!fused) sums = precondition_residual();
    const double beta = sums.rz / rz;
    rz = sums.rz;
    const LoopBytes search_bytes{.read = bytes::kFlag + 2 * bytes::kVector3,
                                 .written = bytes::kVector3};
    run.for_each(ElementKind::particles, search_bytes, [&](std::int64_t s) {
      auto p = vec3(ns.search, s);
      p = ctx_.is_free(s) ? Eigen::Vector3d(vec3(ns.product, s) + beta * p) : Eigen::Vector3d::Zero();
    });
  }
  if (report.iterations == 0) {
    // H was not positive on the first direction: fall back to the preconditioned gradient.
    run.for_each(ElementKind::particles, copy_bytes,
                 [&](std::int64_t s) { vec3(st.direction, s) = vec3(ns.search, s); });
  }
  run.for_each<PcgSums>(ElementKind::particles, &ns.partials,
                        LoopBytes{.read = 2 * bytes::kVector3}, [&](std::int64_t s, PcgSums& acc) {
                          acc.slope += vec3(st.gradient, s).dot(vec3(st.direction, s));
                        });
  report.slope = run.reduce(ns.partials).slope;
  return report;
}

}  // namespace clothbench::kernels
