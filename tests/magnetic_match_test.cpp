// Magnetic maps and matching: interpolation, the FFT search against brute force, PSO on standard
// test functions, and matches of simulated sessions against their ground truth.

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <limits>
#include <random>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/magnetic/compass_prior.hpp"
#include "mm4mm/magnetic/correlation_search.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/magnetic/match_score.hpp"
#include "mm4mm/magnetic/pso.hpp"
#include "mm4mm/merge/joint_match.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace mm4mm {
namespace {

double linearField(const Eigen::Vector2d& p) { return 40.0 + 0.7 * p.x() - 0.3 * p.y(); }

// A rig of `sensors` magnetometers 0.5 m apart driving a gentle arc, reading a linear field.
std::vector<PlacedFingerprint> linearFieldTrack(int sensors, SensorRig* rig) {
  rig->magnetometers_body.clear();
  for (int k = 0; k < sensors; ++k)
    rig->magnetometers_body.emplace_back(0.0, 0.5 * (k - 0.5 * (sensors - 1)), 0.3);
  std::vector<PlacedFingerprint> samples;
  for (int j = 0; j < 400; ++j) {
    const double t = 0.05 * j, yaw = 0.02 * t;
    const Eigen::Isometry3d pose = planarPose(t * std::cos(yaw), t * std::sin(yaw), yaw);
    for (int k = 0; k < sensors; ++k) {
      PlacedFingerprint s;
      s.time_s = t;
      s.sensor = k;
      s.position_m = pose * rig->magnetometers_body[k];
      const double v = linearField(s.position_m.head<2>());
      s.fingerprint = {v, v - 80.0, v + 5.0};
      samples.push_back(s);
    }
  }
  return samples;
}

TEST(MagneticMap, StripInterpolationIsExactOnALinearField) {
  SensorRig rig;
  const auto samples = linearFieldTrack(7, &rig);
  const MagneticMap map = buildMagneticMap(samples, rig, MagneticMapConfig{});
  ASSERT_GT(map.coveredCells(), 3000u);
  double worst = 0.0;
  for (int iy = 0; iy < map.height; ++iy)
    for (int ix = 0; ix < map.width; ++ix) {
      if (!map.covered(ix, iy)) continue;
      const double expected = linearField(map.cellCentre(ix, iy));
      worst = std::max(worst, std::abs(map.horizontal_uT[map.index(ix, iy)] - expected));
      EXPECT_NEAR(map.vertical_uT[map.index(ix, iy)], expected - 80.0, 1e-3);
    }
  EXPECT_LT(worst, 1e-3);
  // Covered width: 3 m of swath along a 20 m track, nothing invented outside it.
  EXPECT_NEAR(map.coveredArea_m2(), 3.0 * 19.95, 2.0);
}

TEST(MagneticMap, SingleSensorGetsItsFootprint) {
  SensorRig rig;
  const auto samples = linearFieldTrack(1, &rig);
  MagneticMapConfig config;
  config.single_sensor_interpolation = SingleSensorInterpolation::kFootprint;
  config.single_sensor_footprint_m = 0.4;
  const MagneticMap map = buildMagneticMap(samples, rig, config);
  EXPECT_NEAR(map.coveredArea_m2(), 0.4 * 19.95, 0.5);
}

// A strip (one pass along a corridor) is long and thin, and the field it holds is its spread.
TEST(MatchScorer, OverlapStatisticsGiveTheStripsShapeAndItsField) {
  MagneticMap strip;
  strip.cell_size_m = 0.05;
  strip.width = 400;  // 20 m along x
  strip.height = 12;  // 0.6 m across
  const std::size_t n = static_cast<std::size_t>(strip.width) * strip.height;
  for (auto* layer : {&strip.horizontal_uT, &strip.vertical_uT, &strip.total_uT,
                      &strip.session_x_uT, &strip.session_y_uT})
    layer->assign(n, 0.0f);
  for (int iy = 0; iy < strip.height; ++iy)
    for (int ix = 0; ix < strip.width; ++ix) {
      const std::size_t i = strip.index(ix, iy);
      strip.horizontal_uT[i] = static_cast<float>(20.0 + 2.0 * std::sin(ix * 0.05 * 3.0));
      strip.vertical_uT[i] = -40.0f;
      strip.total_uT[i] = std::hypot(strip.horizontal_uT[i], strip.vertical_uT[i]);
      strip.session_x_uT[i] = strip.horizontal_uT[i];
    }
  const MatchScorer scorer(strip, strip, MatchScoreConfig{});
  const OverlapStatistics all = scorer.overlapStatistics(PlanarTransform{});
  EXPECT_GT(all.cells, 100);
  // 4 sigma of a uniform spread over L is 4 L / sqrt(12); the look-ups need all four
  // neighbours, so the last cell along each axis is not scored.
  EXPECT_NEAR(all.length_m, 4.0 * 20.0 / std::sqrt(12.0), 0.3);
  EXPECT_NEAR(all.width_m, 4.0 * 0.6 / std::sqrt(12.0), 0.1);
  EXPECT_NEAR(all.centroid.x(), 10.0, 0.2);
  // B_h spreads as 2 sin (std sqrt(2)), B_v not at all: pooled over both, 1 µT.
  EXPECT_NEAR(all.field_std_uT, 1.0, 0.05);
  // Shifted by half its length, half the strip overlaps.
  const OverlapStatistics half = scorer.overlapStatistics(PlanarTransform{10.0, 0.0, 0.0});
  EXPECT_NEAR(half.length_m, 0.5 * all.length_m, 0.3);
  EXPECT_NEAR(half.centroid.x(), 5.0, 0.2);
  const OverlapStatistics none = scorer.overlapStatistics(PlanarTransform{30.0, 0.0, 0.0});
  EXPECT_EQ(none.cells, 0);
}

// Random smooth-ish maps with holes; b is a shifted crop of a plus noise.
MagneticMap randomMap(int width, int height, std::uint64_t seed) {
  MagneticMap map;
  map.cell_size_m = 0.5;
  map.width = width;
  map.height = height;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 3.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const std::size_t n = static_cast<std::size_t>(width) * height;
  for (auto* layer :
       {&map.horizontal_uT, &map.vertical_uT, &map.total_uT, &map.session_x_uT, &map.session_y_uT})
    layer->assign(n, std::nanf(""));
  for (std::size_t i = 0; i < n; ++i) {
    if (u(rng) < 0.3) continue;  // holes
    map.horizontal_uT[i] = static_cast<float>(20.0 + g(rng));
    map.vertical_uT[i] = static_cast<float>(-40.0 + g(rng));
    map.total_uT[i] = std::hypot(map.horizontal_uT[i], map.vertical_uT[i]);
    map.session_x_uT[i] = map.horizontal_uT[i];
    map.session_y_uT[i] = 0.0f;
  }
  return map;
}

// Direct z at an integer-cell shift: a's cell (u + dx, v + dy) meets b's cell (u, v).
double directZ(const MagneticMap& a, const MagneticMap& b, int dx, int dy) {
  double n = 0, sa[2] = {}, sb[2] = {}, saa = 0, sbb = 0, sab = 0;
  for (int v = 0; v < b.height; ++v)
    for (int u = 0; u < b.width; ++u) {
      if (!b.covered(u, v) || !a.covered(u + dx, v + dy)) continue;
      const std::size_t ia = a.index(u + dx, v + dy), ib = b.index(u, v);
      const double va[2] = {a.horizontal_uT[ia], a.vertical_uT[ia]};
      const double vb[2] = {b.horizontal_uT[ib], b.vertical_uT[ib]};
      ++n;
      for (int c = 0; c < 2; ++c) {
        sa[c] += va[c], sb[c] += vb[c];
        saa += va[c] * va[c], sbb += vb[c] * vb[c], sab += va[c] * vb[c];
      }
    }
  if (n * 0.25 < 15.0) return -1e9;
  double cov = sab, var_a = saa, var_b = sbb;
  for (int c = 0; c < 2; ++c)
    cov -= sa[c] * sb[c] / n, var_a -= sa[c] * sa[c] / n, var_b -= sb[c] * sb[c] / n;
  return correlationZ(cov / std::sqrt(var_a * var_b), n * 0.25);
}

TEST(CorrelationSearch, FftAgreesWithDirectComputation) {
  const MagneticMap a = randomMap(40, 30, 1);
  MagneticMap b = randomMap(16, 12, 2);
  // Plant a noisy copy of a's block at (13, 9) into b so that one shift stands out.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (int v = 0; v < b.height; ++v)
    for (int u = 0; u < b.width; ++u) {
      const std::size_t ia = a.index(u + 13, v + 9), ib = b.index(u, v);
      if (!a.covered(u + 13, v + 9) || !b.covered(u, v)) continue;
      b.horizontal_uT[ib] = static_cast<float>(a.horizontal_uT[ia] + noise(rng));
      b.vertical_uT[ib] = static_cast<float>(a.vertical_uT[ia] + noise(rng));
    }
  CorrelationSearchConfig config;
  config.yaw_window_deg = 1.0;  // yaw 0 only
  config.pyramid_factor = 1;    // the transforms alone
  const auto modes = correlationSearch(a, b, config);
  ASSERT_FALSE(modes.empty());
  // Brute force over every integer shift.
  double best = -1e9;
  int best_dx = 0, best_dy = 0;
  for (int dy = -b.height; dy <= a.height; ++dy)
    for (int dx = -b.width; dx <= a.width; ++dx) {
      const double z = directZ(a, b, dx, dy);
      if (z > best) best = z, best_dx = dx, best_dy = dy;
    }
  EXPECT_EQ(best_dx, 13);
  EXPECT_EQ(best_dy, 9);
  EXPECT_NEAR(modes.front().z, best, 1e-6 * std::abs(best));
  EXPECT_NEAR(modes.front().T_a_b.x_m, 13 * 0.5, 1e-9);
  EXPECT_NEAR(modes.front().T_a_b.y_m, 9 * 0.5, 1e-9);
  EXPECT_NEAR(modes.front().T_a_b.yaw_rad, 0.0, 1e-12);
  // Every other reported mode also carries the directly computed z of its shift.
  for (const auto& m : modes) {
    const int dx = static_cast<int>(std::lround(m.T_a_b.x_m / 0.5));
    const int dy = static_cast<int>(std::lround(m.T_a_b.y_m / 0.5));
    EXPECT_NEAR(m.z, directZ(a, b, dx, dy), 1e-6 * std::abs(m.z) + 1e-9);
  }
}

TEST(CorrelationSearch, SameModesWithOneThreadOrMany) {
  // Every yaw fills its own rotated canvas of b, concurrently; a buffer shared between yaws
  // (found by the sanitizer build: matches changed from run to run) would mix their cells.
  const MagneticMap a = randomMap(60, 40, 4);
  const MagneticMap b = randomMap(30, 24, 5);
  CorrelationSearchConfig config;
  config.yaw_window_deg = 180.0;
  config.yaw_step_deg = 5.0;
  std::vector<CorrelationMode> serial, parallel;
  tbb::task_arena(1).execute([&] { serial = correlationSearch(a, b, config); });
  tbb::task_arena(4).execute([&] { parallel = correlationSearch(a, b, config); });
  ASSERT_FALSE(serial.empty());
  ASSERT_EQ(serial.size(), parallel.size());
  for (std::size_t i = 0; i < serial.size(); ++i) {
    EXPECT_EQ(serial[i].z, parallel[i].z) << "mode " << i;
    EXPECT_EQ(serial[i].T_a_b.x_m, parallel[i].T_a_b.x_m) << "mode " << i;
    EXPECT_EQ(serial[i].T_a_b.y_m, parallel[i].T_a_b.y_m) << "mode " << i;
    EXPECT_EQ(serial[i].T_a_b.yaw_rad, parallel[i].T_a_b.yaw_rad) << "mode " << i;
  }
}

// A field of `waves` random plane waves of 2-6 m wavelength on 0.5 m cells, with holes: smooth
// as a building's anomaly is, so a coarser map still carries its shape.
MagneticMap smoothRandomMap(int width, int height, std::uint64_t seed) {
  MagneticMap map = randomMap(width, height, seed);
  std::mt19937_64 rng(seed + 100);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  struct Wave {
    Eigen::Vector2d k;
    double phase, amplitude_h, amplitude_v;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 12; ++i) {
    const double wavelength = 2.0 + 4.0 * u(rng), heading = 2.0 * M_PI * u(rng);
    waves.push_back(
        {2.0 * M_PI / wavelength * Eigen::Vector2d(std::cos(heading), std::sin(heading)),
         2.0 * M_PI * u(rng), 3.0 * u(rng), 3.0 * u(rng)});
  }
  for (int iy = 0; iy < height; ++iy)
    for (int ix = 0; ix < width; ++ix) {
      const std::size_t i = map.index(ix, iy);
      if (std::isnan(map.total_uT[i])) continue;
      const Eigen::Vector2d p = map.origin_m + 0.5 * Eigen::Vector2d(ix + 0.5, iy + 0.5);
      double h = 20.0, v = -40.0;
      for (const Wave& w : waves) {
        h += w.amplitude_h * std::sin(w.k.dot(p) + w.phase);
        v += w.amplitude_v * std::cos(w.k.dot(p) + w.phase);
      }
      map.horizontal_uT[i] = static_cast<float>(h);
      map.vertical_uT[i] = static_cast<float>(v);
      map.total_uT[i] = static_cast<float>(std::hypot(h, v));
      map.session_x_uT[i] = map.horizontal_uT[i];
    }
  return map;
}

TEST(CorrelationSearch, CoarseToFineFindsTheExhaustiveSweepsBestMode) {
  // b is a noisy copy of a block of a, at an odd shift (the coarse cells of the two maps then
  // straddle each other) and turned by a yaw between two of the search's steps.
  const MagneticMap a = smoothRandomMap(80, 60, 7);
  MagneticMap b = smoothRandomMap(40, 30, 8);
  const double yaw = 31.0 * M_PI / 180.0;
  const Eigen::Rotation2Dd R(yaw);
  const Eigen::Vector2d t(13.5, 9.5);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> noise(0.0, 0.3);
  for (int v = 0; v < b.height; ++v)
    for (int u = 0; u < b.width; ++u) {
      const std::size_t ib = b.index(u, v);
      if (!b.covered(u, v)) continue;
      const Eigen::Vector2d p_a = R * (0.5 * Eigen::Vector2d(u + 0.5, v + 0.5)) + t;
      const int ix = static_cast<int>(std::floor(p_a.x() / 0.5)),
                iy = static_cast<int>(std::floor(p_a.y() / 0.5));
      if (!a.covered(ix, iy)) {
        b.horizontal_uT[ib] = b.vertical_uT[ib] = b.total_uT[ib] = std::nanf("");
        continue;
      }
      const std::size_t ia = a.index(ix, iy);
      b.horizontal_uT[ib] = static_cast<float>(a.horizontal_uT[ia] + noise(rng));
      b.vertical_uT[ib] = static_cast<float>(a.vertical_uT[ia] + noise(rng));
      b.total_uT[ib] = std::hypot(b.horizontal_uT[ib], b.vertical_uT[ib]);
    }
  CorrelationSearchConfig exhaustive;
  exhaustive.yaw_step_deg = 4.0;
  exhaustive.pyramid_factor = 1;
  CorrelationSearchConfig pyramid = exhaustive;
  pyramid.pyramid_factor = 2;
  const auto full = correlationSearch(a, b, exhaustive);
  const auto fast = correlationSearch(a, b, pyramid);
  ASSERT_FALSE(full.empty());
  ASSERT_FALSE(fast.empty());
  // The exhaustive sweep finds the planted place, within a cell and half a yaw step ...
  EXPECT_NEAR(full.front().T_a_b.x_m, t.x(), 0.75);
  EXPECT_NEAR(full.front().T_a_b.y_m, t.y(), 0.75);
  EXPECT_NEAR(full.front().T_a_b.yaw_rad, yaw, 2.0 * M_PI / 180.0);
  // ... and coarse to fine lands on the same cell and yaw with the same score: at the yaws it
  // sweeps again it is the exhaustive sweep.
  EXPECT_NEAR(fast.front().T_a_b.x_m, full.front().T_a_b.x_m, 1e-9);
  EXPECT_NEAR(fast.front().T_a_b.y_m, full.front().T_a_b.y_m, 1e-9);
  EXPECT_NEAR(fast.front().T_a_b.yaw_rad, full.front().T_a_b.yaw_rad, 1e-9);
  EXPECT_NEAR(fast.front().z, full.front().z, 1e-6 * full.front().z);
  EXPECT_NEAR(fast.front().r, full.front().r, 1e-6);
  // The planted place is the only credible one: neither search offers another credible mode.
  for (const auto* modes : {&full, &fast})
    for (std::size_t i = 1; i < modes->size(); ++i)
      EXPECT_LT((*modes)[i].r, exhaustive.credible_r) << "mode " << i;
}

bool identical(const std::vector<CorrelationMode>& x, const std::vector<CorrelationMode>& y) {
  if (x.size() != y.size()) return false;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (x[i].T_a_b.x_m != y[i].T_a_b.x_m || x[i].T_a_b.y_m != y[i].T_a_b.y_m ||
        x[i].T_a_b.yaw_rad != y[i].T_a_b.yaw_rad || x[i].z != y[i].z || x[i].r != y[i].r ||
        x[i].overlap_m2 != y[i].overlap_m2)
      return false;
  return true;
}

// The exhaustive sweep after coarse to fine takes the yaws coarse to fine swept on the fine cells
// from their memo, and answers exactly as without it.
TEST(CorrelationSearch, AMemoOfSweptYawsChangesNoMode) {
  const MagneticMap a = smoothRandomMap(80, 60, 7);
  const MagneticMap b = smoothRandomMap(40, 30, 8);
  CorrelationSearchConfig exhaustive;
  exhaustive.yaw_step_deg = 4.0;
  exhaustive.pyramid_factor = 1;
  CorrelationSearchConfig pyramid = exhaustive;
  pyramid.pyramid_factor = 2;
  pyramid.pyramid_yaws = 3;
  SweepMemo memo;
  const auto fast = correlationSearch(a, b, pyramid, &memo);
  const std::size_t swept_fine = memo.per_yaw.size();
  // The fine yaws within half a coarse step (4 deg) of 3 coarse peaks' yaws: 2 or 3 each.
  EXPECT_GE(swept_fine, 3u);
  EXPECT_LE(swept_fine, 9u);
  EXPECT_TRUE(identical(fast, correlationSearch(a, b, pyramid)));
  // Swept again from the memo alone, coarse to fine gives the same modes.
  EXPECT_TRUE(identical(fast, correlationSearch(a, b, pyramid, &memo)));
  EXPECT_EQ(memo.per_yaw.size(), swept_fine);
  const auto remembered = correlationSearch(a, b, exhaustive, &memo);
  EXPECT_EQ(memo.per_yaw.size(), 90u);  // every yaw of the full circle, each swept once
  const auto full = correlationSearch(a, b, exhaustive);
  ASSERT_FALSE(full.empty());
  EXPECT_TRUE(identical(remembered, full));
}

double rastrigin(const Eigen::VectorXd& x) {
  return 10.0 * x.size() + (x.array().square() - 10.0 * (2.0 * M_PI * x.array()).cos()).sum();
}

double ackley(const Eigen::VectorXd& x) {
  const double n = static_cast<double>(x.size());
  return -20.0 * std::exp(-0.2 * std::sqrt(x.squaredNorm() / n)) -
         std::exp((2.0 * M_PI * x.array()).cos().sum() / n) + 20.0 + M_E;
}

TEST(CorrelationSearch, CredibleModesRankBeforeLargerMediocreOnes) {
  CorrelationSearchConfig config;
  config.max_modes = 2;
  // A large overlap of mediocre correlation outscores a small excellent one in z; a near
  // duplicate of the excellent one must be suppressed, not kept as a second mode.
  const CorrelationMode mediocre{{20.0, 0.0, 0.0}, 19.0, 0.70, 300.0};
  const CorrelationMode excellent{{0.0, 0.0, 0.0}, 12.0, 0.96, 50.0};
  const CorrelationMode duplicate{{0.5, 0.0, 0.0}, 11.0, 0.95, 48.0};
  const CorrelationMode other{{-30.0, 5.0, 1.0}, 10.0, 0.90, 45.0};
  const auto modes = distinctModes({mediocre, duplicate, other, excellent}, config);
  ASSERT_EQ(modes.size(), 2u);
  EXPECT_DOUBLE_EQ(modes[0].z, excellent.z);
  EXPECT_DOUBLE_EQ(modes[1].z, other.z);
  config.credible_r = 0.99;  // nothing credible: plain z order
  EXPECT_DOUBLE_EQ(distinctModes({excellent, mediocre}, config).front().z, mediocre.z);
}

TEST(Pso, FindsTheGlobalOptimumOfMultimodalTestFunctions) {
  PsoConfig config;
  config.particles = 60;
  config.iterations = 300;
  config.stall_iterations = 60;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    config.seed = seed;
    const Eigen::VectorXd lower = Eigen::VectorXd::Constant(2, -5.12), upper = -lower;
    const PsoResult r =
        psoMaximize([](const Eigen::VectorXd& x) { return -rastrigin(x); }, lower, upper, config);
    EXPECT_LT(r.best.norm(), 0.05) << "Rastrigin, seed " << seed;
    const Eigen::VectorXd lo = Eigen::VectorXd::Constant(3, -32.0), hi = -lo;
    const PsoResult a =
        psoMaximize([](const Eigen::VectorXd& x) { return -ackley(x); }, lo, hi, config);
    EXPECT_LT(a.best.norm(), 0.05) << "Ackley, seed " << seed;
  }
}

