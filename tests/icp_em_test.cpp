// ICP-EM (paper Eq. 7-11): Jacobians of the Ceres costs against finite differences, recovery of
// known transforms on synthetic, simulated and real LiDAR clouds, the prior holding the seed
// along a degenerate corridor, overlap regions, and rejection of bad input.

#include "mm4mm/geometry/icp_em.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>

#include "../src/geometry/icp_em_costs.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/geometry/point_map.hpp"
#include "mm4mm/io/pcd_io.hpp"
#include "mm4mm/magnetic/overlap_region.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace mm4mm {
namespace {

constexpr double kDeg = M_PI / 180.0;

// ---------------------------------------------------------------------------------------------
// Synthetic scenes: axis-aligned boxes sampled on their faces.

struct Box {
  Eigen::Vector3d min, max;
  bool inside_view = false;  // a room seen from inside (its faces), else a solid seen from outside
};

// Uniform random points on the faces of `boxes`, `density` points per m², with Gaussian noise.
PointCloud sampleBoxes(const std::vector<Box>& boxes, double density, double noise_m,
                       std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_m);
  PointCloud cloud;
  for (const Box& box : boxes) {
    const Eigen::Vector3d size = box.max - box.min;
    for (int axis = 0; axis < 3; ++axis) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const double area = size[u] * size[v];
      const int count = static_cast<int>(area * density);
      for (int side = 0; side < 2; ++side) {
        if (!box.inside_view && axis == 2 && side == 0) continue;  // a solid's underside
        for (int k = 0; k < count; ++k) {
          Eigen::Vector3d p;
          p[axis] = side == 0 ? box.min[axis] : box.max[axis];
          p[u] = box.min[u] + unit(rng) * size[u];
          p[v] = box.min[v] + unit(rng) * size[v];
          p += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
          cloud.push_back(p.cast<float>());
        }
      }
    }
  }
  return cloud;
}

// A 24 m x 16 m x 4 m hall with pillars and crates: every direction is constrained.
std::vector<Box> hallScene() {
  std::vector<Box> boxes = {{{-12, -8, 0}, {12, 8, 4}, true}};
  for (double x : {-6.0, 0.0, 6.0})
    for (double y : {-3.0, 3.0}) boxes.push_back({{x - 0.3, y - 0.3, 0}, {x + 0.3, y + 0.3, 4}});
  boxes.push_back({{-10, -7, 0}, {-8, -6, 1.5}});
  boxes.push_back({{8, 5, 0}, {9.5, 7, 2.0}});
  boxes.push_back({{2, -7.5, 0}, {3, -5, 1.0}});
  return boxes;
}

PointCloud transformed(const PointCloud& cloud, const Eigen::Isometry3d& T) {
  PointCloud out;
  out.reserve(cloud.size());
  for (const Eigen::Vector3f& p : cloud) out.push_back((T * p.cast<double>()).cast<float>());
  return out;
}

double translationError(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  return (estimate.translation() - truth.translation()).norm();
}
double rotationErrorDeg(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  return rotationAngle(estimate.rotation() * truth.rotation().transpose()) / kDeg;
}

// The seed the tests start from: the truth moved by `metres` and turned by `degrees` about a
// tilted axis.
Eigen::Isometry3d perturbed(const Eigen::Isometry3d& truth, double metres, double degrees) {
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  delta.translation() = metres * Eigen::Vector3d(0.6, -0.7, 0.2).normalized();
  delta.linear() =
      Eigen::AngleAxisd(degrees * kDeg, Eigen::Vector3d(0.2, 0.1, 1.0).normalized()).matrix();
  return truth * delta;
}

// ---------------------------------------------------------------------------------------------
// Ceres costs.

std::vector<icp_em::Correspondence> randomPairs(int count, double offset_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<icp_em::Correspondence> pairs(count);
  for (auto& c : pairs) {
    c.a = Eigen::Vector3d::Constant(offset_m) + 5.0 * Eigen::Vector3d(g(rng), g(rng), g(rng));
    c.b = Eigen::Vector3d::Constant(-offset_m) + 5.0 * Eigen::Vector3d(g(rng), g(rng), g(rng));
    for (int i = 0; i < 9; ++i) c.whitening(i) = g(rng);
  }
  return pairs;
}

