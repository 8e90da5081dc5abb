#include <cairo.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/render/session_render.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

// A straight 20 m drive along x with the robot turned 0.3 rad off its direction of travel, so a
// renderer that ignored keyframe rotations would put walls and sensors in the wrong place.
constexpr double kYaw = 0.3;
const Eigen::Vector3d kSensorBody(0.0, -1.0, 0.3);

Eigen::Isometry3d keyframePose(double x) { return planarPose(x, 0.0, kYaw); }

double fieldAt(double t) { return 40.0 + t; }  // |B| rises by 1 µT per metre along the track

Eigen::Vector2d sensorAt(double t) { return (keyframePose(t) * kSensorBody).head<2>(); }

// Each scan sees, in the session frame: a wall at y = 6 m (x from -2 to 22 m, inside the height
// band), a floor strip at y = 3 m and a ceiling strip at y = -4 m (both outside it), and one
// long return 500 m away that must not stretch the picture.
PointCloud scanFrom(const Eigen::Isometry3d& T_session_body) {
  const Eigen::Isometry3d T_body_session = T_session_body.inverse();
  PointCloud scan;
  const auto add = [&](double x, double y, double z) {
    scan.push_back((T_body_session * Eigen::Vector3d(x, y, z)).cast<float>());
  };
  for (double x = -2.0; x <= 22.0 + 1e-9; x += 0.05) {
    for (double z : {0.5, 1.0, 1.5}) add(x, 6.0, z);
    add(x, 3.0, 0.0);
    add(x, -4.0, 3.0);
  }
  add(500.0, 0.0, 1.0);
  return scan;
}

Session syntheticSession() {
  Session session;
  session.id = "render-test";
  session.rig.magnetometers_body = {kSensorBody};
  for (int k = 0; k <= 20; ++k) {
    session.keyframes.push_back({static_cast<double>(k), keyframePose(k)});
    session.scans.push_back(scanFrom(keyframePose(k)));
  }
  // Samples before the first keyframe cannot be placed and must be skipped.
  for (double t = -2.0; t <= 20.0 + 1e-9; t += 0.05)
    session.magnetometer.push_back({t, 0, Eigen::Vector3d(0.0, 0.0, fieldAt(t))});
  // One reading next to steel: without percentile clipping it would squash the colour range.
  session.magnetometer.push_back({10.02, 0, Eigen::Vector3d(500.0, 0.0, 0.0)});
  return session;
}

struct Rgb8 {
  int r, g, b;
};

class PngImage {
 public:
  explicit PngImage(const fs::path& path)
      : surface_(cairo_image_surface_create_from_png(path.c_str())) {}
  ~PngImage() { cairo_surface_destroy(surface_); }
  PngImage(const PngImage&) = delete;
  PngImage& operator=(const PngImage&) = delete;

  bool ok() const { return cairo_surface_status(surface_) == CAIRO_STATUS_SUCCESS; }
  int width() const { return cairo_image_surface_get_width(surface_); }
  int height() const { return cairo_image_surface_get_height(surface_); }
  Rgb8 at(const Eigen::Vector2d& px) const {
    const int col = static_cast<int>(std::floor(px.x()));
    const int row = static_cast<int>(std::floor(px.y()));
    uint32_t pixel = 0;
    std::memcpy(&pixel,
                cairo_image_surface_get_data(surface_) +
                    row * cairo_image_surface_get_stride(surface_) + col * 4,
                sizeof(pixel));
    return {static_cast<int>((pixel >> 16) & 0xFF), static_cast<int>((pixel >> 8) & 0xFF),
            static_cast<int>(pixel & 0xFF)};
  }

 private:
  cairo_surface_t* surface_;
};

class SessionRender : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mm4mm_render_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
};

