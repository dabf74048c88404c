// Every shipped fabric preset reproduces its own KES tensile figures (EMT, LT, RT) when its
// band curves are "measured" again by numerical integration (MODEL.md section 3).
#include <gtest/gtest.h>

#include <filesystem>

#include "harness/scene/scene.hpp"
#include "kernels/kes_material.hpp"

namespace clothbench {
namespace {

TEST(FabricPresets, EveryPresetReproducesItsOwnTensileFigures) {
  const std::filesystem::path presets =
      std::filesystem::path(CLOTHBENCH_SOURCE_DIR) / "scenarios" / "presets" / "fabrics.toml";
  const auto names = harness::fabric_preset_names(presets);
  ASSERT_FALSE(names.empty());
  for (const std::string& name : names) {
    const kernels::KesParameters p = harness::load_fabric_preset(presets, name);
    for (const kernels::KesDirection* d : {&p.warp, &p.weft}) {
      const kernels::TensileBand band = kernels::TensileBand::from_kes(*d, p.fm_gf_per_cm);
      const kernels::KesDirection measured = kernels::remeasure_tensile(band);
      EXPECT_NEAR(measured.emt_percent / d->emt_percent, 1.0, 1e-6) << name;
      EXPECT_NEAR(measured.lt / d->lt, 1.0, 1e-6) << name;
      EXPECT_NEAR(measured.rt_percent / d->rt_percent, 1.0, 1e-6) << name;
    }
    // The bending band closes at zero curvature and its unloading branch never goes negative.
    const kernels::FabricMaterial material = kernels::FabricMaterial::from_kes(p);
    for (const kernels::BendingBand& b : material.bending) {
      EXPECT_EQ(b.loading(0.0), 0.0) << name;
      EXPECT_EQ(b.unloading(0.0), 0.0) << name;
      for (double kappa : {0.1, 1.0, 10.0, 100.0}) {
        EXPECT_GE(b.unloading(kappa), 0.0) << name;
        EXPECT_GT(b.loading(kappa), b.unloading(kappa)) << name << " kappa " << kappa;
      }
    }
  }
}

}  // namespace
}  // namespace clothbench