TEST(Pso, ObjectiveThatIsMinusInfinityEverywhereStillReturnsAPoint) {
  const Eigen::VectorXd lower = Eigen::VectorXd::Constant(3, -1.0), upper = -lower;
  const PsoResult r =
      psoMaximize([](const Eigen::VectorXd&) { return -std::numeric_limits<double>::infinity(); },
                  lower, upper, PsoConfig{});
  ASSERT_EQ(r.best.size(), 3);
  EXPECT_TRUE(((r.best.array() >= -1.0) && (r.best.array() <= 1.0)).all());
  EXPECT_FALSE(std::isfinite(r.value));
}

TEST(Pso, SameSeedSameResult) {
  PsoConfig config;
  const Eigen::VectorXd lower = Eigen::VectorXd::Constant(2, -5.0), upper = -lower;
  const auto f = [](const Eigen::VectorXd& x) { return -rastrigin(x); };
  const PsoResult a = psoMaximize(f, lower, upper, config),
                  b = psoMaximize(f, lower, upper, config);
  EXPECT_EQ(a.best, b.best);
  EXPECT_EQ(a.evaluations, b.evaluations);
}

// Two magnetic-only warehouse sessions of the paper's set-up (0.2 m and 180° apart), shortened.
std::vector<Session> simulatedPair(bool disjoint, std::uint64_t seed) {
  sim::SimulationConfig config;
  config.lidar.enabled = false;
  config.layout.route_length_m = 200.0;
  config.layout.disjoint_session = disjoint;
  sim::applyRigPreset("array7", &config);  // realistic sensors, calibrated by the matcher
  return sim::simulateSessions(config, disjoint ? 3 : 2, seed);
}