TEST_F(SessionRender, PictureSizeFollowsScaleAndIgnoresFilteredAndFarPoints) {
  const Session session = syntheticSession();
  SessionRenderOptions options;
  const SessionRenderLayout layout10 = layoutSessionRender(session, options);
  // x: the wall spans [-2, 22] m; y: from the sensor track (-cos(0.3) m) to the wall (6 m); the
  // ceiling at -4 m and the return at x = 500 m must not count. Plus 2 m margin.
  EXPECT_NEAR(layout10.map_area_m.min().x(), -4.0, 1e-4);
  EXPECT_NEAR(layout10.map_area_m.max().x(), 24.0, 1e-4);
  EXPECT_NEAR(layout10.map_area_m.min().y(), -std::cos(kYaw) - 2.0, 1e-4);
  EXPECT_NEAR(layout10.map_area_m.max().y(), 8.0, 1e-4);
  EXPECT_DOUBLE_EQ(layout10.pixels_per_metre, 10.0);

  // Scales at which the map, not the minimum picture size, sets both sides.
  options.pixels_per_metre = 20.0;
  const SessionRenderLayout layout20 = layoutSessionRender(session, options);
  const fs::path png20 = dir_ / "scale20.png";
  renderSessionPng(session, options, png20);
  options.pixels_per_metre = 40.0;
  const fs::path png40 = dir_ / "scale40.png";
  renderSessionPng(session, options, png40);

  const PngImage image20(png20), image40(png40);
  ASSERT_TRUE(image20.ok());
  ASSERT_TRUE(image40.ok());
  EXPECT_EQ(image20.width(), layout20.width_px);
  EXPECT_EQ(image20.height(), layout20.height_px);
  // Doubling the scale adds one more map's worth of pixels; furniture around it stays fixed.
  EXPECT_NEAR(image40.width() - image20.width(), 28.0 * 20.0, 1.0);
  EXPECT_NEAR(image40.height() - image20.height(), (10.0 + std::cos(kYaw)) * 20.0, 1.0);
  EXPECT_FALSE(fs::exists(dir_ / "scale20.png.tmp"));
}

TEST_F(SessionRender, ScaleIsLoweredToRespectMaximumSide) {
  const Session session = syntheticSession();
  SessionRenderOptions options;
  options.pixels_per_metre = 100.0;
  options.max_image_side_px = 400;
  const fs::path png = dir_ / "limited.png";
  renderSessionPng(session, options, png);
  const PngImage image(png);
  ASSERT_TRUE(image.ok());
  EXPECT_LE(image.width(), 400);
  EXPECT_LE(image.height(), 400);
  EXPECT_EQ(image.width(), 400);  // x is the long side, so it meets the limit exactly
  EXPECT_LT(layoutSessionRender(session, options).pixels_per_metre, 100.0);
}

TEST_F(SessionRender, WallIsDarkAndFilteredHeightsStayBlank) {
  const Session session = syntheticSession();
  const SessionRenderOptions options;
  const SessionRenderLayout layout = layoutSessionRender(session, options);
  const fs::path png = dir_ / "wall.png";
  renderSessionPng(session, options, png);
  const PngImage image(png);
  ASSERT_TRUE(image.ok());

  const Rgb8 wall = image.at(layout.pixelOf({10.0, 6.0}));
  const Rgb8 floor = image.at(layout.pixelOf({10.0, 3.0}));
  const Rgb8 ceiling = image.at(layout.pixelOf({10.0, -4.0 + 0.95}));  // inside the map area
  EXPECT_EQ(floor.r, 255);
  EXPECT_EQ(floor.g, 255);
  EXPECT_EQ(floor.b, 255);
  EXPECT_EQ(ceiling.r, 255);
  EXPECT_LT(wall.r, 200);
  EXPECT_EQ(wall.r, wall.g);  // drawn in grey
  EXPECT_EQ(wall.g, wall.b);
}