TEST(IcpEmCosts, CompressedCorrespondencesCostPassesGradientChecker) {
  const std::vector<icp_em::Correspondence> pairs = randomPairs(7, 30.0, 3);
  const icp_em::CompressedCorrespondencesCost cost(pairs);
  std::mt19937 rng(4);
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Quaterniond q = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized();
  double q_xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
  double t[3] = {g(rng), g(rng), g(rng)};
  const double* parameters[2] = {q_xyzw, t};
  const ceres::EigenQuaternionManifold quaternion_manifold;
  const std::vector<const ceres::Manifold*> manifolds = {&quaternion_manifold, nullptr};
  const ceres::GradientChecker checker(&cost, &manifolds, ceres::NumericDiffOptions());
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(parameters, 1e-7, &results)) << results.error_log;
}

// The compression is exact: ½|r|² + constant is the plain sum of squares at any pose, also for
// points far from the origin and for fewer pairs than the twelve unknowns (a singular Q).
TEST(IcpEmCosts, CompressionEqualsThePlainSumOfSquares) {
  for (const int count : {2, 50}) {
    const std::vector<icp_em::Correspondence> pairs = randomPairs(count, 300.0, 5);
    const icp_em::CompressedCorrespondencesCost cost(pairs);
    for (const Eigen::Isometry3d& T :
         {Eigen::Isometry3d::Identity(), poseFromRpy({2.0, -1.0, 0.5}, 0.1, -0.2, 2.0),
          poseFromRpy({600.0, 600.0, 600.0}, 0.0, 0.0, -1.0)}) {
      double plain = 0.0;
      for (const auto& c : pairs) plain += 0.5 * (c.whitening * (c.a - T * c.b)).squaredNorm();
      const Eigen::Quaterniond q(T.rotation());
      double q_xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
      const double* parameters[2] = {q_xyzw, T.translation().data()};
      Eigen::Matrix<double, 12, 1> residuals;
      ASSERT_TRUE(cost.Evaluate(parameters, residuals.data(), nullptr));
      EXPECT_NEAR(0.5 * residuals.squaredNorm() + cost.constant(), plain, 1e-9 * plain)
          << count << " pairs";
    }
  }
}

TEST(IcpEmCosts, SeedPriorPassesGradientChecker) {
  const Eigen::Isometry3d seed = poseFromRpy({3.0, -2.0, 0.4}, 0.02, -0.03, 2.5);
  Eigen::Matrix<double, 6, 1> sqrt_info;
  sqrt_info << 1.0, 1.0, 2.0, 28.0, 28.0, 11.0;
  std::unique_ptr<ceres::CostFunction> cost(icp_em::SeedPriorCost::Create(seed, sqrt_info));
  // Away from the seed (the general branch) and at it (ceres' small-angle branch).
  for (const Eigen::Isometry3d& at : {perturbed(seed, 0.7, 9.0), seed}) {
    const Eigen::Quaterniond q(at.rotation());
    double q_xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
    double t[3] = {at.translation().x(), at.translation().y(), at.translation().z()};
    const double* parameters[2] = {q_xyzw, t};
    const ceres::EigenQuaternionManifold quaternion_manifold;
    const std::vector<const ceres::Manifold*> manifolds = {&quaternion_manifold, nullptr};
    const ceres::GradientChecker checker(cost.get(), &manifolds, ceres::NumericDiffOptions());
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(checker.Probe(parameters, 1e-7, &results)) << results.error_log;
  }
  // The residual is the whitened deviation: 0.5 m along x of frame a and 4° of yaw.
  Eigen::Isometry3d at = seed;
  at.translation().x() += 0.5;
  at.linear() = seed.linear() * rotationZ(4.0 * kDeg);
  const Eigen::Quaterniond q(at.rotation());
  double q_xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
  double t[3] = {at.translation().x(), at.translation().y(), at.translation().z()};
  const double* parameters[2] = {q_xyzw, t};
  double residuals[6];
  ASSERT_TRUE(cost->Evaluate(parameters, residuals, nullptr));
  EXPECT_NEAR(residuals[0], 0.5, 1e-12);
  EXPECT_NEAR(residuals[5], 11.0 * 4.0 * kDeg, 1e-9);
  for (int k : {1, 2, 3, 4}) EXPECT_NEAR(residuals[k], 0.0, 1e-9);
}

