// The simulated magnetic field: the exact dipole formula, its fall-off, a source-free background,
// and magnitudes like those measured in steel buildings.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "mm4mm/sim/magnetic_field.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace mm4mm::sim {
namespace {

TEST(DipoleField, MatchesAxialAndEquatorialFormulas) {
  const Eigen::Vector3d m(0, 0, 50.0);  // A·m²
  // On the axis: B = μ0/4π · 2m / r³; in the equatorial plane: −μ0/4π · m / r³.
  const double r = 1.7;
  EXPECT_NEAR(dipoleField(m, {0, 0, r}).z(), 0.1 * 2 * 50.0 / (r * r * r), 1e-12);
  EXPECT_NEAR(dipoleField(m, {r, 0, 0}).z(), -0.1 * 50.0 / (r * r * r), 1e-12);
  EXPECT_NEAR(dipoleField(m, {r, 0, 0}).head<2>().norm(), 0.0, 1e-12);
}

TEST(DipoleField, FallsOffWithTheCubeOfDistance) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d m(g(rng), g(rng), g(rng));
    const Eigen::Vector3d r = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const Eigen::Vector3d near = dipoleField(m, r);
    const Eigen::Vector3d far = dipoleField(m, 2.0 * r);
    EXPECT_TRUE((near / 8.0).isApprox(far, 1e-12));
  }
}

// Outside the sources a magnetic field has zero divergence and zero curl; check both numerically
// for the whole model (background plus every dipole, no cutoff) away from the steel.
TEST(MagneticFieldModel, IsDivergenceAndCurlFree) {
  SimulationConfig config;
  config.steel.cutoff_radius_m = 1000.0;
  const SimulatedWorld world(config, 11);
  const double h = 1e-4;
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(20.1, 15.1, 0.3), Eigen::Vector3d(43.2, 37.1, 1.1),
        Eigen::Vector3d(5.3, 5.2, 0.3)}) {
    Eigen::Matrix3d J;  // J(i, j) = ∂B_i/∂x_j
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d dp = h * Eigen::Vector3d::Unit(j);
      J.col(j) = (world.field.fieldAt(p + dp) - world.field.fieldAt(p - dp)) / (2 * h);
    }
    const double tolerance = 1e-5 * J.norm() + 1e-6;
    EXPECT_GT(J.norm(), 0.1);  // the field does vary here, so the check means something
    EXPECT_NEAR(J.trace(), 0.0, tolerance) << "divergence at " << p.transpose();
    EXPECT_NEAR((J - J.transpose()).norm(), 0.0, tolerance) << "curl at " << p.transpose();
  }
}

// The cutoff that keeps simulation fast changes the field by about the sensor noise at most: the
// long steel members' far field falls off slowly.
TEST(MagneticFieldModel, CutoffRadiusChangesFieldLessThanSensorNoise) {
  SimulationConfig config;
  const SimulatedWorld fast(config, 4);
  config.steel.cutoff_radius_m = 1000.0;
  const SimulatedWorld exact(config, 4);
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> ux(2.0, 83.0), uy(2.0, 73.0);
  double worst = 0.0, sum = 0.0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(ux(rng), uy(rng), 0.3);
    const double error = (fast.field.fieldAt(p) - exact.field.fieldAt(p)).norm();
    worst = std::max(worst, error);
    sum += error;
  }
  EXPECT_LT(sum / 200, config.rig.magnetometer_noise_uT);
  EXPECT_LT(worst, 1.5 * config.rig.magnetometer_noise_uT);
}

TEST(MagneticFieldModel, EarthFieldHasConfiguredMagnitudeAndDip) {
  SimulationConfig config;
  const SimulatedWorld world(config, 3);
  const Eigen::Vector3d earth = world.field.earthField();
  EXPECT_NEAR(earth.norm(), config.earth.magnitude_uT, 1e-9);
  EXPECT_NEAR(std::asin(-earth.z() / earth.norm()) * 180 / M_PI, config.earth.inclination_deg,
              1e-9);
}

// Typical deviations from the Earth's field at sensor height: tens of µT half a metre from the
// steel, a few µT in the middle of an aisle.
TEST(MagneticFieldModel, AnomaliesAreStrongNearSteelAndWeakInAisles) {
  SimulationConfig config;
  const SimulatedWorld world(config, 7);
  std::vector<double> near_steel, aisle_centre, background;
  // Aisle centre lines are the lane edges along x between rows; shelves are 2 m to either side.
  for (std::size_t a = 0; a < world.world.lanes.nodes.size(); ++a)
    for (int b : world.world.lanes.neighbours[a]) {
      const Eigen::Vector2d pa = world.world.lanes.nodes[a], pb = world.world.lanes.nodes[b];
      if (std::abs(pa.y() - pb.y()) > 1e-6) continue;  // along-x edges only
      for (double s = 0.1; s < 0.9; s += 0.01) {
        const Eigen::Vector2d p = (1 - s) * pa + s * pb;
        const Eigen::Vector3d centre(p.x(), p.y(), 0.3);
        aisle_centre.push_back(world.field.anomalyAt(centre).norm());
        if (world.raycaster.clearance(p + Eigen::Vector2d(0, 1.5), 0.0, 1.0, 3.0) < 0.6)
          near_steel.push_back(world.field.anomalyAt(centre + Eigen::Vector3d(0, 1.5, 0)).norm());
        background.push_back(world.field.backgroundAt(centre).norm());
      }
    }
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  ASSERT_GT(near_steel.size(), 100u);
  EXPECT_GT(median(near_steel), 10.0);
  EXPECT_LT(median(near_steel), 80.0);
  EXPECT_GT(median(aisle_centre), 0.5);
  EXPECT_LT(median(aisle_centre), 8.0);
  EXPECT_GT(median(background), 0.5);
  EXPECT_LT(median(background), 8.0);
  std::printf("median |anomaly|: near steel %.1f µT, aisle centre %.1f µT; background %.1f µT\n",
              median(near_steel), median(aisle_centre), median(background));
}

// Two identical pillars differ magnetically: the moments are random.
TEST(MagneticFieldModel, IdenticalPlacesDifferMagnetically) {
  SimulationConfig config;
  config.world = "corridor";
  const SimulatedWorld world(config, 5);
  // Same offset from two pillars of the same row, 8 m apart.
  const Eigen::Vector3d a(4.0 + 0.8, 6.67, 0.3), b(12.0 + 0.8, 6.67, 0.3);
  EXPECT_GT((world.field.anomalyAt(a) - world.field.anomalyAt(b)).norm(), 2.0);
}

}  // namespace
}  // namespace mm4mm::sim
