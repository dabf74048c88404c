// The plane-strain strip (strip_drape.hpp): its element laws, potential, model and solver.
#include "kernels/strip_drape.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace clothbench::kernels {

namespace {

using Vec2 = Eigen::Vector2d;
using Mat2 = Eigen::Matrix2d;

double softplus(double z) {
  if (z > 30.0) return z;
  if (z < -30.0) return std::exp(z);
  return std::log1p(std::exp(z));
}
double logistic(double z) {
  return z >= 0.0 ? 1.0 / (1.0 + std::exp(-z)) : std::exp(z) / (1.0 + std::exp(z));
}

/// A band law written as strain of force (the compliance): the inverse loading curve below
/// the previous force fp, the inverse unloading curve less the plateau's width D above it,
/// D times a logistic step of `width` at fp, less barrier / f. Its integral over the force
/// is the complementary energy; the primal law is found by a safeguarded Newton in f.
template <class Band>
class SmoothedLaw {
 public:
  SmoothedLaw(const Band& band, double fp, const BandBreakpoints& bp, double width,
              double barrier)
      : band_(band), fp_(fp), lower_(bp.lower), upper_(bp.upper),
        width_(bp.upper - bp.lower), step_width_(width), barrier_(barrier) {}

  StripLaw at(double eps) const {
    StripLaw law;
    double der = 0.0;
    double comp = 0.0;
    double lo = 0.0;
    if (barrier_ > 0.0) {
      lo = barrier_ * 1e-3;
      for (int i = 0; i < 2000 && strain(lo, der, comp) > eps; ++i) lo *= 0.5;
    } else if (!(eps > strain(0.0, der, comp))) {
      return law;  // no force below the strain of zero force
    }
    double hi = std::max(fp_, 1e-6);
    for (int i = 0; i < 2000 && strain(hi, der, comp) < eps; ++i) hi *= 2.0;
    double f = lo > 0.0 ? std::sqrt(lo * hi) : 0.5 * hi;
    for (int it = 0; it < 300; ++it) {
      const double e = strain(f, der, comp);
      if (e < eps) lo = f; else hi = f;
      double next = f - (e - eps) / der;
      if (!(next > lo && next < hi)) next = (lo > 0.0 && hi > 4.0 * lo) ? std::sqrt(lo * hi)
                                                                        : 0.5 * (lo + hi);
      const bool done = std::abs(next - f) <= 1e-14 * f || hi - lo <= 1e-14 * hi;
      f = next;
      if (done) break;
    }
    const double e = strain(f, der, comp);
    law.force = f;
    law.slope = 1.0 / der;
    law.potential = f * e - comp + f * (eps - e);  // Legendre transform, first-order exact
    return law;
  }

 private:
  /// Strain at force f > 0 (f = 0 allowed without a barrier), d strain / d f, and the
  /// complementary energy (its integral from 0, up to the barrier's constant).
  double strain(double f, double& der, double& comp) const {
    double e = 0.0;
    if (f <= fp_) {
      e = band_.loading_inverse(f);
      der = inverse_slope(band_.loading_slope(e));
      comp = f * e - band_.loading_integral(e);
    } else {
      const double eu = band_.unloading_inverse(f);
      e = eu - width_;
      der = inverse_slope(band_.unloading_slope(eu));
      const double below = fp_ * lower_ - band_.loading_integral(lower_);
      const double at_fp = fp_ * upper_ - band_.unloading_integral(upper_);
      comp = below + (f * eu - band_.unloading_integral(eu)) - at_fp - width_ * (f - fp_);
    }
    if (barrier_ > 0.0) {
      e -= barrier_ / f;
      der += barrier_ / (f * f);
      comp -= barrier_ * std::log(f);
    }
    if (width_ > 0.0) {
      const double z = (f - fp_) / step_width_;
      const double s = logistic(z);
      e += width_ * s;
      der += width_ * s * (1.0 - s) / step_width_;
      comp += width_ * step_width_ * (softplus(z) - softplus(-fp_ / step_width_));
    }
    return e;
  }
  static double inverse_slope(double slope) { return slope > 0.0 ? 1.0 / slope : 1e30; }