// ---------------------------------------------------------------------------------------------
// Registration.

TEST(IcpEm, PointMapFromCloudMatchesTheSessionBuilder) {
  const PointCloud cloud = sampleBoxes(hallScene(), 5.0, 0.01, 1);
  Session session;
  session.rig.magnetometers_body = {Eigen::Vector3d::Zero()};
  session.keyframes.push_back({0.0, Eigen::Isometry3d::Identity()});
  session.scans.push_back(cloud);
  PointMapConfig config;
  config.voxel_size_m = 0.5;
  const PointMap from_session = buildPointMap(session, config);
  PointCloud with_nan = cloud;
  with_nan.emplace_back(std::nanf(""), 0.0f, 0.0f);
  const PointMap from_cloud = buildPointMapFromCloud(with_nan, config);
  ASSERT_EQ(from_cloud.size(), from_session.size());
  EXPECT_EQ(from_cloud.input_points, cloud.size());
  for (std::size_t i = 0; i < from_cloud.size(); ++i) {
    ASSERT_EQ(from_cloud.points[i], from_session.points[i]);
    ASSERT_TRUE(from_cloud.covariances[i].isApprox(from_session.covariances[i]));
  }
  // Far points stay: there is no range filter without a sensor position.
  config.max_range_m = 1.0;
  EXPECT_EQ(buildPointMapFromCloud(cloud, config).size(), from_session.size());
}

TEST(IcpEm, RecoversAKnownTransformInAStructuredHall) {
  const std::vector<Box> scene = hallScene();
  const Eigen::Isometry3d T_a_b = poseFromRpy({1.3, -0.8, 0.05}, 0.01, -0.015, 0.6);
  const PointCloud target = sampleBoxes(scene, 40.0, 0.01, 1);
  const PointCloud source = transformed(sampleBoxes(scene, 40.0, 0.01, 2), T_a_b.inverse());
  const Eigen::Isometry3d seed = perturbed(T_a_b, 0.5, 3.0);

  const IcpEmResult result = refineIcpEm(target, source, seed, IcpEmConfig{});
  EXPECT_TRUE(result.converged);
  EXPECT_LT(translationError(result.T_a_b, T_a_b), 0.02);
  EXPECT_LT(rotationErrorDeg(result.T_a_b, T_a_b), 0.1);
  EXPECT_GT(result.inlier_ratio, 0.9);
  EXPECT_FALSE(result.degenerate) << result.hessian_eigenvalues.transpose();
  EXPECT_GT(result.hessian_eigenvalues[0], 1e-2 * result.hessian_eigenvalues[5]);
  // The information is symmetric positive definite in a constrained scene.
  EXPECT_TRUE(result.information.isApprox(result.information.transpose()));
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  const Eigen::SelfAdjointEigenSolver<Matrix6d> information(result.information);
  EXPECT_GT(information.eigenvalues()[0], 0.0);

  // Deterministic: a second run gives the same bits.
  const IcpEmResult again = refineIcpEm(target, source, seed, IcpEmConfig{});
  EXPECT_TRUE(again.T_a_b.matrix() == result.T_a_b.matrix());
  EXPECT_EQ(again.iterations, result.iterations);
}

