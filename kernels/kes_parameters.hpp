// KES (Kawabata Evaluation System) parameters of a fabric, in Kawabata's units.
// Converted once to SI by kes_material.hpp (1 gf = 9.80665e-3 N). MODEL.md section 3.
#pragma once

namespace clothbench::kernels {

/// Tensile and bending KES data of one thread direction (warp or weft).
struct KesDirection {
  double emt_percent = 5.0;       ///< EMT: strain at the maximum load Fm, percent
  double lt = 0.65;               ///< LT: linearity of the loading curve, dimensionless (0, 2)
  double rt_percent = 50.0;       ///< RT: resilience, percent (0, 100]
  double bending_b = 0.05;        ///< B: bending rigidity, gf cm^2 / cm
  double bending_2hb = 0.05;      ///< 2HB: bending hysteresis width, gf cm / cm
};

/// One fabric: KES data per direction plus areal weight and thickness.
struct KesParameters {
  KesDirection warp;                ///< along grid index i
  KesDirection weft;                ///< along grid index j
  double weight_mg_per_cm2 = 15.0;  ///< W: areal weight, mg / cm^2
  double thickness_mm = 0.3;        ///< T: thickness at 0.5 gf/cm^2, mm
  double fm_gf_per_cm = 500.0;      ///< Fm: maximum tensile load of the KES test, gf / cm
  double kappa0_per_cm = 0.1;       ///< kappa0 of the bending band's smooth closure, 1 / cm
  /// R: the force's slope inside the tensile band in units of Fm / EMT (an opt-in variant of
  /// the model, kernels/tilted_plateau.hpp); 0 keeps MODEL.md 4B's flat plateau. 0 <= R < p.
  double tension_plateau_slope = 0.0;
};

}  // namespace clothbench::kernels