TEST_F(SessionRender, SampleColoursFollowFieldAlongTrack) {
  const Session session = syntheticSession();
  const SessionRenderOptions options;
  const SessionRenderLayout layout = layoutSessionRender(session, options);
  const fs::path png = dir_ / "field.png";
  renderSessionPng(session, options, png);
  const PngImage image(png);
  ASSERT_TRUE(image.ok());

  // Viridis runs from dark purple (68, 1, 84) at low |B| to yellow (253, 231, 37) at high |B|.
  const Rgb8 low = image.at(layout.pixelOf(sensorAt(0.3)));
  const Rgb8 high = image.at(layout.pixelOf(sensorAt(19.7)));
  EXPECT_LT(low.r, 110);
  EXPECT_LT(low.g, 60);
  EXPECT_GT(low.b, low.g + 30);
  // The 500 µT outlier would make this end dark too if the range were not clipped.
  EXPECT_GT(high.r, 200);
  EXPECT_GT(high.g, 200);
  EXPECT_LT(high.b, 100);
}

TEST_F(SessionRender, MagneticOnlySessionStillRenders) {
  Session session = syntheticSession();
  session.scans.clear();
  const SessionRenderOptions options;
  const SessionRenderLayout layout = layoutSessionRender(session, options);
  EXPECT_TRUE(layout.has_colour_bar);
  EXPECT_NEAR(layout.map_area_m.max().y(), 2.0, 1e-9);  // only the trajectory at y = 0
  const fs::path png = dir_ / "magnetic_only.png";
  renderSessionPng(session, options, png);
  const PngImage image(png);
  ASSERT_TRUE(image.ok());
  EXPECT_EQ(image.width(), layout.width_px);
  const Rgb8 high = image.at(layout.pixelOf(sensorAt(19.7)));
  EXPECT_GT(high.g, 200);
}

TEST_F(SessionRender, SessionWithoutSamplesHasNoColourBar) {
  Session session = syntheticSession();
  const SessionRenderOptions options;
  const int width_with_bar = layoutSessionRender(session, options).width_px;
  session.magnetometer.clear();
  const SessionRenderLayout layout = layoutSessionRender(session, options);
  EXPECT_FALSE(layout.has_colour_bar);
  EXPECT_LT(layout.width_px, width_with_bar);
  const fs::path png = dir_ / "no_samples.png";
  renderSessionPng(session, options, png);
  EXPECT_TRUE(PngImage(png).ok());
}

TEST_F(SessionRender, SingleKeyframeSessionRenders) {
  Session session;
  session.id = "one";
  session.keyframes.push_back({0.0, Eigen::Isometry3d::Identity()});
  const fs::path png = dir_ / "one.png";
  renderSessionPng(session, SessionRenderOptions(), png);
  EXPECT_TRUE(PngImage(png).ok());
}

TEST_F(SessionRender, UnwritablePathThrowsWithPath) {
  const fs::path png = dir_ / "missing_dir" / "out.png";
  try {
    renderSessionPng(syntheticSession(), SessionRenderOptions(), png);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find(png.string()), std::string::npos) << error.what();
  }
  EXPECT_FALSE(fs::exists(png));
}

// Two sessions merged into an atlas, plus one that stayed unconnected. Session "a" drives along
// y = 0 and sees a wall at y = 5 m; session "b" drives along y = 1 m, turned and with odometry
// that disagrees with its optimised poses, and sees a wall at y = -4 m; session "c" (unconnected)
// sees a wall at y = 12 m. Walls span x in [0, 12] m in the atlas frame.
PointCloud wallScanFrom(const Eigen::Isometry3d& T_atlas_body, double wall_y) {
  const Eigen::Isometry3d T_body_atlas = T_atlas_body.inverse();
  PointCloud scan;
  for (double x = 0.0; x <= 12.0 + 1e-9; x += 0.05) {
    for (double z : {0.5, 1.0, 1.5})
      scan.push_back((T_body_atlas * Eigen::Vector3d(x, wall_y, z)).cast<float>());
    scan.push_back((T_body_atlas * Eigen::Vector3d(x, 2.5, 0.0)).cast<float>());  // floor
  }
  return scan;
}