// Eq. 7's prior at work where the geometry is well constrained: a prior far tighter than the
// geometry keeps the seed, none at all (pure maximum likelihood, Eq. 8) gives the truth.
TEST(IcpEm, PriorWeighsAgainstTheGeometry) {
  const std::vector<Box> scene = hallScene();
  const Eigen::Isometry3d T_a_b = poseFromRpy({1.3, -0.8, 0.05}, 0.01, -0.015, 0.6);
  const PointCloud target = sampleBoxes(scene, 10.0, 0.01, 1);
  const PointCloud source = transformed(sampleBoxes(scene, 10.0, 0.01, 2), T_a_b.inverse());
  const Eigen::Isometry3d seed = perturbed(T_a_b, 0.3, 2.0);
  IcpEmConfig config;
  config.prior_sigma_horizontal_m = config.prior_sigma_vertical_m = 1e-5;
  config.prior_sigma_yaw_deg = config.prior_sigma_tilt_deg = 1e-4;
  const IcpEmResult tight = refineIcpEm(target, source, seed, config);
  EXPECT_LT(translationError(tight.T_a_b, seed), 0.005);
  EXPECT_LT(rotationErrorDeg(tight.T_a_b, seed), 0.02);
  config.prior_sigma_horizontal_m = config.prior_sigma_vertical_m =
      std::numeric_limits<double>::infinity();
  config.prior_sigma_yaw_deg = config.prior_sigma_tilt_deg =
      std::numeric_limits<double>::infinity();
  const IcpEmResult none = refineIcpEm(target, source, seed, config);
  EXPECT_LT(translationError(none.T_a_b, T_a_b), 0.02);
  EXPECT_LT(rotationErrorDeg(none.T_a_b, T_a_b), 0.1);
}

// A straight corridor (two walls, floor, ceiling): nothing fixes the position along x, so the
// estimate must stay at the seed there while the other five directions are recovered.
TEST(IcpEm, PriorHoldsTheSeedAlongADegenerateCorridor) {
  const PointCloud target = sampleBoxes({{{0, -2, 0}, {60, 2, 3}, true}}, 40.0, 0.01, 1);
  // The source sees the middle 30 m: its ends are open, not walls the target lacks.
  PointCloud middle;
  for (const Eigen::Vector3f& p : sampleBoxes({{{0, -2, 0}, {60, 2, 3}, true}}, 40.0, 0.01, 2))
    if (p.x() > 15.0 && p.x() < 45.0) middle.push_back(p);
  const Eigen::Isometry3d T_a_b = poseFromRpy({20.0, 0.1, 0.0}, 0.0, 0.0, 0.02);
  const PointCloud source = transformed(middle, T_a_b.inverse());
  Eigen::Isometry3d seed = T_a_b;
  seed.translation() += Eigen::Vector3d(0.6, -0.25, 0.1);
  seed.linear() = seed.linear() * rotationZ(2.0 * kDeg);

  const IcpEmResult result = refineIcpEm(target, source, seed, IcpEmConfig{});
  EXPECT_TRUE(result.degenerate) << result.hessian_eigenvalues.transpose();
  EXPECT_GT(std::abs(result.weakest_direction[0]), 0.99) << result.weakest_direction.transpose();
  // Along the corridor: the seed; across it: the truth.
  EXPECT_NEAR(result.T_a_b.translation().x(), seed.translation().x(), 0.05);
  EXPECT_NEAR(result.T_a_b.translation().y(), T_a_b.translation().y(), 0.02);
  EXPECT_NEAR(result.T_a_b.translation().z(), T_a_b.translation().z(), 0.02);
  EXPECT_LT(rotationErrorDeg(result.T_a_b, T_a_b), 0.1);
  // The information says so: almost nothing along x, plenty across.
  EXPECT_LT(result.information(0, 0), 1e-3 * result.information(1, 1));
}

