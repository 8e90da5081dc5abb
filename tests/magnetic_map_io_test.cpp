// Magnetic map files and pictures, and `mm4mm map` as a user runs it: exact PCD round trips,
// readable errors, the PNG's size and colours, and the three output files.

#include "mm4mm/io/magnetic_map_io.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/pcd_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/render/magnetic_map_render.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "test_support.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

class MagneticMapFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mm4mm_magnetic_map_io_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
};

// A grid at an origin no float32 can hold exactly, with random values and random holes.
MagneticMap randomMap(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> field(-60.0f, 60.0f);
  std::bernoulli_distribution covered(0.6);
  MagneticMap map;
  map.origin_m = Eigen::Vector2d(-123.456789012345, 98.7654321);
  map.cell_size_m = 0.05;
  map.width = 37;
  map.height = 23;
  map.height_m = 0.3 + 1e-12;
  for (int i = 0; i < map.width * map.height; ++i) {
    const bool on = covered(rng);
    map.horizontal_uT.push_back(on ? field(rng) : kNaN);
    map.vertical_uT.push_back(on ? field(rng) : kNaN);
    map.total_uT.push_back(on ? field(rng) : kNaN);
    map.session_x_uT.push_back(on ? field(rng) : kNaN);
    map.session_y_uT.push_back(on ? field(rng) : kNaN);
  }
  return map;
}

// Bitwise equality of two float vectors (NaN equals NaN: the coverage mask must survive).
void expectSameBits(const std::vector<float>& a, const std::vector<float>& b, const char* name) {
  ASSERT_EQ(a.size(), b.size()) << name;
  for (std::size_t i = 0; i < a.size(); ++i)
    ASSERT_EQ(std::memcmp(&a[i], &b[i], sizeof(float)), 0)
        << name << "[" << i << "]: " << a[i] << " vs " << b[i];
}

void expectSameMap(const MagneticMap& a, const MagneticMap& b) {
  EXPECT_EQ(a.origin_m.x(), b.origin_m.x());
  EXPECT_EQ(a.origin_m.y(), b.origin_m.y());
  EXPECT_EQ(a.cell_size_m, b.cell_size_m);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.height_m, b.height_m);
  expectSameBits(a.horizontal_uT, b.horizontal_uT, "bh");
  expectSameBits(a.vertical_uT, b.vertical_uT, "bv");
  expectSameBits(a.total_uT, b.total_uT, "bf");
  expectSameBits(a.session_x_uT, b.session_x_uT, "bx");
  expectSameBits(a.session_y_uT, b.session_y_uT, "by");
}

// Quick corridor sessions, as the CLI tests use.
sim::SimulationConfig quickCorridor() {
  sim::SimulationConfig config;
  config.world = "corridor";
  config.lidar.azimuth_step_deg = 4.0;
  config.layout.window_length_m = 16.0;
  return config;
}

TEST_F(MagneticMapFiles, RoundTripIsExact) {
  const MagneticMap map = randomMap(1);
  const fs::path file = dir_ / "map.pcd";
  writeMagneticMapPcd(file, map);
  expectSameMap(readMagneticMapPcd(file), map);
  // The cells are points x y z (a PCD viewer shows them), one per covered cell.
  EXPECT_EQ(readPcd(file).size(), map.coveredCells());
  for (const fs::directory_entry& entry : fs::directory_iterator(dir_))
    EXPECT_EQ(entry.path(), file) << "left behind: " << entry.path();
}

TEST_F(MagneticMapFiles, RoundTripOfASimulatedSessionsMapIsExact) {
  const std::vector<Session> sessions = sim::simulateSessions(quickCorridor(), 1, 5);
  const Session& session = sessions.front();
  const MagneticMap map =
      buildMagneticMap(placeFingerprints(session), session.rig, MagneticMapConfig{});
  ASSERT_GT(map.coveredCells(), 1000u);
  writeMagneticMapPcd(dir_ / "map.pcd", map);
  expectSameMap(readMagneticMapPcd(dir_ / "map.pcd"), map);
}