  const Band& band_;
  double fp_, lower_, upper_, width_, step_width_, barrier_;
};

template <class Band>
StripLaw band_law(const Band& band, double previous, double strain, double mu, double width,
                  double barrier) {
  const BandBreakpoints bp = band_breakpoints(band, previous);
  if (!(mu > 0.0)) {
    const ReturnMapped r = return_map(band, previous, bp, strain);
    return {r.force, r.slope, r.potential};
  }
  const double fp = previous > 0.0 ? previous : 0.0;
  BandBreakpoints smoothed = bp;
  if (!(fp > 0.0)) smoothed.upper = smoothed.lower;  // no plateau without a previous force
  return SmoothedLaw<Band>(band, fp, smoothed, width, barrier).at(strain);
}

/// The tilted plateau's law of one edge for one step: f(s) = clamp(fp + E (s - ep), tU(s),
/// tL(s)) for s > 0 and 0 otherwise, as pieces (which of the three it is) with their
/// potentials at the piece starts. Its pieces are found once a step by sign changes on a
/// geometric grid of strains, refined by bisection.
class TiltedLaw {
 public:
  TiltedLaw() = default;
  TiltedLaw(const TensileBand& band, double fp, double ep, double stiffness)
      : band_(&band), fp_(fp), ep_(ep), e_(stiffness) {
    std::vector<double> roots;
    const double top = 8.0 * std::max(band.emt, ep);
    double previous_s = 0.0;
    double previous_l = line(0.0) - band.loading(0.0);
    double previous_u = line(0.0) - band.unloading(0.0);
    constexpr int kGrid = 240;
    for (int k = 0; k <= kGrid; ++k) {
      const double s = top * std::pow(10.0, -9.0 * (1.0 - static_cast<double>(k) / kGrid));
      const double gl = line(s) - band.loading(s);
      const double gu = line(s) - band.unloading(s);
      if ((gl > 0.0) != (previous_l > 0.0)) roots.push_back(bisect(previous_s, s, true));
      if ((gu > 0.0) != (previous_u > 0.0)) roots.push_back(bisect(previous_s, s, false));
      previous_s = s;
      previous_l = gl;
      previous_u = gu;
    }
    std::sort(roots.begin(), roots.end());
    starts_.push_back(0.0);
    for (double r : roots) {
      if (r > starts_.back()) starts_.push_back(r);
    }
    for (std::size_t i = 0; i < starts_.size(); ++i) {
      const double mid = i + 1 < starts_.size() ? 0.5 * (starts_[i] + starts_[i + 1])
                                                : 2.0 * starts_[i] + band.emt;
      kinds_.push_back(kind(mid));
    }
    potentials_.push_back(0.0);
    for (std::size_t i = 0; i + 1 < starts_.size(); ++i) {
      potentials_.push_back(potentials_.back() + integral(kinds_[i], starts_[i], starts_[i + 1]));
    }
  }

  StripLaw at(double s) const {
    StripLaw law;
    if (!(s > 0.0)) return law;
    const std::size_t i = static_cast<std::size_t>(
        std::upper_bound(starts_.begin(), starts_.end(), s) - starts_.begin() - 1);
    switch (kinds_[i]) {
      case 0:
        law.force = band_->unloading(s);
        law.slope = band_->unloading_slope(s);
        break;
      case 1:
        law.force = line(s);
        law.slope = e_;
        break;
      default:
        law.force = band_->loading(s);
        law.slope = band_->loading_slope(s);
        break;
    }
    law.potential = potentials_[i] + integral(kinds_[i], starts_[i], s);
    return law;
  }

 private:
  double line(double s) const { return fp_ + e_ * (s - ep_); }
  int kind(double s) const {
    const double l = line(s);
    if (l <= band_->unloading(s)) return 0;
    return l >= band_->loading(s) ? 2 : 1;
  }
  double integral(int k, double a, double b) const {
    if (k == 0) return band_->unloading_integral(b) - band_->unloading_integral(a);
    if (k == 2) return band_->loading_integral(b) - band_->loading_integral(a);
    return fp_ * (b - a) + 0.5 * e_ * ((b - ep_) * (b - ep_) - (a - ep_) * (a - ep_));
  }
  double bisect(double a, double b, bool loading) const {
    auto g = [&](double s) { return line(s) - (loading ? band_->loading(s) : band_->unloading(s)); };
    const bool ga = g(a) > 0.0;
    for (int i = 0; i < 200 && b - a > 1e-15 * b; ++i) {
      const double m = 0.5 * (a + b);
      if ((g(m) > 0.0) == ga) a = m; else b = m;
    }
    return 0.5 * (a + b);
  }