// A short simulated warehouse session at its true poses: the first two thirds of the keyframes
// are the target, the last two thirds, moved into a frame b, the source.
TEST(IcpEm, RecoversAKnownTransformBetweenSimulatedSubmaps) {
  sim::SimulationConfig config;
  config.world = "warehouse";
  config.layout.route_length_m = 36.0;
  config.lidar.azimuth_step_deg = 2.0;
  std::vector<Session> sessions = sim::simulateSessions(config, 1, 5);
  const Session& session = sessions.front();
  ASSERT_TRUE(session.ground_truth.has_value());
  const std::size_t n = session.keyframes.size();
  ASSERT_GT(n, 20u);
  const Eigen::Isometry3d T_a_b = poseFromRpy({-2.0, 1.5, 0.0}, 0.0, 0.0, 2.0);
  PointCloud target, source;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Isometry3d& T_world_body = (*session.ground_truth)[k].T_frame_body;
    if (3 * k < 2 * n)
      for (const Eigen::Vector3f& p : transformed(session.scans[k], T_world_body))
        target.push_back(p);
    if (3 * k >= n)
      for (const Eigen::Vector3f& p : transformed(session.scans[k], T_a_b.inverse() * T_world_body))
        source.push_back(p);
  }
  const Eigen::Isometry3d seed = perturbed(T_a_b, 0.5, 3.0);
  const IcpEmResult result = refineIcpEm(target, source, seed, IcpEmConfig{});
  EXPECT_TRUE(result.converged);
  EXPECT_LT(translationError(result.T_a_b, T_a_b), 0.02);
  EXPECT_LT(rotationErrorDeg(result.T_a_b, T_a_b), 0.1);
  EXPECT_FALSE(result.degenerate) << result.hessian_eigenvalues.transpose();
}

Eigen::Isometry3d readMatrix(const std::filesystem::path& file) {
  std::ifstream in(file);
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) in >> m(i / 4, i % 4);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  Eigen::Isometry3d T;
  T.matrix() = m;
  return T;
}

// Two real scans of a spinning LiDAR (koide3/fast_gicp and small_gicp test data) and the
// reference transform those projects register them to.
TEST(IcpEm, RecoversTheReferenceTransformOfARealLidarPair) {
  const std::filesystem::path dir =
      std::filesystem::path(MM4MM_SHARED_DATA_DIR) / "koide-gicp-lidar-scan-pair";
  ASSERT_TRUE(std::filesystem::exists(dir / "fast_gicp" / "251370668.pcd"))
      << "no LiDAR pair in " << dir;
  const PointCloud target = readPcd(dir / "fast_gicp" / "251370668.pcd");
  const PointCloud source = readPcd(dir / "fast_gicp" / "251371071.pcd");
  const Eigen::Isometry3d reference = readMatrix(dir / "small_gicp" / "T_target_source.txt");
  const Eigen::Isometry3d other = readMatrix(dir / "fast_gicp" / "relative.txt");
  const Eigen::Isometry3d seed = perturbed(reference, 0.5, 3.0);

  const IcpEmResult result = refineIcpEm(target, source, seed, IcpEmConfig{});
  EXPECT_TRUE(result.converged);
  // The references, themselves registrations, differ by 1.9 cm and 0.23°: within a few cm and
  // a few tenths of a degree of both.
  for (const Eigen::Isometry3d& truth : {reference, other}) {
    EXPECT_LT(translationError(result.T_a_b, truth), 0.04);
    EXPECT_LT(rotationErrorDeg(result.T_a_b, truth), 0.4);
  }
  EXPECT_FALSE(result.degenerate);
}

// ---------------------------------------------------------------------------------------------
// Overlap regions.