TEST(MagneticMatcher, FindsTheTrueOverlapOfASimulatedPair) {
  const auto sessions = simulatedPair(false, 11);
  const MagneticMatchResult result =
      matchSessions(sessions[0], sessions[1], MagneticMatcherConfig{});
  EXPECT_EQ(result.verdict, MatchVerdict::kMatch);
  const OverlapError error = overlapError(sessions[0], sessions[1], result.T_a_b.toIsometry());
  EXPECT_GT(error.pairs, 10);
  EXPECT_LT(error.median_translation_m, 0.5);
  EXPECT_LT(error.median_rotation_deg, 2.0);
  EXPECT_GT(result.overlap_m2, 15.0);
  EXPECT_GE(result.probability, MatchConfidenceConfig{}.min_probability);
}

// With `decides`, the probability decides: the same pair, asked for more certainty than its
// match has, is refused; with the probability only reported, the z / r thresholds decide.
TEST(MagneticMatcher, TheProbabilityDecides) {
  const auto sessions = simulatedPair(false, 11);
  MagneticMatcherConfig config;
  config.confidence_model.decides = true;
  // One search over one set of yaws for both runs: a refusal by coarse to fine (or within the
  // compass window) falls back on the exhaustive sweep (or the full circle), whose pose, and so
  // probability, may differ in the last digits from the one that accepted (it did under clang).
  config.search.pyramid_factor = 1;
  config.use_compass_prior = false;
  const MagneticMap a = buildSessionMap(sessions[0], config);
  const MagneticMap b = buildSessionMap(sessions[1], config);
  const MagneticMatchResult accepted = matchMagneticMaps(a, b, config);
  ASSERT_EQ(accepted.verdict, MatchVerdict::kMatch);
  ASSERT_LT(accepted.probability, 0.999999);
  config.confidence_model.min_probability = 0.5 * (1.0 + accepted.probability);
  const MagneticMatchResult refused = matchMagneticMaps(a, b, config);
  EXPECT_FALSE(refused.overlap());
  EXPECT_DOUBLE_EQ(refused.probability, accepted.probability);
  EXPECT_LT(refused.probability, config.confidence_model.min_probability);
  config.confidence_model.decides = false;  // the thresholds, which this pair passes
  EXPECT_TRUE(matchMagneticMaps(a, b, config).overlap());
  // Features as the fitting script computes them, clamped where a degenerate overlap would not
  // be finite.
  MagneticMatchResult degenerate;
  degenerate.r = 1.0;
  const MatchFeatures f = matchFeatures(degenerate, true);
  EXPECT_TRUE(std::isfinite(f.atanh_r) && std::isfinite(f.log_aspect) &&
              std::isfinite(f.log_field_std) && std::isfinite(f.log_yaw_uncertainty));
  EXPECT_EQ(f.single_track, 1.0);
  const double p = matchProbability(f, MatchConfidenceConfig{});
  EXPECT_GT(p, 0.0);
  EXPECT_LT(p, 1.0);
}