  const TensileBand* band_ = nullptr;
  double fp_ = 0.0, ep_ = 0.0, e_ = 0.0;
  std::vector<double> starts_;
  std::vector<int> kinds_;
  std::vector<double> potentials_;
};

/// Which piece of the return mapping a strain is on (for the trace's branch changes).
int branch(const TensileBand& band, double previous, double eps) {
  const BandBreakpoints bp = band_breakpoints(band, previous);
  if (!(eps > 0.0)) return 0;
  if (eps < bp.lower) return 1;
  return eps < bp.upper ? 2 : 3;
}

/// The strip: geometry, material, state and the potential of one step.
class Strip {
 public:
  explicit Strip(const StripSettings& s)
      : s_(s), n_(s.particles), h_(1.0 / (s.particles - 1)),
        tension_(TensileBand::from_kes(s.fabric.warp, s.fabric.fm_gf_per_cm)),
        bending_(BendingBand::from_kes(s.fabric.warp, s.fabric.kappa0_per_cm)),
        mass_(static_cast<std::size_t>(n_)), x_(2 * n_), previous_x_(2 * n_), target_(2 * n_),
        tension_prev_(static_cast<std::size_t>(n_ - 1), 0.0),
        strain_prev_(static_cast<std::size_t>(n_ - 1), 0.0),
        moment_prev_(static_cast<std::size_t>(n_ - 2), 0.0),
        edge_memory_(static_cast<std::size_t>(n_ - 1), 0.0),
        triple_memory_(static_cast<std::size_t>(n_ - 2), 0.0) {
    const double density = s.fabric.weight_mg_per_cm2 * 1e-2;  // mg/cm^2 -> kg/m^2
    for (int i = 0; i < n_; ++i) {
      mass_[idx(i)] = density * kWidth * h_ * ((i == 0 || i == n_ - 1) ? 0.5 : 1.0);
      x_.segment<2>(2 * i) = Vec2(-0.5 + i * h_, kStartHeight);
    }
    previous_x_ = x_;
    build_tilted();
  }

  int particles() const { return n_; }
  const Eigen::VectorXd& positions() const { return x_; }

  /// Starts a step: the inertial target, and the initial guess (the target with particles
  /// inside the contact layer put back on it).
  Eigen::VectorXd begin_step() {
    // Damping is a rate (MODEL.md 5): the velocity kept over a step of dt is (1 - damping)^(dt /
    // 4 ms), exactly 1 - damping at 4 ms.
    const double keep = std::pow(1.0 - s_.damping, s_.step_s / 0.004);
    target_ = x_ + keep * (x_ - previous_x_);
    Eigen::VectorXd guess = target_;
    for (int i = 0; i < n_; ++i) {
      Vec2 normal;
      const double phi = distance(guess.segment<2>(2 * i), normal);
      if (phi < kContactDistance) guess.segment<2>(2 * i) += (kContactDistance - phi) * normal;
    }
    return guess;
  }
  /// Ends a step at `x`: the forces become the next step's previous forces (exact law).
  void end_step(const Eigen::VectorXd& x) {
    for (int e = 0; e < n_ - 1; ++e) {
      tension_prev_[idx(e)] = edge_law(x, e, 0.0).force;
      strain_prev_[idx(e)] = (x.segment<2>(2 * e + 2) - x.segment<2>(2 * e)).norm() / h_ - 1.0;
    }
    build_tilted();
    for (int t = 0; t < n_ - 2; ++t) {
      moment_prev_[idx(t)] = triple_law(x, t, 0.0).force;
    }
    previous_x_ = x_;
    x_ = x;
  }

