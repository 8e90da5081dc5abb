#include "mm4mm/render/session_render.hpp"

#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <stdexcept>
#include <system_error>
#include <utility>
#include <vector>

#include "cairo_drawing.hpp"
#include "mm4mm/geometry/pose.hpp"

namespace mm4mm {
namespace {

using render::Rgb;

// Picture furniture around the map area (px).
constexpr int kTitleBandPx = 36;
constexpr int kBottomBandPx = 40;
constexpr int kSidePadPx = 12;
constexpr int kColourBarBandPx = 110;
// A tiny map still gets room for a legible title, scale bar and colour bar. Both stay below
// kMinImageSidePx so that the size limit can always be met.
constexpr int kMinWidthPx = 320;
constexpr int kMinHeightPx = 260;
constexpr int kMinImageSidePx = 400;
constexpr int kMaxImageSidePx = 32767;  // cairo's image surface limit
constexpr double kPointClipDistanceM = 30.0;

const Rgb kTrajectoryColour{0.55, 0.0, 0.0};

struct PlacedSample {
  Eigen::Vector2d xy_m;  // sensor position, session frame
  double magnitude_uT;
};

// Everything but the points, which are streamed twice instead of stored: a long session holds
// tens of millions of them.
struct Scene {
  std::vector<Eigen::Vector2d> trajectory_xy_m;
  std::vector<PlacedSample> samples;
  Eigen::AlignedBox2d point_clip_m;
  Eigen::AlignedBox2d content_m;
};

// Keyframe pose at time t (linear in translation, slerp in rotation); none outside the keyframes'
// time span, where it would be an extrapolation.
std::optional<Eigen::Isometry3d> poseAt(const std::vector<StampedPose>& keyframes, double t) {
  if (t < keyframes.front().time_s || t > keyframes.back().time_s) return std::nullopt;
  const auto after = std::upper_bound(
      keyframes.begin(), keyframes.end(), t,
      [](double time, const StampedPose& keyframe) { return time < keyframe.time_s; });
  if (after == keyframes.end()) return keyframes.back().T_frame_body;
  const StampedPose& before = *(after - 1);
  const double alpha = (t - before.time_s) / (after->time_s - before.time_s);
  return interpolatePose(before.T_frame_body, after->T_frame_body, alpha);
}

std::vector<PlacedSample> placeSamples(const Session& session) {
  const std::vector<Eigen::Vector3d>& sensors_body = session.rig.magnetometers_body;
  std::vector<PlacedSample> placed;
  placed.reserve(session.magnetometer.size());
  for (const MagnetometerSample& sample : session.magnetometer) {
    if (sample.sensor < 0 || sample.sensor >= static_cast<int>(sensors_body.size()))
      throw std::invalid_argument("session '" + session.id +
                                  "': magnetometer sample at t=" + std::to_string(sample.time_s) +
                                  " names unknown sensor " + std::to_string(sample.sensor));
    const std::optional<Eigen::Isometry3d> T_session_body =
        poseAt(session.keyframes, sample.time_s);
    if (!T_session_body) continue;
    const Eigen::Vector3d p_session = *T_session_body * sensors_body[sample.sensor];
    placed.push_back({p_session.head<2>(), sample.field_body_uT.norm()});
  }
  return placed;
}

// Calls visit(xy_session_m) for every scan point inside the height band and the clip box.
template <typename Visit>
void forEachMapPoint(const Session& session, const SessionRenderOptions& options,
                     const Eigen::AlignedBox2d& clip_m, Visit&& visit) {
  for (size_t k = 0; k < session.scans.size(); ++k) {
    const Eigen::Isometry3f T_session_body = session.keyframes[k].T_frame_body.cast<float>();
    for (const Eigen::Vector3f& p_body : session.scans[k]) {
      const Eigen::Vector3f p = T_session_body * p_body;
      if (p.z() < options.min_point_height_m || p.z() > options.max_point_height_m) continue;
      const Eigen::Vector2d xy = p.head<2>().cast<double>();
      if (clip_m.contains(xy)) visit(xy);
    }
  }
}

Scene collectScene(const Session& session, const SessionRenderOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("SessionRenderOptions: " + error);
  if (session.keyframes.empty())
    throw std::invalid_argument("session '" + session.id + "' has no keyframes to render");
  if (session.hasScans() && session.scans.size() != session.keyframes.size())
    throw std::invalid_argument("session '" + session.id + "' has " +
                                std::to_string(session.scans.size()) + " scans for " +
                                std::to_string(session.keyframes.size()) + " keyframes");
  Scene scene;
  Eigen::AlignedBox2d trajectory_box;
  for (const StampedPose& keyframe : session.keyframes) {
    scene.trajectory_xy_m.push_back(keyframe.T_frame_body.translation().head<2>());
    trajectory_box.extend(scene.trajectory_xy_m.back());
  }
  scene.samples = placeSamples(session);
  scene.content_m = trajectory_box;
  for (const PlacedSample& sample : scene.samples) scene.content_m.extend(sample.xy_m);
  scene.point_clip_m = trajectory_box;
  scene.point_clip_m.min().array() -= kPointClipDistanceM;
  scene.point_clip_m.max().array() += kPointClipDistanceM;
  forEachMapPoint(session, options, scene.point_clip_m,
                  [&](const Eigen::Vector2d& xy) { scene.content_m.extend(xy); });
  return scene;
}

SessionRenderLayout layoutFor(const Scene& scene, const SessionRenderOptions& options) {
  SessionRenderLayout layout;
  layout.has_colour_bar = !scene.samples.empty();
  layout.map_area_m = scene.content_m;
  layout.map_area_m.min().array() -= options.margin_m;
  layout.map_area_m.max().array() += options.margin_m;
  const Eigen::Vector2d extent_m = layout.map_area_m.sizes();
  const int fixed_w = kSidePadPx + (layout.has_colour_bar ? kColourBarBandPx : kSidePadPx);
  const int fixed_h = kTitleBandPx + kBottomBandPx;
  const int side = options.max_image_side_px;
  // A zero extent divides to +inf and so never limits the scale.
  layout.pixels_per_metre = std::min(
      {options.pixels_per_metre, (side - fixed_w) / extent_m.x(), (side - fixed_h) / extent_m.y()});
  // The tolerance keeps rounding from pushing a picture at the size limit one pixel over it.
  const auto pixels = [&](double metres) {
    return std::max(1, static_cast<int>(std::ceil(metres * layout.pixels_per_metre - 1e-6)));
  };
  layout.width_px = std::max(kMinWidthPx, fixed_w + pixels(extent_m.x()));
  layout.height_px = std::max(kMinHeightPx, fixed_h + pixels(extent_m.y()));
  layout.map_corner_px = Eigen::Vector2d(kSidePadPx, kTitleBandPx);
  return layout;
}

std::vector<uint32_t> pointDensity(const Session& session, const SessionRenderOptions& options,
                                   const Scene& scene, const SessionRenderLayout& layout) {
  std::vector<uint32_t> counts(static_cast<size_t>(layout.width_px) * layout.height_px, 0);
  forEachMapPoint(session, options, scene.point_clip_m, [&](const Eigen::Vector2d& xy) {
    const Eigen::Vector2d px = layout.pixelOf(xy);
    const int col = static_cast<int>(std::floor(px.x()));
    const int row = static_cast<int>(std::floor(px.y()));
    if (col >= 0 && col < layout.width_px && row >= 0 && row < layout.height_px)
      ++counts[static_cast<size_t>(row) * layout.width_px + col];
  });
  return counts;
}

// Grey levels on a log scale: LiDAR density falls with range, so on a linear scale the walls
// next to the path would swamp everything else. The 99th percentile of hit pixels saturates to
// near black, so a few pixels under a standing robot's scans do not decide the whole scale.
void drawPointDensity(cairo_surface_t* surface, const std::vector<uint32_t>& counts, int width) {
  std::vector<uint32_t> hits;
  std::copy_if(counts.begin(), counts.end(), std::back_inserter(hits),
               [](uint32_t c) { return c > 0; });
  if (hits.empty()) return;
  const auto p99 = hits.begin() + static_cast<std::ptrdiff_t>(0.99 * (hits.size() - 1));
  std::nth_element(hits.begin(), p99, hits.end());
  const double log_saturation = std::log1p(static_cast<double>(*p99));
  cairo_surface_flush(surface);
  unsigned char* data = cairo_image_surface_get_data(surface);
  const int stride = cairo_image_surface_get_stride(surface);
  for (size_t i = 0; i < counts.size(); ++i) {
    if (counts[i] == 0) continue;
    const double t = std::min(1.0, std::log1p(static_cast<double>(counts[i])) / log_saturation);
    const auto grey = static_cast<uint32_t>(std::lround(255.0 * (0.75 - 0.7 * t)));
    const uint32_t pixel = 0xFF000000u | (grey << 16) | (grey << 8) | grey;
    std::memcpy(data + (i / width) * stride + (i % width) * 4, &pixel, sizeof(pixel));
  }
  cairo_surface_mark_dirty(surface);
}

// |B| range of the colour map: the 2nd to 98th percentile, so that the few readings next to
// steel do not squeeze the rest of the session into one colour.
std::pair<double, double> colourRange(const std::vector<PlacedSample>& samples) {
  std::vector<double> magnitudes;
  for (const PlacedSample& sample : samples) magnitudes.push_back(sample.magnitude_uT);
  const auto percentile = [&](double q) {
    const auto nth = magnitudes.begin() + std::lround(q * (magnitudes.size() - 1));
    std::nth_element(magnitudes.begin(), nth, magnitudes.end());
    return *nth;
  };
  const double low = percentile(0.02);
  const double high = percentile(0.98);
  if (high - low < 1e-6) return {low - 0.5, high + 0.5};
  return {low, high};
}

// One dot per picture pixel, coloured by the mean |B| of its samples: sensors at tens of Hz
// would otherwise cost millions of overlapping cairo arcs.
void drawSamples(cairo_t* cr, const std::vector<PlacedSample>& samples,
                 const SessionRenderLayout& layout, std::pair<double, double> range) {
  std::vector<std::pair<int64_t, double>> by_pixel;
  for (const PlacedSample& sample : samples) {
    const Eigen::Vector2d px = layout.pixelOf(sample.xy_m);
    const int64_t key = static_cast<int64_t>(std::floor(px.y())) * layout.width_px +
                        static_cast<int64_t>(std::floor(px.x()));
    by_pixel.emplace_back(key, sample.magnitude_uT);
  }
  std::sort(by_pixel.begin(), by_pixel.end());
  const double radius = std::clamp(0.2 * layout.pixels_per_metre, 1.5, 5.0);
  for (size_t begin = 0, end = 0; begin < by_pixel.size(); begin = end) {
    double sum = 0.0;
    for (end = begin; end < by_pixel.size() && by_pixel[end].first == by_pixel[begin].first; ++end)
      sum += by_pixel[end].second;
    const double mean = sum / static_cast<double>(end - begin);
    const Rgb colour = render::viridis((mean - range.first) / (range.second - range.first));
    const int64_t key = by_pixel[begin].first;
    cairo_set_source_rgb(cr, colour.r, colour.g, colour.b);
    cairo_arc(cr, key % layout.width_px + 0.5, key / layout.width_px + 0.5, radius, 0, 2 * M_PI);
    cairo_fill(cr);
  }
}

void drawTrajectory(cairo_t* cr, const std::vector<Eigen::Vector2d>& xy_m,
                    const SessionRenderLayout& layout) {
  cairo_set_source_rgb(cr, kTrajectoryColour.r, kTrajectoryColour.g, kTrajectoryColour.b);
  cairo_set_line_width(cr, 2.0);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  for (const Eigen::Vector2d& xy : xy_m) {
    const Eigen::Vector2d px = layout.pixelOf(xy);
    cairo_line_to(cr, px.x(), px.y());
  }
  cairo_stroke(cr);
  // A white outline keeps the markers visible on top of dense points.
  const Eigen::Vector2d start = layout.pixelOf(xy_m.front());
  const Eigen::Vector2d end = layout.pixelOf(xy_m.back());
  cairo_new_sub_path(cr);
  cairo_arc(cr, start.x(), start.y(), 5.0, 0, 2 * M_PI);
  cairo_rectangle(cr, end.x() - 5.0, end.y() - 5.0, 10.0, 10.0);
  cairo_fill_preserve(cr);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_set_line_width(cr, 1.0);
  cairo_stroke(cr);
}

void drawTitle(cairo_t* cr, const Session& session) {
  cairo_set_source_rgb(cr, 0, 0, 0);
  render::setFont(cr, 16, true);
  render::drawText(cr, kSidePadPx, 24.0,
                   "session " + (session.id.empty() ? "(no id)" : session.id));
}

}  // namespace

bool SessionRenderOptions::IsValid(std::string* error) const {
  const auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!std::isfinite(pixels_per_metre) || pixels_per_metre <= 0.0)
    return fail("pixels_per_metre must be positive and finite");
  if (max_image_side_px < kMinImageSidePx || max_image_side_px > kMaxImageSidePx)
    return fail("max_image_side_px must be between " + std::to_string(kMinImageSidePx) + " and " +
                std::to_string(kMaxImageSidePx));
  if (!std::isfinite(margin_m) || margin_m < 0.0)
    return fail("margin_m must be non-negative and finite");
  if (!std::isfinite(min_point_height_m) || !std::isfinite(max_point_height_m) ||
      min_point_height_m >= max_point_height_m)
    return fail("min_point_height_m must be below max_point_height_m (both finite)");
  return true;
}