// Warehouse seed 4, sessions 1 and 2 of the paper's set-up: they share about 35 m² of swath, and
// a larger overlap elsewhere correlates at r 0.67 with a higher z. Ranking by z alone refused
// the pair; the credible mode must win.
TEST(MagneticMatcherEndToEnd, SmallExcellentOverlapBeatsALargeMediocreOne) {
  sim::SimulationConfig config;
  config.lidar.enabled = false;
  sim::applyRigPreset("array7", &config);
  config.magnetometer_errors.model = "clean";  // the ranking, not the calibration, is tested
  const auto sessions = sim::simulateSessions(config, 3, 4);
  const MagneticMatchResult result =
      matchSessions(sessions[1], sessions[2], MagneticMatcherConfig{});
  EXPECT_EQ(result.verdict, MatchVerdict::kMatch) << "z " << result.z << " r " << result.r;
  const OverlapError error = overlapError(sessions[1], sessions[2], result.T_a_b.toIsometry());
  EXPECT_TRUE(error.aligned()) << error.median_translation_m << " m, " << error.median_rotation_deg
                               << " deg";
  EXPECT_LT(result.overlap_m2, 100.0);
}

TEST(MagneticMatcherEndToEnd, GridRefinementAgreesWithPso) {
  const auto sessions = simulatedPair(false, 11);
  MagneticMatcherConfig config;
  config.refinement = RefinementMethod::kLocalGrid;
  config.refine_modes = 1;
  const MagneticMatchResult result = matchSessions(sessions[0], sessions[1], config);
  const OverlapError error = overlapError(sessions[0], sessions[1], result.T_a_b.toIsometry());
  EXPECT_LT(error.median_translation_m, 0.5);
  EXPECT_LT(error.median_rotation_deg, 2.0);
}