  /// Phi at x (mu smooths the bands), its gradient and the model Hessian if asked. The
  /// model reaches along `reach` when given (and remembers) when the settings say so.
  double evaluate(const Eigen::VectorXd& x, double mu, Eigen::VectorXd* gradient,
                  std::vector<Eigen::Triplet<double>>* model,
                  const Eigen::VectorXd* reach) const {
    double energy = 0.0;
    if (gradient != nullptr) gradient->setZero(2 * n_);
    for (int i = 0; i < n_; ++i) {
      Vec2 g;
      Mat2 k;
      energy += particle_terms(x, i, &g, &k);
      if (gradient != nullptr) gradient->segment<2>(2 * i) += g;
      if (model != nullptr) add_block(*model, i, i, k);
    }
    for (int e = 0; e < n_ - 1; ++e) {
      const Vec2 d = x.segment<2>(2 * e + 2) - x.segment<2>(2 * e);
      const double l = d.norm();
      const Vec2 u = d / l;
      const double eps = l / h_ - 1.0;
      const StripLaw law = edge_law(x, e, mu);
      energy += kWidth * h_ * law.potential;
      if (gradient != nullptr) {
        gradient->segment<2>(2 * e + 2) += kWidth * law.force * u;
        gradient->segment<2>(2 * e) -= kWidth * law.force * u;
      }
      if (model == nullptr) continue;
      double axial = law.slope;
      if (s_.reach) {
        if (reach != nullptr) {
          const Vec2 d1 = d + reach->segment<2>(2 * e + 2) - reach->segment<2>(2 * e);
          const double eps1 = d1.norm() / h_ - 1.0;
          if (std::abs(eps1 - eps) > 1e-12) {
            const StripLaw far = edge_law_at(e, eps1, mu);
            axial = std::max(axial, (far.force - law.force) / (eps1 - eps));
          }
        }
        axial = std::max(axial, s_.memory * edge_memory_[idx(e)]);
        edge_memory_[idx(e)] = axial;
      }
      const Mat2 uu = u * u.transpose();
      const Mat2 k = kWidth * axial / h_ * uu +
                     kWidth * std::max(law.force, 0.0) / l * (Mat2::Identity() - uu);
      add_block(*model, e, e, k);
      add_block(*model, e + 1, e + 1, k);
      add_block(*model, e, e + 1, -k);
      add_block(*model, e + 1, e, -k);
    }
    for (int t = 0; t < n_ - 2; ++t) {
      Vec2 jac[3];
      double signed_angle = 0.0;
      turning(x, t, jac, signed_angle);
      const double kappa = std::abs(signed_angle) / h_;
      const double sign = signed_angle < 0.0 ? -1.0 : 1.0;
      const StripLaw law = triple_law(x, t, mu);
      energy += kWidth * h_ * law.potential;
      if (gradient != nullptr) {
        for (int k = 0; k < 3; ++k) gradient->segment<2>(2 * (t + k)) += kWidth * law.force * sign * jac[k];
      }
      if (model == nullptr) continue;
      const double at_zero = bending_.b + bending_.hb / bending_.kappa0;
      double c = law.slope;
      if (!(kappa > 1e-12 / h_) && moment_prev_[idx(t)] > 0.0) c = at_zero;
      if (s_.reach) {
        if (kappa > 0.0) c = std::max(c, std::min(law.force / kappa, at_zero));
        if (reach != nullptr) {
          Vec2 moved[3];  // the triple's particles at x + reach
          for (int k = 0; k < 3; ++k) {
            moved[k] = x.segment<2>(2 * (t + k)) + reach->segment<2>(2 * (t + k));
          }
          const Vec2 e1 = moved[1] - moved[0];
          const Vec2 e2 = moved[2] - moved[1];
          const double kappa1 =
              std::abs(std::atan2(e1.x() * e2.y() - e1.y() * e2.x(), e1.dot(e2))) / h_;
          if (std::abs(kappa1 - kappa) * h_ > 1e-12) {
            const StripLaw far = triple_law_at(t, kappa1, mu);
            c = std::max(c, (far.force - law.force) / (kappa1 - kappa));
          }
        }
        c = std::max(c, s_.memory * triple_memory_[idx(t)]);
        triple_memory_[idx(t)] = c;
      }
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) {
          add_block(*model, t + a, t + b, kWidth * c / h_ * jac[a] * jac[b].transpose());
        }
      }
    }
    return energy;
  }

  /// RMS over the particles of |gradient_i| / (m_i |g|).
  double residual(const Eigen::VectorXd& gradient) const {
    double sum = 0.0;
    for (int i = 0; i < n_; ++i) {
      sum += (gradient.segment<2>(2 * i) / (mass_[idx(i)] * kGravity)).squaredNorm();
    }
    return std::sqrt(sum / n_);
  }

  /// The kernel's smoothing rule: colour by colour (3 colours on a line), a local Newton
  /// step with halving on the exact local energy of each particle whose residual is at
  /// least the tolerance.
  /// Returns the hat moves that lowered the energy.
  int smooth(Eigen::VectorXd& x, double mu) const {
    int moved_hats = 0;
    for (int pass = 0; pass < s_.hat_sweeps && s_.hat_levels > 0; ++pass) {
      int top = 1;
      while (top < s_.hat_levels && (2 << top) < n_) ++top;
      for (int level = top; level >= 1; --level) {
        const int width = 1 << level;
        for (int j = 0; j < n_; j += width) moved_hats += hat_move(x, j, width, mu) ? 1 : 0;
      }
    }
    for (int sweep = 0; sweep < s_.smoothing_sweeps; ++sweep) {
      for (int colour = 0; colour < 3; ++colour) {
        for (int i = colour; i < n_; i += 3) {
          Vec2 g;
          Mat2 k;
          const double before = local_energy(x, i, mu, &g, &k);
          if (g.norm() / (mass_[idx(i)] * kGravity) < s_.tolerance) continue;
          const Vec2 step = -k.ldlt().solve(g);
          const Vec2 start = x.segment<2>(2 * i);
          double alpha = 1.0;
          bool moved = false;
          for (int halving = 0; halving < 30 && !moved; ++halving, alpha *= 0.5) {
            x.segment<2>(2 * i) = start + alpha * step;
            moved = local_energy(x, i, mu, nullptr, nullptr) < before;
          }
          if (!moved) x.segment<2>(2 * i) = start;
        }
      }
    }
    return moved_hats;
  }

  /// Moves the hat function of half-width `width` centred on particle j (weights
  /// 1 - |i - j| / width) by one Newton step with halving on the exact energy of the terms it
  /// touches, when its residual is at least the tolerance.
  bool hat_move(Eigen::VectorXd& x, int j, int width, double mu) const {
    const int lo = std::max(0, j - width + 1);
    const int hi = std::min(n_ - 1, j + width - 1);
    Vec2 g;
    Mat2 k;
    double weight = 0.0;
    for (int i = lo; i <= hi; ++i) weight += hat(i, j, width) * mass_[idx(i)] * kGravity;
    const double before = hat_energy(x, lo, hi, j, width, mu, &g, &k);
    if (g.norm() / weight < s_.tolerance) return false;
    const Vec2 step = -k.ldlt().solve(g);
    if (!step.allFinite()) return false;
    Eigen::VectorXd start = x.segment(2 * lo, 2 * (hi - lo + 1));
    double alpha = 1.0;
    for (int halving = 0; halving < 30; ++halving, alpha *= 0.5) {
      for (int i = lo; i <= hi; ++i) {
        x.segment<2>(2 * i) = start.segment<2>(2 * (i - lo)) + alpha * hat(i, j, width) * step;
      }
      if (hat_energy(x, lo, hi, j, width, mu, nullptr, nullptr) < before) return true;
    }
    x.segment(2 * lo, 2 * (hi - lo + 1)) = start;
    return false;
  }

  static double hat(int i, int j, int width) {
    return std::max(0.0, 1.0 - std::abs(i - j) / static_cast<double>(width));
  }

  /// The terms of Phi that involve particles lo..hi, with the gradient and model block with
  /// respect to the displacement of the hat (j, width).
  double hat_energy(const Eigen::VectorXd& x, int lo, int hi, int j, int width, double mu,
                    Vec2* g, Mat2* k) const {
    Vec2 grad = Vec2::Zero();
    Mat2 block = Mat2::Zero();
    double energy = 0.0;
    auto w = [&](int i) { return (i < lo || i > hi) ? 0.0 : hat(i, j, width); };
    for (int i = lo; i <= hi; ++i) {
      Vec2 gi;
      Mat2 ki;
      energy += particle_terms(x, i, &gi, &ki);
      grad += w(i) * gi;
      block += w(i) * w(i) * ki;
    }
    for (int e = std::max(0, lo - 1); e <= std::min(n_ - 2, hi); ++e) {
      const Vec2 d = x.segment<2>(2 * e + 2) - x.segment<2>(2 * e);
      const double l = d.norm();
      const Vec2 u = d / l;
      const StripLaw law = edge_law(x, e, mu);
      energy += kWidth * h_ * law.potential;
      const double dw = w(e + 1) - w(e);
      grad += dw * kWidth * law.force * u;
      const Mat2 uu = u * u.transpose();
      block += dw * dw *
               (kWidth * law.slope / h_ * uu +
                kWidth * std::max(law.force, 0.0) / l * (Mat2::Identity() - uu));
    }
    for (int t = std::max(0, lo - 2); t <= std::min(n_ - 3, hi); ++t) {
      Vec2 jac[3];
      double angle = 0.0;
      turning(x, t, jac, angle);
      const StripLaw law = triple_law(x, t, mu);
      energy += kWidth * h_ * law.potential;
      const Vec2 jw = w(t) * jac[0] + w(t + 1) * jac[1] + w(t + 2) * jac[2];
      grad += kWidth * law.force * (angle < 0.0 ? -1.0 : 1.0) * jw;
      double c = law.slope;
      if (std::abs(angle) < 1e-12 && moment_prev_[idx(t)] > 0.0) {
        c = bending_.b + bending_.hb / bending_.kappa0;
      }
      block += kWidth * c / h_ * jw * jw.transpose();
    }
    if (g != nullptr) *g = grad;
    if (k != nullptr) *k = block;
    return energy;
  }

  /// Edges whose piece of the return mapping differs between x and y.
  int branch_changes(const Eigen::VectorXd& x, const Eigen::VectorXd& y) const {
    int changed = 0;
    for (int e = 0; e < n_ - 1; ++e) {
      const double ex = (x.segment<2>(2 * e + 2) - x.segment<2>(2 * e)).norm() / h_ - 1.0;
      const double ey = (y.segment<2>(2 * e + 2) - y.segment<2>(2 * e)).norm() / h_ - 1.0;
      const double fp = tension_prev_[idx(e)];
      changed += branch(tension_, fp, ex) != branch(tension_, fp, ey) ? 1 : 0;
    }
    return changed;
  }

  /// Signed distance to the box (the strip's section: |x| <= 0.25, 0 <= z <= 0.25), outward
  /// normal.
  static double distance(const Vec2& p, Vec2& normal) {
    const Vec2 q = p - Vec2(0.0, kBoxHalfHeight);
    const Vec2 sign(q.x() < 0.0 ? -1.0 : 1.0, q.y() < 0.0 ? -1.0 : 1.0);
    const Vec2 a = q.cwiseAbs() - Vec2(kBoxHalfWidth, kBoxHalfHeight);
    if (a.x() > 0.0 || a.y() > 0.0) {
      const Vec2 outside = a.cwiseMax(0.0);
      const double d = outside.norm();
      normal = sign.cwiseProduct(outside) / d;
      return d;
    }
    if (a.x() > a.y()) {
      normal = Vec2(sign.x(), 0.0);
      return a.x();
    }
    normal = Vec2(0.0, sign.y());
    return a.y();
  }

  static constexpr double kWidth = 1.0;          // m of cloth each particle stands for
  static constexpr double kStartHeight = 0.27;   // m
  static constexpr double kBoxHalfWidth = 0.25;  // m
  static constexpr double kBoxHalfHeight = 0.125;
  static constexpr double kContactDistance = 0.002;
  static constexpr double kContactStiffness = 1e4;  // times m |g| / d, as in the scene
  static constexpr double kGravity = 9.80665;

 private:
  static std::size_t idx(int i) { return static_cast<std::size_t>(i); }

  void build_tilted() {
    if (!(s_.inner_stiffness > 0.0)) return;
    tilted_.resize(static_cast<std::size_t>(n_ - 1));
    const double stiffness = s_.inner_stiffness * tension_.fm / tension_.emt;
    for (int e = 0; e < n_ - 1; ++e) {
      tilted_[idx(e)] = TiltedLaw(tension_, tension_prev_[idx(e)], strain_prev_[idx(e)], stiffness);
    }
  }

  StripLaw edge_law_at(int e, double eps, double mu) const {
    if (s_.inner_stiffness > 0.0) return tilted_[idx(e)].at(eps);
    return strip_tension_law(tension_, tension_prev_[idx(e)], eps, mu);
  }
  StripLaw triple_law_at(int t, double kappa, double mu) const {
    return strip_bending_law(bending_, moment_prev_[idx(t)], kappa, mu);
  }
  StripLaw edge_law(const Eigen::VectorXd& x, int e, double mu) const {
    return edge_law_at(e, (x.segment<2>(2 * e + 2) - x.segment<2>(2 * e)).norm() / h_ - 1.0, mu);
  }
  StripLaw triple_law(const Eigen::VectorXd& x, int t, double mu) const {
    Vec2 jac[3];
    double angle = 0.0;
    turning(x, t, jac, angle);
    return triple_law_at(t, std::abs(angle) / h_, mu);
  }

  /// Signed turning angle of triple t (t, t+1, t+2) and its gradient per particle.
  void turning(const Eigen::VectorXd& x, int t, Vec2 jac[3], double& angle) const {
    const Vec2 e1 = x.segment<2>(2 * t + 2) - x.segment<2>(2 * t);
    const Vec2 e2 = x.segment<2>(2 * t + 4) - x.segment<2>(2 * t + 2);
    angle = std::atan2(e1.x() * e2.y() - e1.y() * e2.x(), e1.dot(e2));
    const Vec2 d1 = Vec2(-e1.y(), e1.x()) / e1.squaredNorm();
    const Vec2 d2 = Vec2(-e2.y(), e2.x()) / e2.squaredNorm();
    jac[0] = d1;
    jac[1] = -d1 - d2;
    jac[2] = d2;
  }

  /// Inertia, gravity and contact of particle i, with gradient and model block.
  double particle_terms(const Eigen::VectorXd& x, int i, Vec2* g, Mat2* k) const {
    const double m = mass_[idx(i)];
    const double inertia = m / (s_.step_s * s_.step_s);
    const Vec2 p = x.segment<2>(2 * i);
    const Vec2 d = p - target_.segment<2>(2 * i);
    double energy = 0.5 * inertia * d.squaredNorm() + m * kGravity * p.y();
    *g = inertia * d + Vec2(0.0, m * kGravity);
    *k = inertia * Mat2::Identity();
    Vec2 normal;
    const double phi = distance(p, normal);
    if (phi < kContactDistance) {
      const double stiffness = kContactStiffness * m * kGravity / kContactDistance;
      const double depth = kContactDistance - phi;
      energy += 0.5 * stiffness * depth * depth;
      *g -= stiffness * depth * normal;
      *k += stiffness * normal * normal.transpose();
    }
    return energy;
  }

  /// The terms of Phi that involve particle i (exact law at mu), with gradient and block: the
  /// hat of width 1 centred on i.
  double local_energy(const Eigen::VectorXd& x, int i, double mu, Vec2* g, Mat2* k) const {
    return hat_energy(x, i, i, i, 1, mu, g, k);
  }

  static void add_block(std::vector<Eigen::Triplet<double>>& model, int a, int b,
                        const Mat2& k) {
    for (int r = 0; r < 2; ++r) {
      for (int c = 0; c < 2; ++c) model.emplace_back(2 * a + r, 2 * b + c, k(r, c));
    }
  }

  StripSettings s_;
  int n_;
  double h_;
  TensileBand tension_;
  BendingBand bending_;
  std::vector<double> mass_;
  Eigen::VectorXd x_, previous_x_, target_;
  std::vector<double> tension_prev_, strain_prev_, moment_prev_;
  std::vector<TiltedLaw> tilted_;
  mutable std::vector<double> edge_memory_, triple_memory_;
};

}  // namespace