struct SyntheticAtlas {
  std::vector<Session> sessions;
  std::vector<std::vector<Eigen::Isometry3d>> T_atlas_keyframe;
  std::vector<bool> connected;

  std::vector<const Session*> pointers() const {
    std::vector<const Session*> out;
    for (const Session& session : sessions) out.push_back(&session);
    return out;
  }
};

SyntheticAtlas syntheticAtlas() {
  SyntheticAtlas atlas;
  const auto add = [&](const std::string& id, double y, double yaw, double wall_y, bool connected) {
    Session session;
    session.id = id;
    std::vector<Eigen::Isometry3d> poses;
    for (int k = 0; k <= 8; ++k) {
      const Eigen::Isometry3d T_atlas_body = planarPose(2.0 + k, y, yaw);
      // Odometry in the session's own frame: offset, rotated and stretched, so that a renderer
      // using it instead of the atlas poses would put the wall elsewhere.
      session.keyframes.push_back({static_cast<double>(k), planarPose(1.3 * k, 7.0, 0.1 * k)});
      session.scans.push_back(wallScanFrom(T_atlas_body, wall_y));
      poses.push_back(T_atlas_body);
    }
    atlas.sessions.push_back(session);
    atlas.T_atlas_keyframe.push_back(poses);
    atlas.connected.push_back(connected);
  };
  add("a", 0.0, 0.0, 5.0, true);
  add("b", 1.0, 0.4, -4.0, true);
  add("c", 0.0, 0.0, 12.0, false);
  return atlas;
}

bool near(const Rgb8& pixel, const std::array<std::uint8_t, 3>& colour) {
  return std::abs(pixel.r - colour[0]) <= 2 && std::abs(pixel.g - colour[1]) <= 2 &&
         std::abs(pixel.b - colour[2]) <= 2;
}

// Pixels of `colour` inside the drawn map area (so legend swatches do not count).
int countInMapArea(const PngImage& image, const SessionRenderLayout& layout,
                   const std::array<std::uint8_t, 3>& colour) {
  const Eigen::Vector2d top_left =
      layout.pixelOf({layout.map_area_m.min().x(), layout.map_area_m.max().y()});
  const Eigen::Vector2d bottom_right =
      layout.pixelOf({layout.map_area_m.max().x(), layout.map_area_m.min().y()});
  int count = 0;
  for (int row = static_cast<int>(top_left.y()); row < static_cast<int>(bottom_right.y()); ++row)
    for (int col = static_cast<int>(top_left.x()); col < static_cast<int>(bottom_right.x()); ++col)
      if (near(image.at({col + 0.5, row + 0.5}), colour)) ++count;
  return count;
}