TEST_F(MagneticMapFiles, EmptyMapsRoundTrip) {
  MagneticMap uncovered = randomMap(2);
  for (auto* values : {&uncovered.horizontal_uT, &uncovered.vertical_uT, &uncovered.total_uT,
                       &uncovered.session_x_uT, &uncovered.session_y_uT})
    values->assign(values->size(), kNaN);
  writeMagneticMapPcd(dir_ / "uncovered.pcd", uncovered);
  expectSameMap(readMagneticMapPcd(dir_ / "uncovered.pcd"), uncovered);
  writeMagneticMapPcd(dir_ / "empty.pcd", MagneticMap{});
  expectSameMap(readMagneticMapPcd(dir_ / "empty.pcd"), MagneticMap{});
}

TEST_F(MagneticMapFiles, GridIsInferredWithoutTheComment) {
  // Another tool's export: ASCII, no grid comment, no bx by, cells 0.1 m apart with a gap.
  const fs::path file = dir_ / "foreign.pcd";
  std::ofstream(file) << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z bh bv bf\nSIZE 4 4 4 4 4 4\n"
                         "TYPE F F F F F F\nCOUNT 1 1 1 1 1 1\nWIDTH 4\nHEIGHT 1\n"
                         "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA ascii\n"
                         "10.05 20.05 0.5 20 -40 44.7\n10.15 20.05 0.5 21 -41 46\n"
                         "10.45 20.05 0.5 22 -42 47\n10.05 20.25 0.5 23 -43 48\n";
  const MagneticMap map = readMagneticMapPcd(file);
  EXPECT_NEAR(map.cell_size_m, 0.1, 1e-6);
  EXPECT_NEAR(map.origin_m.x(), 10.0, 1e-5);
  EXPECT_NEAR(map.origin_m.y(), 20.0, 1e-5);
  EXPECT_EQ(map.width, 5);
  EXPECT_EQ(map.height, 3);
  EXPECT_NEAR(map.height_m, 0.5, 1e-6);
  EXPECT_EQ(map.coveredCells(), 4u);
  EXPECT_FLOAT_EQ(map.total_uT[map.index(4, 0)], 47.0f);
  EXPECT_FLOAT_EQ(map.vertical_uT[map.index(0, 2)], -43.0f);
  EXPECT_TRUE(std::isnan(map.session_x_uT[map.index(0, 0)]));
  EXPECT_FALSE(map.covered(2, 0));
}