StripLaw strip_tension_law(const TensileBand& band, double previous, double eps, double mu) {
  const double width = std::max(mu * previous, mu * 1e-3 * band.fm);
  return band_law(band, previous, eps, mu, width, mu * 1e-3 * band.fm * 1e-3);
}

StripLaw strip_tilted_tension_law(const TensileBand& band, double previous,
                                  double previous_strain, double stiffness, double eps) {
  return TiltedLaw(band, previous, previous_strain, stiffness).at(eps);
}

StripLaw strip_bending_law(const BendingBand& band, double previous, double kappa, double mu) {
  return band_law(band, previous, kappa, mu, std::max(mu * previous, mu * band.hb), 0.0);
}

namespace {

/// Linear interpolation from every `factor`-th particle of an n-particle strip ((n - 1) a
/// multiple of factor) to all of them, per coordinate.
Eigen::SparseMatrix<double> strip_prolongation(int n, int factor) {
  const int coarse = (n - 1) / factor + 1;
  std::vector<Eigen::Triplet<double>> entries;
  for (int i = 0; i < n; ++i) {
    const int left = i / factor;
    const double t = static_cast<double>(i - left * factor) / factor;
    for (int d = 0; d < 2; ++d) {
      entries.emplace_back(2 * i + d, 2 * left + d, 1.0 - t);
      if (t > 0.0) entries.emplace_back(2 * i + d, 2 * (left + 1) + d, t);
    }
  }
  Eigen::SparseMatrix<double> p(2 * n, 2 * coarse);
  p.setFromTriplets(entries.begin(), entries.end());
  return p;
}

/// Newton iterations on the coarse subspace x + P v: model P^T H P (the element tangents,
/// no reach), gradient P^T g, Armijo on the fine potential, the fine smoothing after each.
/// Stops at the tolerance or when the line search finds no decrease.
void coarse_iterations(const Strip& strip, const StripSettings& settings,
                       const Eigen::SparseMatrix<double>& prolongation, double mu,
                       Eigen::VectorXd& x, StripStep& record) {
  const Eigen::SparseMatrix<double> restriction = prolongation.transpose();
  Eigen::VectorXd gradient;
  std::vector<Eigen::Triplet<double>> blocks;
  Eigen::SparseMatrix<double> model(x.size(), x.size());
  for (int k = 0; k < settings.coarse_newton; ++k) {
    blocks.clear();
    const double energy = strip.evaluate(x, mu, &gradient, &blocks, nullptr);
    if (strip.residual(gradient) < settings.tolerance) return;
    model.setFromTriplets(blocks.begin(), blocks.end());
    const Eigen::SparseMatrix<double> coarse = restriction * model * prolongation;
    const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(coarse);
    if (solver.info() != Eigen::Success) return;
    const Eigen::VectorXd direction = prolongation * solver.solve(-(restriction * gradient));
    const double slope = gradient.dot(direction);
    double alpha = 1.0;
    bool decreased = false;
    for (int halving = 0; halving < 60 && !decreased; ++halving) {
      ++record.evaluations;
      decreased = strip.evaluate(x + alpha * direction, mu, nullptr, nullptr, nullptr) <=
                  energy + 1e-4 * alpha * slope;
      if (!decreased) alpha *= 0.5;
    }
    ++record.coarse;
    if (!decreased) return;
    x += alpha * direction;
    record.hat_moves += strip.smooth(x, mu);
  }
}

}  // namespace