// A map covering [x0, x0 + w) x [y0, y0 + h) of its frame with 0.1 m cells, inside a larger grid.
MagneticMap rectangleMap(double x0, double y0, double w, double h) {
  MagneticMap map;
  map.cell_size_m = 0.1;
  map.origin_m = Eigen::Vector2d(x0 - 1.0, y0 - 1.0);
  map.width = static_cast<int>(std::round((w + 2.0) / 0.1));
  map.height = static_cast<int>(std::round((h + 2.0) / 0.1));
  const std::size_t cells = static_cast<std::size_t>(map.width) * map.height;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  map.horizontal_uT.assign(cells, nan);
  map.vertical_uT.assign(cells, nan);
  map.total_uT.assign(cells, nan);
  for (int iy = 0; iy < map.height; ++iy)
    for (int ix = 0; ix < map.width; ++ix) {
      const Eigen::Vector2d c = map.cellCentre(ix, iy);
      if (c.x() > x0 && c.x() < x0 + w && c.y() > y0 && c.y() < y0 + h)
        map.horizontal_uT[map.index(ix, iy)] = map.vertical_uT[map.index(ix, iy)] =
            map.total_uT[map.index(ix, iy)] = 40.0f;
    }
  return map;
}

TEST(OverlapRegion, CoversWhereBothMapsAreDilatedByTheMargin) {
  // a covers x in [0, 10), y in [0, 4); b the same in its own frame, which sits 5 m along a's x
  // and is turned by 180° about its centre line: in a, b covers x in [5, 15).
  const MagneticMap a = rectangleMap(0.0, 0.0, 10.0, 4.0);
  const MagneticMap b = rectangleMap(0.0, 0.0, 10.0, 4.0);
  const Eigen::Isometry3d T_a_b = planarPose(15.0, 4.0, M_PI);
  const PlanarRegion tight = overlapRegion(a, b, T_a_b, 0.0, 0.2);
  EXPECT_NEAR(tight.cell_size_m, 0.2, 1e-12);
  EXPECT_NEAR(tight.insideCells() * 0.04, 5.0 * 4.0, 1.0);  // the 5 m x 4 m overlap
  EXPECT_TRUE(tight.contains({7.5, 2.0}));
  EXPECT_FALSE(tight.contains({4.5, 2.0}));   // only a
  EXPECT_FALSE(tight.contains({12.0, 2.0}));  // only b
  EXPECT_FALSE(tight.contains({7.5, -0.5}));

  const PlanarRegion wide = overlapRegion(a, b, T_a_b, 2.0, 0.2);
  EXPECT_TRUE(wide.contains({3.3, 2.0}));   // 1.7 m before the overlap
  EXPECT_TRUE(wide.contains({11.7, 2.0}));  // beyond a's map: the LiDAR sees farther
  EXPECT_TRUE(wide.contains({7.5, -1.7}));  // beyond a's grid
  EXPECT_FALSE(wide.contains({2.5, 2.0}));  // 2.5 m away
  EXPECT_FALSE(wide.contains({7.5, 6.5}));
  EXPECT_FALSE(wide.contains({11.5, 5.5}));  // diagonal: 1.5 m and 1.5 m is 2.1 m from a corner
  EXPECT_FALSE(wide.contains({std::nan(""), 0.0}));

  // Disjoint maps: no region at all.
  EXPECT_EQ(overlapRegion(a, b, planarPose(40.0, 0.0, 0.0), 2.0).insideCells(), 0u);
  EXPECT_THROW(overlapRegion(a, b, T_a_b, -1.0), std::invalid_argument);
}

TEST(OverlapRegion, DilationIsADisk) {
  PlanarRegion one;
  one.cell_size_m = 0.25;
  one.width = one.height = 1;
  one.inside = {1};  // the cell [0, 0.25)²; its centre is (0.125, 0.125)
  const PlanarRegion disk = dilateRegion(one, 2.0);
  const double area = disk.insideCells() * 0.25 * 0.25;
  EXPECT_NEAR(area, M_PI * 4.0, 0.6);
  EXPECT_TRUE(disk.contains({0.125 + 1.9, 0.125}));
  EXPECT_FALSE(disk.contains({0.125 + 2.2, 0.125}));
  EXPECT_TRUE(disk.contains({0.125 + 1.3, 0.125 + 1.3}));   // 1.84 m
  EXPECT_FALSE(disk.contains({0.125 + 1.6, 0.125 + 1.6}));  // 2.26 m
}