TEST(MagneticMatcherEndToEnd, DisjointPairIsNoOverlap) {
  const auto sessions = simulatedPair(true, 12);
  const MagneticMatchResult result =
      matchSessions(sessions[0], sessions[2], MagneticMatcherConfig{});
  EXPECT_NE(result.verdict, MatchVerdict::kMatch) << "z " << result.z << " r " << result.r;
  EXPECT_FALSE(result.overlap());
  EXPECT_LT(result.probability, 0.5);
}

// Sessions calibrated apart differ by a constant their calibration could not see (a level
// robot's vertical hard iron: issue 32). The score correlates each channel about its own mean
// over the overlap, so such a constant changes no decision and no pose: b's sensors reading
// 10 µT more along body z (vertical on this level robot) leave an overlapping pair placed as
// before and a disjoint one refused.
TEST(MagneticMatcherEndToEnd, AVerticalOffsetBetweenTheSessionsChangesNoDecision) {
  auto sessions = simulatedPair(true, 12);
  const MagneticMatcherConfig config;
  const MagneticMatchResult overlapping = matchSessions(sessions[0], sessions[1], config);
  const MagneticMatchResult disjoint = matchSessions(sessions[0], sessions[2], config);
  ASSERT_EQ(overlapping.verdict, MatchVerdict::kMatch);
  ASSERT_FALSE(disjoint.overlap());
  for (Session* s : {&sessions[1], &sessions[2]})
    for (MagnetometerSample& sample : s->magnetometer) sample.field_body_uT.z() += 10.0;
  const MagneticMatchResult shifted = matchSessions(sessions[0], sessions[1], config);
  EXPECT_EQ(shifted.verdict, MatchVerdict::kMatch);
  EXPECT_NEAR(shifted.T_a_b.x_m, overlapping.T_a_b.x_m, 0.02);
  EXPECT_NEAR(shifted.T_a_b.y_m, overlapping.T_a_b.y_m, 0.02);
  EXPECT_NEAR(shifted.T_a_b.yaw_rad, overlapping.T_a_b.yaw_rad, 0.2 * M_PI / 180.0);
  EXPECT_NEAR(shifted.r, overlapping.r, 0.01);
  EXPECT_EQ(matchSessions(sessions[0], sessions[2], config).verdict, disjoint.verdict);
}

