// Gaussian-process magnetic maps of a single sensor's track: what they interpolate, where they
// stop, that tiling leaves no seams, and that they make real single-sensor sequences matchable.

#include "mm4mm/magnetic/gaussian_process_map.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"

namespace mm4mm {
namespace {

// A smooth, non-linear field (µT) in the plane.
Eigen::Vector3d smoothField(const Eigen::Vector2d& p) {
  return {18.0 + 2.0 * std::sin(0.8 * p.x()) + 0.5 * p.y(), -3.0 + 1.5 * std::cos(0.6 * p.y()),
          -40.0 + 1.2 * p.x() - 0.8 * p.y()};
}

PlacedFingerprint sampleAt(const Eigen::Vector2d& p, double t) {
  PlacedFingerprint s;
  s.time_s = t;
  s.position_m << p, 0.0;
  s.levelled_uT = smoothField(p);
  s.fingerprint = fingerprintOf(Eigen::Matrix3d::Identity(), s.levelled_uT);
  return s;
}

// The default length scale: the geometry below is laid out in its units.
const double kL = GaussianProcessMapConfig{}.length_scale_m;

// Three passes along x, 1.25 length scales apart, sampled every 2 cm: a lone sensor mowing a
// strip.
std::vector<PlacedFingerprint> threePasses() {
  std::vector<PlacedFingerprint> samples;
  for (int pass = 0; pass < 3; ++pass)
    for (int i = 0; i <= 200; ++i)
      samples.push_back(sampleAt({0.02 * i, 1.25 * kL * pass}, samples.size() * 0.02));
  return samples;
}

float valueAt(const MagneticMap& map, const std::vector<float>& channel, double x, double y) {
  const int ix = static_cast<int>(std::floor((x - map.origin_m.x()) / map.cell_size_m));
  const int iy = static_cast<int>(std::floor((y - map.origin_m.y()) / map.cell_size_m));
  if (ix < 0 || iy < 0 || ix >= map.width || iy >= map.height)
    return std::numeric_limits<float>::quiet_NaN();  // off the grid: not covered either
  return channel[map.index(ix, iy)];
}

TEST(GaussianProcessMap, FillsBetweenPassesAndLeavesFarCellsUncovered) {
  const MagneticMap map = buildGaussianProcessMap(threePasses(), 0.05, {});
  const double last_pass = 2.5 * kL;
  double worst = 0.0;
  int checked = 0;
  for (double x = 0.5; x <= 3.5; x += 0.25)
    for (double y : {0.625 * kL, 1.875 * kL}) {  // halfway between passes, where no sample lies
      const float v = valueAt(map, map.vertical_uT, x, y);
      ASSERT_FALSE(std::isnan(v)) << "between passes at " << x << ", " << y;
      const int ix = static_cast<int>(std::floor((x - map.origin_m.x()) / map.cell_size_m));
      const int iy = static_cast<int>(std::floor((y - map.origin_m.y()) / map.cell_size_m));
      worst = std::max(worst, std::abs(v - smoothField(map.cellCentre(ix, iy)).z()));
      ++checked;
    }
  EXPECT_GT(checked, 20);
  // µT, over a field that varies by 5.6 µT along the strip (the prior mean alone is off by 2.8)
  EXPECT_LT(worst, 0.25);
  // On the grid (which reaches two length scales past the samples) but too far to be known.
  ASSERT_GT(map.origin_m.y() + map.height * map.cell_size_m, last_pass + 1.9 * kL);
  EXPECT_TRUE(std::isnan(valueAt(map, map.vertical_uT, 2.0, last_pass + 1.75 * kL)));
  EXPECT_TRUE(
      std::isnan(valueAt(map, map.vertical_uT, 4.0 + 1.75 * kL, 1.25 * kL)));  // past the ends
  EXPECT_FALSE(std::isnan(valueAt(map, map.vertical_uT, 2.0, last_pass + 0.25 * kL)));
}

TEST(GaussianProcessMap, TilesJoinWithoutSeams) {
  GaussianProcessMapConfig small_tiles;
  small_tiles.tile_size_m = 0.7;
  GaussianProcessMapConfig one_tile;
  one_tile.tile_size_m = 20.0;
  const MagneticMap tiled = buildGaussianProcessMap(threePasses(), 0.05, small_tiles);
  const MagneticMap whole = buildGaussianProcessMap(threePasses(), 0.05, one_tile);
  ASSERT_EQ(tiled.width, whole.width);
  ASSERT_EQ(tiled.height, whole.height);
  std::size_t both = 0, either = 0;
  double worst = 0.0;
  for (std::size_t i = 0; i < whole.total_uT.size(); ++i) {
    const bool a = !std::isnan(tiled.total_uT[i]), b = !std::isnan(whole.total_uT[i]);
    either += a || b;
    if (!(a && b)) continue;
    ++both;
    worst = std::max(worst, static_cast<double>(std::abs(tiled.total_uT[i] - whole.total_uT[i])));
  }
  EXPECT_GT(both, 0.99 * either);
  EXPECT_LT(worst, 0.02);
}

TEST(GaussianProcessMap, SameMapWithOneThreadOrMany) {
  GaussianProcessMapConfig config;
  config.tile_size_m = 0.5;  // many tiles, so the threads share them out
  const auto build = [&] { return buildGaussianProcessMap(threePasses(), 0.05, config); };
  MagneticMap serial;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    serial = build();
  }
  const MagneticMap parallel = build();
  ASSERT_EQ(serial.horizontal_uT.size(), parallel.horizontal_uT.size());
  for (std::size_t i = 0; i < serial.horizontal_uT.size(); ++i) {
    const float a = serial.horizontal_uT[i], b = parallel.horizontal_uT[i];
    ASSERT_TRUE((std::isnan(a) && std::isnan(b)) || a == b) << "cell " << i;
  }
}

TEST(GaussianProcessMap, BadConfigSaysWhichKey) {
  GaussianProcessMapConfig config;
  config.max_std_ratio = 1.5;
  EXPECT_THROW(
      {
        try {
          buildGaussianProcessMap(threePasses(), 0.05, config);
        } catch (const std::invalid_argument& e) {
          EXPECT_NE(std::string(e.what()).find("max_std_ratio"), std::string::npos) << e.what();
          throw;
        }
      },
      std::invalid_argument);
}

TEST(GaussianProcessMap, ConfigKeysAreReadAndUnknownOnesRefused) {
  const auto dir = std::filesystem::temp_directory_path() / "mm4mm_gp_config_test";
  std::filesystem::create_directories(dir);
  const auto good = dir / "good.yaml";
  std::ofstream(good) << "merge:\n  matcher:\n    map:\n"
                         "      single_sensor_interpolation: gaussian_process\n"
                         "      gaussian_process:\n        length_scale_m: 0.7\n"
                         "        max_std_ratio: 0.4\n";
  const MagneticMatcherConfig c = loadPipelineConfig(good).merge.matcher;
  EXPECT_EQ(c.map.single_sensor_interpolation, SingleSensorInterpolation::kGaussianProcess);
  EXPECT_DOUBLE_EQ(c.map.gaussian_process.length_scale_m, 0.7);
  EXPECT_DOUBLE_EQ(c.map.gaussian_process.max_std_ratio, 0.4);

  const auto typo = dir / "typo.yaml";
  std::ofstream(typo) << "merge:\n  matcher:\n    map:\n      gaussian_process:\n"
                         "        lenght_scale_m: 0.7\n";
  try {
    loadPipelineConfig(typo);
    FAIL() << "a misspelt key was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("merge.matcher.map.gaussian_process.lenght_scale_m"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("typo.yaml:5:"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

// ---- real data: the Aalto robot's single magnetometer (see ../shared/data) ----

std::vector<Eigen::Vector3d> readTriples(const std::filesystem::path& file, int columns) {
  std::ifstream in(file);
  std::vector<Eigen::Vector3d> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    for (int k = 0; k < columns; ++k) fields >> v[k];
    rows.push_back(v);
  }
  return rows;
}

// One sequence as a magnetic-only session in a frame T_session_world (planar): the readings
// are already in the world frame, so the body axes are the world's and every keyframe's
// session-frame orientation is T's yaw (as scripts/convert_aalto.py writes it).
Session aaltoSession(const std::filesystem::path& dir, int sequence,
                     const PlanarTransform& T_session_world) {
  const std::string n = std::to_string(sequence);
  const auto t = readTriples(dir / (n + "-time.csv"), 1);
  const auto xy = readTriples(dir / (n + "-loc.csv"), 2);
  const auto mag = readTriples(dir / (n + "-mag.csv"), 3);
  Session s;
  s.id = "seq" + n;
  s.rig.magnetometers_body = {Eigen::Vector3d::Zero()};
  const Eigen::Isometry3d T = T_session_world.toIsometry();
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (i % 5 == 0 || i + 1 == t.size()) {
      Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();
      T_world_body.translation() << xy[i].x(), xy[i].y(), 0.0;
      s.keyframes.push_back({t[i].x(), T * T_world_body});
    }
    s.magnetometer.push_back({t[i].x(), 0, mag[i]});
  }
  return s;
}

// Development data (the Aalto recordings), not a figure: nothing is chosen on it.
TEST(GaussianProcessMapEndToEnd, RealSequencesOfTheUnchangedFieldMatchAtTheirKnownOffset) {
  const auto dir =
      std::filesystem::path(MM4MM_SHARED_DATA_DIR) / "aalto-magnetic-data" / "invensense";
  ASSERT_TRUE(std::filesystem::exists(dir / "1-mag.csv")) << "no Aalto data in " << dir;
  const PlanarTransform T_a_world{0.0, 0.0, 0.0};
  const PlanarTransform T_b_world{3.2, -1.7, 137.0 * M_PI / 180.0};
  const Session a = aaltoSession(dir, 1, T_a_world);
  const Session b = aaltoSession(dir, 3, T_b_world);
  const Eigen::Isometry3d truth = T_a_world.toIsometry() * T_b_world.toIsometry().inverse();

  // The default length scale (0.25 m) covers a narrow swath along each track: these two share
  // about 2.5 m² of it. Counting one independent sample per πℓ² of it, the default finds the
  // place, and its yaw interval covers the yaw error it has.
  const MagneticMatchResult result = matchSessions(a, b, MagneticMatcherConfig{});
  EXPECT_EQ(result.verdict, MatchVerdict::kMatch) << toString(result.verdict);
  EXPECT_LT(result.overlap_m2, 4.0);
  const Eigen::Isometry3d error = result.T_a_b.toIsometry() * truth.inverse();
  const double yaw_error_deg = std::abs(Eigen::AngleAxisd(error.linear()).angle()) * 180.0 / M_PI;
  EXPECT_LT(error.translation().head<2>().norm(), 0.5);
  EXPECT_LT(yaw_error_deg, 2.0);
  EXPECT_GT(result.yaw_uncertainty_deg, yaw_error_deg);

  // Counting one sample per m², as the default did before, a score needs 4 m²: the pair is
  // refused, not misplaced.
  MagneticMatcherConfig per_m2;
  per_m2.single_track.area_per_sample_m2 = 1.0;
  per_m2.single_track.min_overlap_m2 = 4.0;
  per_m2.single_track.min_z = 2.5;
  per_m2.single_track.min_r = 0.825;
  const MagneticMatchResult refused = matchSessions(a, b, per_m2);
  EXPECT_EQ(refused.verdict, MatchVerdict::kNoOverlap) << toString(refused.verdict);
  EXPECT_LT(refused.overlap_m2, per_m2.single_track.min_overlap_m2);
}

}  // namespace
}  // namespace mm4mm