TEST(IcpEm, AssociatesOnlyInsideTheOverlapRegion) {
  const std::vector<Box> scene = hallScene();
  const Eigen::Isometry3d T_a_b = planarPose(0.4, 0.3, 0.1);
  const PointCloud target = sampleBoxes(scene, 20.0, 0.01, 1);
  PointCloud source = transformed(sampleBoxes(scene, 20.0, 0.01, 2), T_a_b.inverse());
  const Eigen::Isometry3d seed = perturbed(T_a_b, 0.3, 2.0);
  // A region covering the hall's west half: the result stays right.
  PlanarRegion west;
  west.origin_m = Eigen::Vector2d(-13.0, -9.0);
  west.cell_size_m = 0.5;
  west.width = 26;   // x in [-13, 0)
  west.height = 36;  // y in [-9, 9)
  west.inside.assign(west.width * west.height, 1);
  const IcpEmResult half = refineIcpEm(target, source, seed, IcpEmConfig{}, &west);
  EXPECT_TRUE(half.converged);
  EXPECT_LT(translationError(half.T_a_b, T_a_b), 0.02);
  EXPECT_LT(rotationErrorDeg(half.T_a_b, T_a_b), 0.1);
  const IcpEmResult whole = refineIcpEm(target, source, seed, IcpEmConfig{});
  EXPECT_LT(half.correspondences, 0.7 * whole.correspondences);
  EXPECT_GT(half.correspondences, 0.3 * whole.correspondences);

  // A region away from all points: nothing associates, the seed comes back unconverged.
  PlanarRegion elsewhere = west;
  elsewhere.origin_m = Eigen::Vector2d(100.0, 100.0);
  const IcpEmResult none = refineIcpEm(target, source, seed, IcpEmConfig{}, &elsewhere);
  EXPECT_FALSE(none.converged);
  EXPECT_TRUE(none.T_a_b.matrix() == seed.matrix());
  EXPECT_EQ(none.inlier_ratio, 0.0);
  EXPECT_TRUE(none.degenerate);
}

// ---------------------------------------------------------------------------------------------
// Bad input.

TEST(IcpEm, RejectsInvalidConfigAndSeed) {
  const auto expect_invalid = [](const IcpEmConfig& config, const std::string& field) {
    std::string error;
    EXPECT_FALSE(config.IsValid(&error)) << field;
    EXPECT_NE(error.find(field), std::string::npos) << error;
    EXPECT_THROW(refineIcpEm({{0, 0, 0}}, {{0, 0, 0}}, Eigen::Isometry3d::Identity(), config),
                 std::invalid_argument);
  };
  IcpEmConfig config;
  EXPECT_TRUE(config.IsValid(nullptr));
  config.voxel_sizes_m = {};
  expect_invalid(config, "voxel_sizes_m");
  config.voxel_sizes_m = {0.25, 0.5};  // fine to coarse
  expect_invalid(config, "voxel_sizes_m");
  config = IcpEmConfig{};
  config.prior_sigma_yaw_deg = 0.0;
  expect_invalid(config, "prior_sigma_yaw_deg");
  config = IcpEmConfig{};
  config.prior_sigma_horizontal_m = std::nan("");
  expect_invalid(config, "prior_sigma_horizontal_m");
  config = IcpEmConfig{};
  config.max_correspondence_voxels = -1.0;
  expect_invalid(config, "max_correspondence_voxels");
  config = IcpEmConfig{};
  config.covariance_neighbours = 2;
  expect_invalid(config, "covariance_neighbours");
  config = IcpEmConfig{};
  config.prior_sigma_horizontal_m = std::numeric_limits<double>::infinity();  // no prior: valid
  EXPECT_TRUE(config.IsValid(nullptr));

  Eigen::Isometry3d bad_seed = Eigen::Isometry3d::Identity();
  bad_seed.translation().x() = std::nan("");
  EXPECT_THROW(refineIcpEm({{0, 0, 0}}, {{0, 0, 0}}, bad_seed, IcpEmConfig{}),
               std::invalid_argument);
}

}  // namespace
}  // namespace mm4mm