// Coarse to fine only hastens a match: where it accepts, the place is the exhaustive sweep's;
// where it does not (a disjoint pair), the exhaustive sweep runs after it, and its answer is the
// one returned, whole. For proposals alone (matchForProposals) coarse to fine's answer stands.
TEST(MagneticMatcherEndToEnd, CoarseToFineRefusesOnlyWhereTheExhaustiveSweepDoes) {
  const auto sessions = simulatedPair(true, 12);
  MagneticMatcherConfig exhaustive;
  exhaustive.search.pyramid_factor = 1;
  MagneticMatcherConfig fast = exhaustive;
  fast.search.pyramid_factor = 2;
  const MagneticMap a = buildSessionMap(sessions[0], exhaustive);
  const MagneticMap b = buildSessionMap(sessions[1], exhaustive);
  const MagneticMap disjoint = buildSessionMap(sessions[2], exhaustive);

  const MagneticMatchResult full = matchMagneticMaps(a, b, exhaustive);
  const MagneticMatchResult quick = matchMagneticMaps(a, b, fast);
  ASSERT_EQ(full.verdict, MatchVerdict::kMatch);
  EXPECT_EQ(full.coarse_to_fine, CoarseToFine::kOff);
  EXPECT_EQ(quick.coarse_to_fine, CoarseToFine::kAccepted);
  EXPECT_EQ(quick.verdict, MatchVerdict::kMatch);
  EXPECT_LT(translationDistance(quick.T_a_b, full.T_a_b), 0.1);
  EXPECT_LT(yawDistance(quick.T_a_b, full.T_a_b), 0.5 * M_PI / 180.0);

  const MagneticMatchResult refused = matchMagneticMaps(a, disjoint, exhaustive);
  const MagneticMatchResult fell_back = matchMagneticMaps(a, disjoint, fast);
  ASSERT_FALSE(refused.overlap());
  EXPECT_EQ(fell_back.coarse_to_fine, CoarseToFine::kFellBack);
  EXPECT_EQ(fell_back.verdict, refused.verdict);
  EXPECT_DOUBLE_EQ(fell_back.z, refused.z);
  EXPECT_DOUBLE_EQ(fell_back.r, refused.r);
  EXPECT_DOUBLE_EQ(fell_back.second_mode_ratio, refused.second_mode_ratio);
  EXPECT_DOUBLE_EQ(fell_back.T_a_b.x_m, refused.T_a_b.x_m);
  EXPECT_DOUBLE_EQ(fell_back.T_a_b.yaw_rad, refused.T_a_b.yaw_rad);
  EXPECT_EQ(fell_back.modes.size(), refused.modes.size());
  // Evaluations run are counted, coarse to fine's with them; a mode the exhaustive sweep finds
  // where coarse to fine refined it is not refined again (SearchMemo): here every one of them.
  EXPECT_EQ(fell_back.evaluations, refused.evaluations);

  // For proposals alone coarse to fine's answer stands: where it accepts, the match
  // matchMagneticMaps gives; where it does not, its own answer and modes (kAlone), with no
  // exhaustive sweep after it; without coarse to fine, the exhaustive sweep's.
  const MagneticMatchResult proposed = matchForProposals(a, b, fast);
  EXPECT_EQ(proposed.coarse_to_fine, CoarseToFine::kAccepted);
  EXPECT_DOUBLE_EQ(proposed.z, quick.z);
  const MagneticMatchResult alone = matchForProposals(a, disjoint, fast);
  EXPECT_EQ(alone.coarse_to_fine, CoarseToFine::kAlone);
  EXPECT_FALSE(alone.overlap());
  EXPECT_FALSE(alone.modes.empty());
  const MagneticMatchResult swept = matchForProposals(a, disjoint, exhaustive);
  EXPECT_EQ(swept.coarse_to_fine, CoarseToFine::kOff);
  EXPECT_DOUBLE_EQ(swept.z, refused.z);
}

// The paper's baseline (Eq. 4-5, one global PSO) places any pair it can overlap; judged by the
// default's confidence rule it refuses the same disjoint pair.
TEST(MagneticMatcherEndToEnd, ThePaperBaselineRefusesADisjointPairOnlyUnderTheConfidenceRule) {
  const auto sessions = simulatedPair(true, 12);
  MagneticMatcherConfig paper;
  paper.global = GlobalSearchMethod::kPaperPso;
  paper.score.kind = MatchScoreKind::kPaperFitness;
  paper.score.stride = 6;
  paper.paper_pso.particles = 100;
  paper.paper_pso.iterations = 60;
  const MagneticMatchResult as_published = matchSessions(sessions[0], sessions[2], paper);
  EXPECT_EQ(as_published.verdict, MatchVerdict::kMatch);
  paper.paper_confidence_rule = true;
  const MagneticMatchResult judged = matchSessions(sessions[0], sessions[2], paper);
  EXPECT_FALSE(judged.overlap()) << "z " << judged.z << " r " << judged.r;
  EXPECT_TRUE(judged.T_a_b.toIsometry().isApprox(as_published.T_a_b.toIsometry(), 1e-9));
}

// A smooth random field (sum of plane waves of 2-4 m wavelength) sampled on a rectangle of b's
// frame, with white noise on each reading; the same field in every map, so T_a_b is identity.
MagneticMap waveFieldMap(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, double noise_uT,
                         std::uint64_t noise_seed, std::uint64_t field_seed = 7) {
  std::mt19937_64 waves(field_seed);  // the same seed, the same field
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector4d> h, v;  // (kx, ky, phase, amplitude)
  for (auto* set : {&h, &v})
    for (int k = 0; k < 12; ++k) {
      const double wavelength = 2.0 + 2.0 * u(waves), angle = 2 * M_PI * u(waves);
      set->push_back({2 * M_PI / wavelength * std::cos(angle),
                      2 * M_PI / wavelength * std::sin(angle), 2 * M_PI * u(waves), 1.0});
    }
  std::mt19937_64 rng(noise_seed);
  std::normal_distribution<double> g(0.0, noise_uT);
  MagneticMap map;
  map.origin_m = lo;
  map.cell_size_m = 0.05;
  map.width = static_cast<int>(std::round((hi.x() - lo.x()) / map.cell_size_m));
  map.height = static_cast<int>(std::round((hi.y() - lo.y()) / map.cell_size_m));
  const std::size_t n = static_cast<std::size_t>(map.width) * map.height;
  for (auto* layer :
       {&map.horizontal_uT, &map.vertical_uT, &map.total_uT, &map.session_x_uT, &map.session_y_uT})
    layer->assign(n, 0.0f);
  const auto sum = [](const std::vector<Eigen::Vector4d>& set, const Eigen::Vector2d& p) {
    double f = 0.0;
    for (const Eigen::Vector4d& w : set) f += w[3] * std::cos(w[0] * p.x() + w[1] * p.y() + w[2]);
    return f;
  };
  for (int iy = 0; iy < map.height; ++iy)
    for (int ix = 0; ix < map.width; ++ix) {
      const Eigen::Vector2d p = map.cellCentre(ix, iy);
      const std::size_t i = map.index(ix, iy);
      map.horizontal_uT[i] = static_cast<float>(20.0 + sum(h, p) + g(rng));
      map.vertical_uT[i] = static_cast<float>(-40.0 + sum(v, p) + g(rng));
      map.total_uT[i] = std::hypot(map.horizontal_uT[i], map.vertical_uT[i]);
      map.session_x_uT[i] = map.horizontal_uT[i];
    }
  return map;
}