// The error must name the file and, for the comment, its line.
void expectInputError(const fs::path& file, const std::string& words, int line = 0) {
  try {
    readMagneticMapPcd(file);
    FAIL() << "no error for " << file;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file.string());
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST_F(MagneticMapFiles, BadFilesAreInputErrorsNamingFileAndLine) {
  expectInputError(dir_ / "missing.pcd", "not found");
  std::ofstream(dir_ / "text.pcd") << "hello\n";
  expectInputError(dir_ / "text.pcd", "not a PCD", 1);

  // The header after FIELDS for `points` ASCII points of five float fields.
  const auto ascii_header = [](int points) {
    const std::string n = std::to_string(points);
    return "SIZE 4 4 4 4 4\nTYPE F F F F F\nCOUNT 1 1 1 1 1\nWIDTH " + n + "\nHEIGHT 1\nPOINTS " +
           n + "\nDATA ascii\n";
  };
  const std::string header_end = ascii_header(1);
  std::ofstream(dir_ / "no_bf.pcd") << "VERSION 0.7\nFIELDS x y z bh bv\n"
                                    << header_end << "0 0 0 1 2\n";
  expectInputError(dir_ / "no_bf.pcd", "bf");

  // Found by fuzz/fuzz_magnetic_map_pcd.cpp: FIELDS and SIZE of different lengths crashed PCL.
  std::ofstream(dir_ / "short_fields.pcd") << "VERSION 0.7\nFIELDS x y z bh\n"
                                           << header_end << "0 0 0 1 2\n";
  expectInputError(dir_ / "short_fields.pcd", "4 FIELDS but 5 SIZE", 9);

  const std::string fields = "VERSION 0.7\nFIELDS x y bh bv bf\n";
  std::ofstream(dir_ / "bad_comment.pcd")
      << "# .PCD v0.7\n# mm4mm_magnetic_grid origin_x_m=0 origin_y_m=zero cell_size_m=0.1 "
         "width=2 height=2 height_m=0\n"
      << fields << header_end << "0.05 0.05 1 2 3\n";
  expectInputError(dir_ / "bad_comment.pcd", "origin_y_m", 2);

  const std::string grid =
      "# mm4mm_magnetic_grid origin_x_m=0 origin_y_m=0 cell_size_m=0.1 width=2 height=2 "
      "height_m=0\n";
  std::ofstream(dir_ / "off_grid.pcd") << grid << fields << header_end << "0.08 0.05 1 2 3\n";
  expectInputError(dir_ / "off_grid.pcd", "not at a cell centre");
  std::ofstream(dir_ / "outside.pcd") << grid << fields << header_end << "0.55 0.05 1 2 3\n";
  expectInputError(dir_ / "outside.pcd", "outside the grid");
  std::ofstream(dir_ / "nan.pcd") << grid << fields << header_end << "0.05 0.05 1 nan 3\n";
  expectInputError(dir_ / "nan.pcd", "non-finite bv");
  std::ofstream(dir_ / "twice.pcd")
      << grid << fields << ascii_header(2) << "0.05 0.05 1 2 3\n0.05 0.05 1 2 3\n";
  expectInputError(dir_ / "twice.pcd", "repeats the cell");
  std::ofstream(dir_ / "corrupt.pcd")
      << fields
      << "SIZE 4 4 4 4 4\nTYPE F F F F F\nCOUNT 1 1 1 1 1\nWIDTH 1000000000\nHEIGHT 1\n"
         "POINTS 1000000000\nDATA binary\n0123456789";
  expectInputError(dir_ / "corrupt.pcd", "declares 1000000000 points in 10 bytes", 9);
  // Found by fuzz/fuzz_magnetic_map_pcd.cpp in CI: without the grid comment, a far coordinate
  // overflowed the inferred width into a negative count and the grid's allocation threw.
  std::ofstream(dir_ / "far.pcd") << fields << ascii_header(2)
                                  << "0.05 0.05 1 2 3\n0.15 -33333333333333333 1 2 3\n";
  expectInputError(dir_ / "far.pcd", "implausibly large grid");
  // And grids that fit the cell limit but not memory: 10^8 cells (2 GB) for three points.
  std::ofstream(dir_ / "sparse.pcd")
      << fields << ascii_header(3) << "0.05 0.05 1 2 3\n0.15 0.05 1 2 3\n1000.05 1000.05 1 2 3\n";
  expectInputError(dir_ / "sparse.pcd", "10001 x 10001 cells for 3 fingerprints");
  std::ofstream(dir_ / "sparse_comment.pcd")
      << "# mm4mm_magnetic_grid origin_x_m=0 origin_y_m=0 cell_size_m=0.1 width=20000 "
         "height=20000 height_m=0\n"
      << fields << header_end << "0.05 0.05 1 2 3\n";
  expectInputError(dir_ / "sparse_comment.pcd", "20000 x 20000 cells for 1 fingerprints");
}

// ---------------------------------------------------------------------------------------------
// Pictures

// Width and height from a PNG's IHDR chunk (big-endian, bytes 16 to 23).
std::pair<int, int> pngSize(const fs::path& file) {
  std::ifstream stream(file, std::ios::binary);
  std::array<unsigned char, 24> head{};
  stream.read(reinterpret_cast<char*>(head.data()), head.size());
  const auto word = [&](int at) {
    return (head[at] << 24) | (head[at + 1] << 16) | (head[at + 2] << 8) | head[at + 3];
  };
  EXPECT_EQ(std::memcmp(head.data() + 1, "PNG", 3), 0);
  return {word(16), word(20)};
}

// A 10 m x 4 m map whose B_F rises linearly along x and whose right half of the top row is
// uncovered; B_v falls along x.
MagneticMap rampMap() {
  MagneticMap map;
  map.origin_m = Eigen::Vector2d(5.0, -2.0);
  map.cell_size_m = 0.1;
  map.width = 100;
  map.height = 40;
  for (int iy = 0; iy < map.height; ++iy)
    for (int ix = 0; ix < map.width; ++ix) {
      const bool covered = !(iy >= 30 && ix >= 50);
      const float t = static_cast<float>(ix);
      map.horizontal_uT.push_back(covered ? 20.0f : kNaN);
      map.vertical_uT.push_back(covered ? -30.0f - 0.1f * t : kNaN);
      map.total_uT.push_back(covered ? 40.0f + 0.1f * t : kNaN);
      map.session_x_uT.push_back(covered ? 20.0f : kNaN);
      map.session_y_uT.push_back(covered ? 0.0f : kNaN);
    }
  return map;
}

struct Rgb8 {
  int r, g, b;
  bool grey() const { return r == g && g == b; }
};

Rgb8 at(const std::vector<std::uint8_t>& rgb, const MagneticMapRenderLayout& layout,
        const Eigen::Vector2d& xy_m) {
  const Eigen::Vector2d px = layout.pixelOf(xy_m);
  const std::size_t i = (static_cast<std::size_t>(std::floor(px.y())) * layout.width_px +
                         static_cast<std::size_t>(std::floor(px.x()))) *
                        3;
  return {rgb[i], rgb[i + 1], rgb[i + 2]};
}

TEST_F(MagneticMapFiles, PictureColoursCoveredCellsByValue) {
  const MagneticMap map = rampMap();
  MagneticMapRenderOptions options;
  const MagneticMapRenderLayout layout = layoutMagneticMapRender(map, options);
  // 10 m x 4 m plus 1 m margins at 20 px/m. Of the 3500 covered cells, the 2nd and 98th
  // percentiles fall in columns 1 and 97 (50 columns of 40 cells, then 50 of 30).
  EXPECT_NEAR(layout.map_area_m.sizes().x(), 12.0, 1e-9);
  EXPECT_NEAR(layout.map_area_m.sizes().y(), 6.0, 1e-9);
  EXPECT_NEAR(layout.colour_low_uT, 40.1, 0.01);
  EXPECT_NEAR(layout.colour_high_uT, 49.7, 0.01);

  const fs::path png = dir_ / "map.png";
  renderMagneticMapPng(map, options, png);
  EXPECT_EQ(pngSize(png), std::make_pair(layout.width_px, layout.height_px));
  EXPECT_FALSE(fs::exists(dir_ / "map.png.tmp"));

  const std::vector<std::uint8_t> rgb = renderMagneticMapRgb(map, options);
  ASSERT_EQ(rgb.size(), static_cast<std::size_t>(layout.width_px) * layout.height_px * 3);
  // Low B_F on the left is viridis' dark purple, high on the right its yellow.
  const Rgb8 left = at(rgb, layout, {5.05, 0.0}), right = at(rgb, layout, {14.95, -1.0});
  EXPECT_GT(left.b, left.g);
  EXPECT_LT(left.r + left.g + left.b, 250);
  EXPECT_GT(right.r, 200);
  EXPECT_GT(right.g, 200);
  EXPECT_LT(right.b, 100);
  // Every covered cell is coloured; uncovered cells and the margin are grey.
  for (int ix = 0; ix < map.width; ix += 3)
    for (int iy = 0; iy < map.height; iy += 3) {
      const Rgb8 pixel = at(rgb, layout, map.cellCentre(ix, iy));
      EXPECT_EQ(pixel.grey(), !map.covered(ix, iy)) << ix << ", " << iy;
    }
  EXPECT_TRUE(at(rgb, layout, {4.5, 0.0}).grey());
  EXPECT_TRUE(at(rgb, layout, {14.0, 1.5}).grey());

  // B_v falls along x: the same map drawn in B_v is bright on the left.
  options.component = MagneticComponent::kVertical;
  const std::vector<std::uint8_t> vertical = renderMagneticMapRgb(map, options);
  const Rgb8 v_left = at(vertical, layout, {5.05, 0.0});
  EXPECT_GT(v_left.r, 200);
  EXPECT_LT(v_left.b, 100);
}

TEST_F(MagneticMapFiles, PictureRejectsUncoveredMapsAndBadOptions) {
  MagneticMap map = rampMap();
  MagneticMapRenderOptions options;
  options.pixels_per_metre = 0.0;
  std::string error;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("pixels_per_metre"), std::string::npos);
  EXPECT_THROW(renderMagneticMapPng(map, options, dir_ / "bad.png"), std::invalid_argument);
  map.total_uT.assign(map.total_uT.size(), kNaN);
  EXPECT_THROW(renderMagneticMapPng(map, MagneticMapRenderOptions{}, dir_ / "empty.png"),
               std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir_ / "empty.png"));
}