Eigen::Vector2d SessionRenderLayout::pixelOf(const Eigen::Vector2d& xy_session_m) const {
  return map_corner_px +
         pixels_per_metre * Eigen::Vector2d(xy_session_m.x() - map_area_m.min().x(),
                                            map_area_m.max().y() - xy_session_m.y());
}

SessionRenderLayout layoutSessionRender(const Session& session,
                                        const SessionRenderOptions& options) {
  return layoutFor(collectScene(session, options), options);
}

void renderSessionPng(const Session& session, const SessionRenderOptions& options,
                      const std::filesystem::path& png_path) {
  const Scene scene = collectScene(session, options);
  const SessionRenderLayout layout = layoutFor(scene, options);
  const render::SurfacePtr surface(
      cairo_image_surface_create(CAIRO_FORMAT_RGB24, layout.width_px, layout.height_px));
  render::throwIfFailed(cairo_surface_status(surface.get()), png_path);
  const render::ContextPtr context(cairo_create(surface.get()));
  cairo_t* cr = context.get();
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);

  drawPointDensity(surface.get(), pointDensity(session, options, scene, layout), layout.width_px);
  std::optional<std::pair<double, double>> range;
  if (!scene.samples.empty()) {
    range = colourRange(scene.samples);
    drawSamples(cr, scene.samples, layout, *range);
  }
  drawTrajectory(cr, scene.trajectory_xy_m, layout);
  if (range) {
    const double top = kTitleBandPx + 28.0;
    const double height = std::clamp(layout.height_px - top - kBottomBandPx, 60.0, 400.0);
    render::drawColourBar(cr, layout.width_px - kColourBarBandPx + 14.0, top, height, range->first,
                          range->second, "|B| (\u00b5T)");
  }
  render::drawScaleBar(cr, kSidePadPx, layout.height_px - 18.0, layout.pixels_per_metre,
                       layout.map_area_m.sizes().x() * layout.pixels_per_metre);
  drawTitle(cr, session);
  render::throwIfFailed(cairo_status(cr), png_path);
  cairo_surface_flush(surface.get());
  render::writePngAtomically(surface.get(), png_path);
}

}  // namespace mm4mm