TEST_F(SessionRender, AtlasDrawsConnectedSessionsInTheirOwnColoursAtAtlasPoses) {
  const SyntheticAtlas atlas = syntheticAtlas();
  const SessionRenderOptions options;
  const SessionRenderLayout layout =
      layoutAtlasRender(atlas.pointers(), atlas.T_atlas_keyframe, atlas.connected, options);
  EXPECT_TRUE(layout.has_legend);
  EXPECT_FALSE(layout.has_colour_bar);
  // Walls of a and b, plus the margin; the unconnected session's wall at y = 12 m and the
  // odometry poses (y = 7 m and beyond) must not count.
  EXPECT_NEAR(layout.map_area_m.min().x(), -2.0, 1e-4);
  EXPECT_NEAR(layout.map_area_m.max().x(), 14.0, 1e-4);
  EXPECT_NEAR(layout.map_area_m.min().y(), -6.0, 1e-4);
  EXPECT_NEAR(layout.map_area_m.max().y(), 7.0, 1e-4);

  const fs::path png = dir_ / "atlas.png";
  renderAtlasPng(atlas.pointers(), atlas.T_atlas_keyframe, atlas.connected, options, "atlas test",
                 png);
  const PngImage image(png);
  ASSERT_TRUE(image.ok());
  EXPECT_EQ(image.width(), layout.width_px);
  EXPECT_EQ(image.height(), layout.height_px);
  EXPECT_FALSE(fs::exists(dir_ / "atlas.png.tmp"));

  // Both walls grey where the atlas poses put them; the filtered floor blank.
  for (const Eigen::Vector2d& xy : {Eigen::Vector2d(6.0, 5.0), Eigen::Vector2d(1.0, 5.0),
                                    Eigen::Vector2d(6.0, -4.0), Eigen::Vector2d(11.0, -4.0)}) {
    const Rgb8 wall = image.at(layout.pixelOf(xy));
    EXPECT_LT(wall.r, 200) << xy.transpose();
    EXPECT_EQ(wall.r, wall.g) << xy.transpose();
    EXPECT_EQ(wall.g, wall.b) << xy.transpose();
  }
  const Rgb8 floor = image.at(layout.pixelOf({6.0, 2.5}));
  EXPECT_EQ(floor.r + floor.g + floor.b, 3 * 255);

  // Each connected session's trajectory in its palette colour, none in the single-session red.
  const std::array<std::uint8_t, 3> colour_a = atlasSessionColour(0);
  const std::array<std::uint8_t, 3> colour_b = atlasSessionColour(1);
  EXPECT_GT(countInMapArea(image, layout, colour_a), 50);
  EXPECT_GT(countInMapArea(image, layout, colour_b), 50);
  EXPECT_EQ(countInMapArea(image, layout, {140, 0, 0}), 0);
  EXPECT_TRUE(near(image.at(layout.pixelOf({2.0, 0.0})), colour_a));  // a's start marker
  const Eigen::Vector2d b_start = atlas.T_atlas_keyframe[1].front().translation().head<2>();
  EXPECT_TRUE(near(image.at(layout.pixelOf(b_start)), colour_b));
  // The legend, right of the map area, shows both colours too.
  int legend_a = 0, legend_b = 0;
  const int legend_left = static_cast<int>(layout.pixelOf(layout.map_area_m.max()).x()) + 1;
  for (int row = 0; row < image.height(); ++row)
    for (int col = legend_left; col < image.width(); ++col) {
      legend_a += near(image.at({col + 0.5, row + 0.5}), colour_a);
      legend_b += near(image.at({col + 0.5, row + 0.5}), colour_b);
    }
  EXPECT_GT(legend_a, 20);
  EXPECT_GT(legend_b, 20);
}

TEST_F(SessionRender, OneSessionAtItsOdometryIsTheSessionPicture) {
  Session session = syntheticSession();
  session.magnetometer.clear();
  std::vector<Eigen::Isometry3d> odometry;
  for (const StampedPose& keyframe : session.keyframes) odometry.push_back(keyframe.T_frame_body);
  const SessionRenderOptions options;
  const SessionRenderLayout single = layoutSessionRender(session, options);
  const SessionRenderLayout atlas = layoutAtlasRender({&session}, {odometry}, {true}, options);
  EXPECT_TRUE(atlas.map_area_m.isApprox(single.map_area_m));
  EXPECT_DOUBLE_EQ(atlas.pixels_per_metre, single.pixels_per_metre);
  EXPECT_EQ(atlas.height_px, single.height_px);
  EXPECT_GT(atlas.width_px, single.width_px);  // the legend band
}

TEST(AtlasRender, PaletteIsDistinctAndNeverGrey) {
  for (std::size_t i = 0; i < 9; ++i) {
    const std::array<std::uint8_t, 3> c = atlasSessionColour(i);
    EXPECT_FALSE(c[0] == c[1] && c[1] == c[2]) << i;
    for (std::size_t j = 0; j < i; ++j) EXPECT_NE(c, atlasSessionColour(j)) << i << " " << j;
  }
  EXPECT_EQ(atlasSessionColour(9), atlasSessionColour(0));
}