// A change map as an atlas's fused grid holds one: an origin float32 cannot hold, compared cells
// with random values, some in numbered regions.
ChangeMap randomChangeMap(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution compared(0.5), in_region(0.1);
  std::uniform_real_distribution<float> chi2(0.0f, 80.0f), delta(0.0f, 12.0f);
  ChangeMap map;
  map.origin_m = Eigen::Vector2d(-123.456789012345, 98.7654321);
  map.cell_size_m = 0.05;
  map.width = 41;
  map.height = 19;
  map.height_m = 0.3 + 1e-12;
  for (int i = 0; i < map.width * map.height; ++i) {
    const bool on = compared(rng);
    map.pairs.push_back(on ? static_cast<std::uint16_t>(1 + rng() % 5) : 0);
    map.chi2.push_back(on ? chi2(rng) : kNaN);
    map.delta_uT.push_back(on ? delta(rng) : kNaN);
    map.region.push_back(on && in_region(rng) ? 1 + rng() % 3 : 0);
  }
  return map;
}

TEST_F(MagneticMapFiles, ChangeMapRoundTripIsExactAndBadOnesAreNamed) {
  const ChangeMap map = randomChangeMap(7);
  ASSERT_GT(map.comparedCells(), 300u);
  const fs::path file = dir_ / "magnetic_change.pcd";
  writeChangeMapPcd(file, map);
  const ChangeMap back = readChangeMapPcd(file);
  EXPECT_EQ(back.origin_m, map.origin_m);
  EXPECT_EQ(back.cell_size_m, map.cell_size_m);
  EXPECT_EQ(back.width, map.width);
  EXPECT_EQ(back.height, map.height);
  EXPECT_EQ(back.height_m, map.height_m);
  EXPECT_EQ(back.pairs, map.pairs);
  EXPECT_EQ(back.region, map.region);
  expectSameBits(back.chi2, map.chi2, "chi2");
  expectSameBits(back.delta_uT, map.delta_uT, "delta");

  // A map with no compared cell is a file without points, and reads back so.
  ChangeMap none = map;
  std::fill(none.pairs.begin(), none.pairs.end(), 0);
  writeChangeMapPcd(dir_ / "none.pcd", none);
  EXPECT_EQ(readChangeMapPcd(dir_ / "none.pcd").comparedCells(), 0u);

  // Vectors that do not match the grid are the writer's caller's bug.
  ChangeMap short_map = map;
  short_map.region.pop_back();
  EXPECT_THROW(writeChangeMapPcd(dir_ / "short.pcd", short_map), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir_ / "short.pcd"));

  const auto expectBad = [&](const fs::path& bad, const std::string& words) {
    try {
      readChangeMapPcd(bad);
      FAIL() << "no error for " << bad;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), bad.string());
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expectBad(dir_ / "missing.pcd", "not found");
  // A fused magnetic map is no change map.
  writeMagneticMapPcd(dir_ / "magnetic_map.pcd", randomMap(3));
  expectBad(dir_ / "magnetic_map.pcd", "no field 'delta'");
  const std::string header =
      "VERSION 0.7\nFIELDS x y z delta chi2 region pairs\nSIZE 4 4 4 4 4 4 4\n"
      "TYPE F F F F F F F\nCOUNT 1 1 1 1 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n";
  std::ofstream(dir_ / "no_grid.pcd") << header << "0.05 0.05 0 1 2 0 1\n";
  expectBad(dir_ / "no_grid.pcd", "mm4mm_magnetic_grid");
  const std::string grid =
      "# mm4mm_magnetic_grid origin_x_m=0 origin_y_m=0 cell_size_m=0.1 width=2 height=2 "
      "height_m=0\n";
  std::ofstream(dir_ / "half_region.pcd") << grid << header << "0.05 0.05 0 1 2 1.5 1\n";
  expectBad(dir_ / "half_region.pcd", "whole numbers");
  std::ofstream(dir_ / "twice.pcd") << grid
                                    << "VERSION 0.7\nFIELDS x y z delta chi2 region pairs\n"
                                       "SIZE 4 4 4 4 4 4 4\nTYPE F F F F F F F\n"
                                       "COUNT 1 1 1 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\n"
                                       "DATA ascii\n0.05 0.05 0 1 2 0 1\n0.05 0.05 0 1 2 0 1\n";
  expectBad(dir_ / "twice.pcd", "repeats the cell");
}