// A wide overlap pins the yaw; a short one of the same field leaves it open by degrees, which is
// what the matcher's yaw refusal rests on. The half-width also grows with the noise.
TEST(MagneticMatcher, YawUncertaintyShrinksWithTheOverlapsExtent) {
  // Map a without noise: white noise on a's 5 cm cells would be averaged away by the bilinear
  // look-up between cell centres and lift r off the cells, unlike a real map's smooth errors.
  const MagneticMap a = waveFieldMap({-6, -6}, {6, 6}, 0.0, 1);
  const MagneticMap wide = waveFieldMap({-4, -4}, {4, 4}, 0.5, 2);
  const MagneticMap small = waveFieldMap({-1.5, -0.75}, {1.5, 0.75}, 0.5, 3);
  const MagneticMap noisy = waveFieldMap({-4, -4}, {4, 4}, 4.0, 4);
  MatchScoreConfig score;
  score.min_overlap_m2 = 4.0;
  const PlanarTransform identity{0.0, 0.0, 0.0};
  const double range = 8.0 * M_PI / 180.0, step = 0.1 * M_PI / 180.0;
  const double wide_deg =
      yawUncertainty(MatchScorer(a, wide, score), identity, range, step) * 180.0 / M_PI;
  const double small_deg =
      yawUncertainty(MatchScorer(a, small, score), identity, range, step) * 180.0 / M_PI;
  const double noisy_deg =
      yawUncertainty(MatchScorer(a, noisy, score), identity, range, step) * 180.0 / M_PI;
  EXPECT_GT(wide_deg, 0.0);
  EXPECT_LT(wide_deg, 1.0);
  EXPECT_GT(small_deg, 2.0);
  EXPECT_GT(small_deg, 3.0 * wide_deg);
  EXPECT_GT(noisy_deg, wide_deg);
  // Turning about the overlap's centroid: a wide overlap far from b's origin pins the yaw as well.
  MagneticMap shifted = wide;
  shifted.origin_m += Eigen::Vector2d(30.0, 0.0);
  const PlanarTransform back{-30.0, 0.0, 0.0};
  EXPECT_NEAR(yawUncertainty(MatchScorer(a, shifted, score), back, range, step) * 180.0 / M_PI,
              wide_deg, 0.15);
}

// Geometry proposes three places of a lattice 8 m apart, equally good by their walls; the field
// picks the true one (identity, proposed 0.1 m and 0.5 deg off) and refines it. Against a map of
// another field the same proposals are refused, and two proposals of the same place are
// ambiguous, not a match.
TEST(JointMatch, TheFieldChoosesAmongTheStructureModes) {
  const MagneticMap a = waveFieldMap({-14, -4}, {14, 4}, 0.0, 1);
  const MagneticMap b = waveFieldMap({-4, -1.25}, {4, 1.25}, 0.5, 2);  // a 20 m² swath
  const MagneticMap other = waveFieldMap({-4, -1.25}, {4, 1.25}, 0.5, 2, 99);
  MagneticMatchResult structure;
  for (double x : {8.0, 0.1, -8.0})
    structure.modes.push_back({{x, 0.05, 0.5 * M_PI / 180.0}, 5.0, 0.8, 40.0});
  MagneticMatcherConfig geometry;
  geometry.min_r = 0.7;
  const MagneticMatcherConfig field;
  JointMatchConfig config;

  const MagneticMatchResult chosen = matchJointly(a, b, structure, geometry, field, config);
  EXPECT_EQ(chosen.verdict, MatchVerdict::kMatch)
      << "z " << chosen.z << " r " << chosen.r << " second " << chosen.second_mode_ratio;
  EXPECT_NEAR(chosen.T_a_b.x_m, 0.0, 0.06);
  EXPECT_NEAR(chosen.T_a_b.y_m, 0.0, 0.06);
  EXPECT_NEAR(chosen.T_a_b.yaw_rad * 180.0 / M_PI, 0.0, 0.6);
  ASSERT_EQ(chosen.modes.size(), 3u);
  EXPECT_LT(chosen.second_mode_ratio, 0.5);

  EXPECT_NE(matchJointly(a, other, structure, geometry, field, config).verdict,
            MatchVerdict::kMatch);

  MagneticMatchResult twice = structure;
  twice.modes[0].T_a_b = {0.0, -0.05, 0.0};  // the true place, proposed twice
  EXPECT_EQ(matchJointly(a, b, twice, geometry, field, config).verdict, MatchVerdict::kAmbiguous);

  // A structure mode the geometry itself does not find credible is not put to the field.
  MagneticMatchResult weak = structure;
  weak.modes[1].r = 0.5;
  const MagneticMatchResult without = matchJointly(a, b, weak, geometry, field, config);
  EXPECT_EQ(without.modes.size(), 2u);
  EXPECT_NE(without.verdict, MatchVerdict::kMatch);

  config.max_candidates = 0;
  EXPECT_THROW(matchJointly(a, b, structure, geometry, field, config), std::invalid_argument);
  config.max_candidates = 8;
  for (int factor : {0, 9}) {
    config.structure_pyramid_factor = factor;
    EXPECT_THROW(matchStructureForJoint(a, b, geometry, config), std::invalid_argument) << factor;
  }
}