StripResult run_strip(const StripSettings& settings, std::FILE* trace) {
  if (settings.particles < 3) throw std::invalid_argument("strip: fewer than 3 particles");
  if (settings.steps < 0 || !(settings.step_s > 0.0) || !(settings.tolerance > 0.0)) {
    throw std::invalid_argument("strip: steps, step or tolerance out of range");
  }
  if (settings.hat_levels < 0 || settings.hat_sweeps < 1 || settings.coarse_newton < 0) {
    throw std::invalid_argument("strip: hat levels, hat sweeps or coarse iterations out of range");
  }
  if (settings.inner_stiffness < 0.0 || (settings.inner_stiffness > 0.0 && settings.path_mu0 > 0.0)) {
    throw std::invalid_argument("strip: the tilted plateau is not combined with path-following");
  }
  if (settings.coarse_newton > 0 &&
      (settings.coarse_factor < 2 || settings.coarse_factor >= settings.particles - 1 ||
       (settings.particles - 1) % settings.coarse_factor != 0)) {
    throw std::invalid_argument("strip: the coarse factor must divide particles - 1 and leave "
                                "at least 3 coarse particles");
  }
  Strip strip(settings);
  const int n = strip.particles();
  const Eigen::SparseMatrix<double> prolongation =
      settings.coarse_newton > 0 ? strip_prolongation(n, settings.coarse_factor)
                                 : Eigen::SparseMatrix<double>();
  StripResult result;
  if (trace != nullptr) {
    std::fprintf(trace, "step,iteration,mu,residual,step_kept,branch_changes\n");
  }
  Eigen::VectorXd gradient(2 * n);
  Eigen::VectorXd exact(2 * n);
  for (int step = 0; step < settings.steps; ++step) {
    Eigen::VectorXd x = strip.begin_step();
    StripStep record;
    double mu = settings.path_mu0;
    double stage_first = -1.0;
    Eigen::VectorXd direction;
    bool have_direction = false;
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
    Eigen::SparseMatrix<double> model(2 * n, 2 * n);
    std::vector<Eigen::Triplet<double>> blocks;
    for (;;) {
      blocks.clear();
      const double energy = strip.evaluate(x, mu, &gradient, nullptr, nullptr);
      const double smoothed = strip.residual(gradient);
      double residual = smoothed;
      if (mu > 0.0) {
        strip.evaluate(x, 0.0, &exact, nullptr, nullptr);
        residual = strip.residual(exact);
      }
      record.residual = residual;
      if (residual < settings.tolerance) {
        record.converged = true;
        break;
      }
      if (mu > 0.0) {
        if (stage_first < 0.0) stage_first = smoothed;
        if (smoothed < std::max(settings.tolerance, settings.path_sigma * stage_first)) {
          mu *= settings.path_shrink;
          if (mu < settings.path_mu_min) mu = 0.0;
          stage_first = -1.0;
          continue;  // a new stage: evaluate again, not an iteration
        }
      }
      if (record.newton >= settings.max_iterations) break;
      ++record.newton;
      // The model reaches along the last direction, then along its own (refinements).
      for (int pass = 0; pass <= settings.model_refinements; ++pass) {
        blocks.clear();
        const Eigen::VectorXd* reach = have_direction ? &direction : nullptr;
        strip.evaluate(x, mu, nullptr, &blocks, reach);
        model.setFromTriplets(blocks.begin(), blocks.end());
        solver.compute(model);
        if (solver.info() != Eigen::Success) throw std::runtime_error("strip: model not SPD");
        direction = solver.solve(-gradient);
        have_direction = true;
        if (!settings.reach) break;
      }
      const double slope = gradient.dot(direction);
      double alpha = 1.0;
      bool decreased = false;
      for (int halving = 0; halving < 60; ++halving, alpha *= 0.5) {
        ++record.evaluations;
        const Eigen::VectorXd trial = x + alpha * direction;
        if (strip.evaluate(trial, mu, nullptr, nullptr, nullptr) <= energy + 1e-4 * alpha * slope) {
          decreased = true;
          break;
        }
      }
      if (!decreased) break;  // no decrease along Newton's direction: the step failed
      const Eigen::VectorXd next = x + alpha * direction;
      if (trace != nullptr) {
        std::fprintf(trace, "%d,%d,%.3e,%.6e,%.6g,%d\n", step, record.newton, mu, residual, alpha,
                     strip.branch_changes(x, next));
      }
      x = next;
      record.hat_moves += strip.smooth(x, mu);
      if (settings.coarse_newton > 0) {
        coarse_iterations(strip, settings, prolongation, mu, x, record);
      }
    }
    strip.end_step(x);
    result.newton += record.newton;
    result.evaluations += record.evaluations;
    result.coarse += record.coarse;
    result.hat_moves += record.hat_moves;
    result.all_converged = result.all_converged && record.converged;
    result.steps.push_back(record);
  }
  const Eigen::VectorXd& x = strip.positions();
  result.lowest_z = x(1);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d p = x.segment<2>(2 * i);
    result.positions.push_back(p);
    result.lowest_z = std::min(result.lowest_z, p.y());
    Eigen::Vector2d normal;
    result.deepest_penetration =
        std::max(result.deepest_penetration, -Strip::distance(p, normal));
  }
  return result;
}

}  // namespace clothbench::kernels