TEST_F(MagneticMapFiles, ChangePictureOutlinesTheRegionsInRed) {
  // |dB| of 1 uT everywhere on the ramp map's cells, and a 2 m x 1 m region in the middle.
  MagneticMap delta = rampMap();
  MapRegionOverlay regions;
  regions.of_cell.assign(delta.total_uT.size(), 0);
  for (int iy = 0; iy < delta.height; ++iy)
    for (int ix = 0; ix < delta.width; ++ix) {
      const std::size_t i = delta.index(ix, iy);
      if (std::isnan(delta.total_uT[i])) continue;
      delta.horizontal_uT[i] = delta.vertical_uT[i] = delta.total_uT[i] = 1.0f;
      if (ix >= 40 && ix < 60 && iy >= 10 && iy < 20) regions.of_cell[i] = 1;
    }
  regions.label_at_m.push_back(Eigen::Vector2d(10.0, -0.5));
  MagneticMapRenderOptions options;
  options.colour_low_uT = 0.0;
  options.colour_high_uT = 10.0;
  const MagneticMapRenderLayout layout = layoutMagneticMapRender(delta, options);
  const auto red = [](const Rgb8& p) { return p.r > 180 && p.g < 80 && p.b < 80; };
  const auto redPixels = [&](const std::vector<std::uint8_t>& rgb) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < rgb.size(); i += 3) n += red({rgb[i], rgb[i + 1], rgb[i + 2]});
    return n;
  };
  const std::vector<std::uint8_t> plain = renderMagneticMapRgb(delta, options);
  EXPECT_EQ(redPixels(plain), 0u);
  const std::vector<std::uint8_t> outlined = renderMagneticMapRgb(delta, options, &regions);
  // The outline: 2 m + 1 m + 2 m + 1 m at 20 px/m, two pixels wide, and the number.
  EXPECT_GT(redPixels(outlined), 200u);
  EXPECT_TRUE(red(at(outlined, layout, {10.5, -1.0})));   // the region's lower edge, y = -1 m
  EXPECT_FALSE(red(at(outlined, layout, {10.5, -0.7})));  // inside it: the map's own colour
  EXPECT_FALSE(red(at(outlined, layout, {7.0, -0.5})));   // outside it
  // The atlas's picture is a PNG of the same map.
  const std::string png = encodeChangePicture(delta, regions, 3);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  // An overlay that is not one label per cell is refused.
  regions.of_cell.pop_back();
  EXPECT_THROW(renderMagneticMapRgb(delta, options, &regions), std::invalid_argument);
}