// Two single tracks that share one pass: b's strip lies on 3 m of a's, 1.8 m² of common swath,
// under the 4 m² any single-track match needs. Geometry proposes the true place and two of a
// lattice 8 m apart; counting one sample per πℓ² the field picks the true one, where counting one
// per m² (the field's own rule) it sees no overlap at any of them.
TEST(JointMatch, AThinOverlapOfTwoTracksIsChosenWhereTheAreaRuleSeesNone) {
  MagneticMap a = waveFieldMap({-14, -0.3}, {14, 0.3}, 0.0, 1);
  MagneticMap b = waveFieldMap({-1.5, -0.3}, {1.5, 0.3}, 0.5, 2);
  a.single_track = b.single_track = true;
  MagneticMatchResult structure;
  for (double x : {8.0, 0.1, -8.0})
    structure.modes.push_back({{x, 0.05, 0.5 * M_PI / 180.0}, 5.0, 0.8, 40.0});
  MagneticMatcherConfig geometry;
  geometry.min_r = 0.7;
  const MagneticMatcherConfig field;
  JointMatchConfig config;

  const MagneticMatchResult chosen = matchJointly(a, b, structure, geometry, field, config);
  EXPECT_EQ(chosen.verdict, MatchVerdict::kMatch)
      << "z " << chosen.z << " r " << chosen.r << " second " << chosen.second_mode_ratio;
  EXPECT_NEAR(chosen.T_a_b.x_m, 0.0, 0.06);
  EXPECT_NEAR(chosen.T_a_b.y_m, 0.0, 0.06);
  EXPECT_GT(chosen.overlap_m2, 1.0);
  EXPECT_LT(chosen.overlap_m2, 4.0);

  // Another field along the same tracks: no candidate is taken.
  MagneticMap other = waveFieldMap({-1.5, -0.3}, {1.5, 0.3}, 0.5, 2, 99);
  other.single_track = true;
  EXPECT_NE(matchJointly(a, other, structure, geometry, field, config).verdict,
            MatchVerdict::kMatch);

  // The field's own single-track count: one sample per m², at least 4 m².
  config.single_track.min_overlap_m2 = 4.0;
  config.single_track.area_per_sample_m2 = 1.0;
  const MagneticMatchResult by_area = matchJointly(a, b, structure, geometry, field, config);
  EXPECT_EQ(by_area.verdict, MatchVerdict::kNoOverlap);
  EXPECT_EQ(by_area.z, 0.0);

  config.single_track.min_overlap_m2 = 0.5;  // under 3 samples of 1 m²
  EXPECT_THROW(matchJointly(a, b, structure, geometry, field, config), std::invalid_argument);
}

double planarDistance(const PlanarTransform& a, const PlanarTransform& b) {
  return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m);
}

// Calibrated sessions' mean horizontal fields point to one north: their difference is the
// sessions' relative yaw, and a search of the window around it finds what the full circle finds.
TEST(CompassPrior, GivesTheRelativeYawAndTheWindowFindsWhatTheCircleFinds) {
  const auto sessions = simulatedPair(false, 11);
  MagneticMatcherConfig exhaustive;
  exhaustive.use_compass_prior = false;
  const MagneticMap a = buildSessionMap(sessions[0], exhaustive);
  const MagneticMap b = buildSessionMap(sessions[1], exhaustive);
  const double true_yaw =
      PlanarTransform::fromIsometry(trueRelativeTransform(sessions[0], sessions[1])).yaw_rad;
  const CompassHeading compass = compassHeading(a, b);
  EXPECT_LT(std::abs(wrapAngle(compass.yaw_rad - true_yaw)), 5.0 * M_PI / 180.0)
      << compass.yaw_rad * 180.0 / M_PI << " deg against " << true_yaw * 180.0 / M_PI;
  EXPECT_GT(compass.resultant, 0.8);

  MagneticMatcherConfig with_compass;
  with_compass.use_compass_prior = true;
  const MagneticMatchResult full = matchMagneticMaps(a, b, exhaustive);
  const MagneticMatchResult windowed = matchMagneticMaps(a, b, with_compass);
  EXPECT_EQ(full.compass, CompassUse::kOff);
  EXPECT_EQ(windowed.compass, CompassUse::kWindow);
  EXPECT_EQ(windowed.verdict, full.verdict);
  EXPECT_LT(planarDistance(windowed.T_a_b, full.T_a_b), 0.1);
  EXPECT_LT(std::abs(wrapAngle(windowed.T_a_b.yaw_rad - full.T_a_b.yaw_rad)), 0.5 * M_PI / 180.0);
}

// A compass that points the wrong way (b's session-frame field turned by 90 degrees, as a
// heading-dependent offset left uncalibrated would) finds nothing credible in its window: the
// full circle is searched after it and gives the exhaustive answer; and an untrusted compass is
// not used at all.
TEST(CompassPrior, AWrongCompassFallsBackToTheFullCircle) {
  const auto sessions = simulatedPair(false, 11);
  MagneticMatcherConfig exhaustive;
  exhaustive.use_compass_prior = false;
  const MagneticMap a = buildSessionMap(sessions[0], exhaustive);
  MagneticMap b = buildSessionMap(sessions[1], exhaustive);
  const MagneticMatchResult full = matchMagneticMaps(a, b, exhaustive);
  ASSERT_EQ(full.verdict, MatchVerdict::kMatch);
  for (std::size_t i = 0; i < b.session_x_uT.size(); ++i) {
    const float x = b.session_x_uT[i];
    b.session_x_uT[i] = -b.session_y_uT[i];
    b.session_y_uT[i] = x;
  }
  MagneticMatcherConfig with_compass;
  with_compass.use_compass_prior = true;
  const MagneticMatchResult fell_back = matchMagneticMaps(a, b, with_compass);
  EXPECT_EQ(fell_back.compass, CompassUse::kFellBack);
  EXPECT_EQ(fell_back.verdict, MatchVerdict::kMatch);
  EXPECT_LT(planarDistance(fell_back.T_a_b, full.T_a_b), 0.1);
  EXPECT_LT(std::abs(wrapAngle(fell_back.T_a_b.yaw_rad - full.T_a_b.yaw_rad)), 0.5 * M_PI / 180.0);

  with_compass.compass_min_resultant = 1.0;  // no real field is uniform: never trusted
  const MagneticMatchResult untrusted = matchMagneticMaps(a, b, with_compass);
  EXPECT_EQ(untrusted.compass, CompassUse::kUntrusted);
  EXPECT_EQ(untrusted.verdict, full.verdict);
  EXPECT_LT(planarDistance(untrusted.T_a_b, full.T_a_b), 0.1);
}

TEST(MagneticMatcher, RejectsBadConfiguration) {
  MagneticMatcherConfig config;
  config.search.yaw_step_deg = 0.0;
  std::string error;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("yaw_step_deg"), std::string::npos);
  config = {};
  config.max_yaw_uncertainty_deg = 0.0;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("max_yaw_uncertainty_deg"), std::string::npos);
  config = {};
  config.confidence_model.min_probability = 1.0;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("confidence_model.min_probability"), std::string::npos);
  config = {};
  config.compass_min_resultant = 1.5;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("compass_min_resultant"), std::string::npos);
}

}  // namespace
}  // namespace mm4mm