TEST(AtlasRender, InconsistentInputsThrowWithClearMessages) {
  const SyntheticAtlas atlas = syntheticAtlas();
  const SessionRenderOptions options;
  const auto message = [&](std::vector<const Session*> sessions,
                           std::vector<std::vector<Eigen::Isometry3d>> poses,
                           std::vector<bool> connected) -> std::string {
    try {
      renderAtlasPng(sessions, poses, connected, options, "", "/nonexistent/never.png");
    } catch (const std::invalid_argument& error) {
      return error.what();
    }
    return "no exception";
  };
  std::vector<std::vector<Eigen::Isometry3d>> short_b = atlas.T_atlas_keyframe;
  short_b[1].pop_back();
  const std::string pose_count = message(atlas.pointers(), short_b, atlas.connected);
  EXPECT_NE(pose_count.find("'b'"), std::string::npos) << pose_count;
  EXPECT_NE(pose_count.find("8 atlas keyframe poses for 9 keyframes"), std::string::npos)
      << pose_count;
  // An unconnected session's poses are not used, so their count does not matter.
  std::vector<std::vector<Eigen::Isometry3d>> no_c = atlas.T_atlas_keyframe;
  no_c[2].clear();
  EXPECT_NO_THROW(layoutAtlasRender(atlas.pointers(), no_c, atlas.connected, options));

  const std::string lengths = message(atlas.pointers(), atlas.T_atlas_keyframe, {true, true});
  EXPECT_NE(lengths.find("3 sessions"), std::string::npos) << lengths;
  EXPECT_NE(lengths.find("2 connected flags"), std::string::npos) << lengths;
  EXPECT_NE(message({atlas.pointers()[0], nullptr, atlas.pointers()[2]}, atlas.T_atlas_keyframe,
                    atlas.connected)
                .find("null"),
            std::string::npos);
  EXPECT_NE(message(atlas.pointers(), atlas.T_atlas_keyframe, {false, false, false})
                .find("no connected session"),
            std::string::npos);
  SyntheticAtlas bad_scans = syntheticAtlas();
  bad_scans.sessions[0].scans.pop_back();
  EXPECT_NE(message(bad_scans.pointers(), bad_scans.T_atlas_keyframe, bad_scans.connected)
                .find("8 scans for 9 keyframes"),
            std::string::npos);
}

TEST(SessionRenderOptions, RejectsBadValues) {
  std::string error;
  EXPECT_TRUE(SessionRenderOptions().IsValid(&error));
  for (double scale : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN()}) {
    SessionRenderOptions options;
    options.pixels_per_metre = scale;
    EXPECT_FALSE(options.IsValid(&error));
    EXPECT_NE(error.find("pixels_per_metre"), std::string::npos);
  }
  SessionRenderOptions heights;
  heights.min_point_height_m = 2.0;
  heights.max_point_height_m = 1.0;
  EXPECT_FALSE(heights.IsValid(&error));
  EXPECT_NE(error.find("min_point_height_m"), std::string::npos);
  SessionRenderOptions tiny;
  tiny.max_image_side_px = 10;
  EXPECT_FALSE(tiny.IsValid(&error));

  Session session;
  session.keyframes.push_back({0.0, Eigen::Isometry3d::Identity()});
  SessionRenderOptions bad;
  bad.pixels_per_metre = 0.0;
  EXPECT_THROW(renderSessionPng(session, bad, "/nonexistent/never.png"), std::invalid_argument);
  EXPECT_THROW(renderSessionPng(Session(), SessionRenderOptions(), "/nonexistent/never.png"),
               std::invalid_argument);
}

}  // namespace
}  // namespace mm4mm