TEST_F(MagneticMapFiles, LargeMapsAreScaledToTheSizeLimit) {
  MagneticMap map = rampMap();
  map.cell_size_m = 5.0;  // 500 m x 200 m
  MagneticMapRenderOptions options;
  options.max_image_side_px = 1000;
  const MagneticMapRenderLayout layout = layoutMagneticMapRender(map, options);
  EXPECT_LE(layout.width_px, 1000);
  EXPECT_LE(layout.height_px, 1000);
  EXPECT_LT(layout.pixels_per_metre, 2.0);
  renderMagneticMapPng(map, options, dir_ / "large.png");
  EXPECT_EQ(pngSize(dir_ / "large.png"), std::make_pair(layout.width_px, layout.height_px));
}

// ---------------------------------------------------------------------------------------------
// mm4mm map

using mm4mm::test::CliRun;
using mm4mm::test::runCli;

TEST_F(MagneticMapFiles, MapCommandWritesTheThreeFiles) {
  const std::vector<Session> sessions = sim::simulateSessions(quickCorridor(), 1, 3);
  writeSession(sessions.front(), dir_ / "s0");
  const CliRun run = runCli("map " + (dir_ / "s0").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("covered"), std::string::npos) << run.output;
  const fs::path out = dir_ / "s0" / "map";
  const MagneticMap map = readMagneticMapPcd(out / "magnetic_map.pcd");
  // One magnetometer: the Gaussian-process map covers a swath along the path, some fraction of a
  // length scale either side (here 0.28 m wide over 59 m), never the whole floor.
  double travelled = 0.0;
  for (std::size_t k = 1; k < sessions.front().keyframes.size(); ++k)
    travelled += (sessions.front().keyframes[k].T_frame_body.translation() -
                  sessions.front().keyframes[k - 1].T_frame_body.translation())
                     .norm();
  const double length_scale = GaussianProcessMapConfig{}.length_scale_m;
  EXPECT_GT(map.coveredArea_m2(), 0.8 * length_scale * travelled);
  EXPECT_LT(map.coveredArea_m2(), 4.0 * length_scale * travelled);
  EXPECT_DOUBLE_EQ(map.cell_size_m, 0.05);
  const auto [width, height] = pngSize(out / "magnetic_map.png");
  EXPECT_GT(width, 300);
  EXPECT_GT(height, 200);
  EXPECT_GT(readPcd(out / "point_map.pcd").size(), 1000u);

  // Options reach the stages; --out puts the files elsewhere.
  const CliRun coarse = runCli("map " + (dir_ / "s0").string() + " --out " +
                               (dir_ / "coarse").string() + " --cell-size 0.2 --voxel-size 0.5");
  ASSERT_EQ(coarse.exit_code, 0) << coarse.output;
  EXPECT_DOUBLE_EQ(readMagneticMapPcd(dir_ / "coarse" / "magnetic_map.pcd").cell_size_m, 0.2);
  EXPECT_LT(readPcd(dir_ / "coarse" / "point_map.pcd").size(),
            readPcd(out / "point_map.pcd").size() / 2);
}

TEST_F(MagneticMapFiles, MapCommandOnANonSessionIsBadInput) {
  const CliRun run = runCli("map " + dir_.string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("not a session directory"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find(dir_.string()), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(dir_ / "map"));
  const CliRun bad_cell = runCli("map " + dir_.string() + " --cell-size -1");
  EXPECT_EQ(bad_cell.exit_code, 2) << bad_cell.output;
  EXPECT_NE(bad_cell.output.find("cell_size_m"), std::string::npos) << bad_cell.output;
}

}  // namespace
}  // namespace mm4mm
