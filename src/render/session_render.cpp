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
#include "mm4mm/core/pose.hpp"

namespace mm4mm {
namespace {

using render::kBottomBandPx;
using render::kColourBarBandPx;
using render::kMaxImageSidePx;
using render::kMinImageSidePx;
using render::kSidePadPx;
using render::Rgb;

// The title band (px); the rest of the furniture is every picture's (cairo_drawing.hpp).
constexpr int kTitleBandPx = 36;
// The legend band grows with the longest session id up to this width; longer ids are cut.
constexpr int kMaxLegendBandPx = 220;
constexpr int kLegendRowPx = 20;
constexpr double kLegendSwatchPx = 22.0;
// Top of the colour bar or the first legend row; their headings sit above it.
constexpr double kRightBandTopPx = kTitleBandPx + 28.0;
// A tiny map still gets room for a legible title, scale bar and colour bar. Both stay below
// kMinImageSidePx so that the size limit can always be met.
constexpr int kMinWidthPx = 320;
constexpr int kMinHeightPx = 260;
constexpr double kPointClipDistanceM = 30.0;

// A single session's trajectory: dark red stands out from grey points and viridis dots alike.
const Rgb kTrajectoryColour{0.55, 0.0, 0.0};
// Tableau 10 without its grey, which would vanish into the point density.
constexpr std::array<std::array<std::uint8_t, 3>, 9> kAtlasPalette{{{31, 119, 180},
                                                                    {255, 127, 14},
                                                                    {44, 160, 44},
                                                                    {214, 39, 40},
                                                                    {148, 103, 189},
                                                                    {140, 86, 75},
                                                                    {227, 119, 194},
                                                                    {188, 189, 34},
                                                                    {23, 190, 207}}};
const Rgb kUnconnectedTextColour{0.45, 0.45, 0.45};

struct PlacedSample {
  Eigen::Vector2d xy_m;  // sensor position, session frame
  double magnitude_uT;
};

// One session as drawn: its keyframes in the picture frame (its own frame for a single session,
// the atlas frame for an atlas) carry its scans there, and its trajectory in `colour`.
struct Track {
  const Session* session;
  std::vector<Eigen::Isometry3d> T_picture_keyframe;
  Rgb colour;
};

struct LegendEntry {
  std::string label;
  std::optional<Rgb> colour;  // none: listed, not drawn (an unconnected session)
};

// Everything but the points, which are streamed twice instead of stored: an atlas holds tens of
// millions of them. A single session is one track with samples; an atlas is tracks and a legend.
struct Scene {
  std::string title;
  std::vector<Track> tracks;
  std::vector<PlacedSample> samples;
  std::vector<LegendEntry> legend;
  Eigen::AlignedBox2d point_clip_m;
  Eigen::AlignedBox2d content_m;
};

void checkOptions(const SessionRenderOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("SessionRenderOptions: " + error);
}

std::string nameOf(const Session& session) { return "session '" + session.id + "'"; }

std::vector<PlacedSample> placeSamples(const Session& session) {
  const std::vector<Eigen::Vector3d>& sensors_body = session.rig.magnetometers_body;
  std::vector<PlacedSample> placed;
  placed.reserve(session.magnetometer.size());
  for (const MagnetometerSample& sample : session.magnetometer) {
    if (sample.sensor < 0 || sample.sensor >= static_cast<int>(sensors_body.size()))
      throw std::invalid_argument(nameOf(session) +
                                  ": magnetometer sample at t=" + std::to_string(sample.time_s) +
                                  " names unknown sensor " + std::to_string(sample.sensor));
    const std::optional<Eigen::Isometry3d> T_session_body =
        poseWithin(session.keyframes, sample.time_s);
    if (!T_session_body) continue;
    const Eigen::Vector3d p_session = *T_session_body * sensors_body[sample.sensor];
    placed.push_back({p_session.head<2>(), sample.field_body_uT.norm()});
  }
  return placed;
}

Track makeTrack(const Session& session, std::vector<Eigen::Isometry3d> T_picture_keyframe,
                const Rgb& colour) {
  if (session.keyframes.empty())
    throw std::invalid_argument(nameOf(session) + " has no keyframes to render");
  if (session.hasScans() && session.scans.size() != session.keyframes.size())
    throw std::invalid_argument(nameOf(session) + " has " + std::to_string(session.scans.size()) +
                                " scans for " + std::to_string(session.keyframes.size()) +
                                " keyframes");
  return {&session, std::move(T_picture_keyframe), colour};
}

// Calls visit(xy_picture_m) for every scan point inside the height band and the clip box.
template <typename Visit>
void forEachMapPoint(const Scene& scene, const SessionRenderOptions& options, Visit&& visit) {
  for (const Track& track : scene.tracks) {
    for (size_t k = 0; k < track.session->scans.size(); ++k) {
      const Eigen::Isometry3f T_picture_body = track.T_picture_keyframe[k].cast<float>();
      for (const Eigen::Vector3f& p_body : track.session->scans[k]) {
        const Eigen::Vector3f p = T_picture_body * p_body;
        if (p.z() < options.min_point_height_m || p.z() > options.max_point_height_m) continue;
        const Eigen::Vector2d xy = p.head<2>().cast<double>();
        if (scene.point_clip_m.contains(xy)) visit(xy);
      }
    }
  }
}

// The extent of trajectories, samples and (clipped) points, once tracks and samples are set.
void boundScene(const SessionRenderOptions& options, Scene* scene) {
  Eigen::AlignedBox2d trajectory_box;
  for (const Track& track : scene->tracks)
    for (const Eigen::Isometry3d& T : track.T_picture_keyframe)
      trajectory_box.extend(T.translation().head<2>());
  scene->content_m = trajectory_box;
  for (const PlacedSample& sample : scene->samples) scene->content_m.extend(sample.xy_m);
  scene->point_clip_m = trajectory_box;
  scene->point_clip_m.min().array() -= kPointClipDistanceM;
  scene->point_clip_m.max().array() += kPointClipDistanceM;
  forEachMapPoint(*scene, options, [&](const Eigen::Vector2d& xy) { scene->content_m.extend(xy); });
}

// A single session in its own frame: the special case of one track at its odometry poses.
Scene sessionScene(const Session& session, const SessionRenderOptions& options) {
  checkOptions(options);
  std::vector<Eigen::Isometry3d> T_session_keyframe;
  for (const StampedPose& keyframe : session.keyframes)
    T_session_keyframe.push_back(keyframe.T_frame_body);
  Scene scene;
  scene.title = "session " + (session.id.empty() ? "(no id)" : session.id);
  scene.tracks.push_back(makeTrack(session, std::move(T_session_keyframe), kTrajectoryColour));
  scene.samples = placeSamples(session);
  boundScene(options, &scene);
  return scene;
}

Rgb paletteColour(std::size_t index) {
  const std::array<std::uint8_t, 3> rgb = atlasSessionColour(index);
  return {rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0};
}

Scene atlasScene(const std::vector<const Session*>& sessions,
                 const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                 const std::vector<bool>& connected, const SessionRenderOptions& options,
                 const std::string& title) {
  checkOptions(options);
  if (T_atlas_keyframe.size() != sessions.size() || connected.size() != sessions.size())
    throw std::invalid_argument("atlas render: " + std::to_string(sessions.size()) +
                                " sessions, but " + std::to_string(T_atlas_keyframe.size()) +
                                " trajectories and " + std::to_string(connected.size()) +
                                " connected flags");
  Scene scene;
  scene.title = title.empty() ? "atlas" : title;
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    if (sessions[s] == nullptr)
      throw std::invalid_argument("atlas render: session " + std::to_string(s) + " is null");
    const Session& session = *sessions[s];
    const std::string id = session.id.empty() ? "(no id)" : session.id;
    if (!connected[s]) {
      scene.legend.push_back({id + " (not connected)", std::nullopt});
      continue;
    }
    if (T_atlas_keyframe[s].size() != session.keyframes.size())
      throw std::invalid_argument(
          nameOf(session) + ": " + std::to_string(T_atlas_keyframe[s].size()) +
          " atlas keyframe poses for " + std::to_string(session.keyframes.size()) + " keyframes");
    scene.tracks.push_back(makeTrack(session, T_atlas_keyframe[s], paletteColour(s)));
    scene.legend.push_back({id, scene.tracks.back().colour});
  }
  if (scene.tracks.empty())
    throw std::invalid_argument("atlas render: no connected session to draw");
  boundScene(options, &scene);
  return scene;
}

// Width of a legend band that fits the longest label, within [colour bar band, max band].
int legendBandWidth(const std::vector<LegendEntry>& legend) {
  const render::SurfacePtr scratch(cairo_image_surface_create(CAIRO_FORMAT_RGB24, 1, 1));
  const render::ContextPtr cr(cairo_create(scratch.get()));
  render::setFont(cr.get(), 12, false);
  double widest = 0.0;
  for (const LegendEntry& entry : legend) {
    cairo_text_extents_t extents;
    cairo_text_extents(cr.get(), entry.label.c_str(), &extents);
    widest = std::max(widest, extents.x_advance);
  }
  const int needed = static_cast<int>(std::ceil(14.0 + kLegendSwatchPx + 6.0 + widest + 8.0));
  return std::clamp(needed, kColourBarBandPx, kMaxLegendBandPx);
}

SessionRenderLayout layoutFor(const Scene& scene, const SessionRenderOptions& options) {
  SessionRenderLayout layout;
  layout.has_colour_bar = !scene.samples.empty();
  layout.has_legend = !scene.legend.empty();
  layout.map_area_m = scene.content_m;
  layout.map_area_m.min().array() -= options.margin_m;
  layout.map_area_m.max().array() += options.margin_m;
  const Eigen::Vector2d extent_m = layout.map_area_m.sizes();
  int right_band = kSidePadPx;
  if (layout.has_colour_bar) right_band = kColourBarBandPx;
  if (layout.has_legend) right_band = std::max(right_band, legendBandWidth(scene.legend));
  const int fixed_w = kSidePadPx + right_band;
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
  // A flat map still gets room for every legend row, as far as the size limit allows.
  const int legend_h =
      layout.has_legend ? static_cast<int>(kRightBandTopPx) +
                              static_cast<int>(scene.legend.size()) * kLegendRowPx + kBottomBandPx
                        : 0;
  layout.height_px =
      std::max({kMinHeightPx, fixed_h + pixels(extent_m.y()), std::min(legend_h, side)});
  layout.map_corner_px = Eigen::Vector2d(kSidePadPx, kTitleBandPx);
  return layout;
}

std::vector<uint32_t> pointDensity(const Scene& scene, const SessionRenderOptions& options,
                                   const SessionRenderLayout& layout) {
  std::vector<uint32_t> counts(static_cast<size_t>(layout.width_px) * layout.height_px, 0);
  forEachMapPoint(scene, options, [&](const Eigen::Vector2d& xy) {
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

// The keyframe path, a circle at its start and a square at its end.
void drawTrajectory(cairo_t* cr, const Track& track, const SessionRenderLayout& layout) {
  const Rgb& colour = track.colour;
  cairo_set_source_rgb(cr, colour.r, colour.g, colour.b);
  cairo_set_line_width(cr, 2.0);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  for (const Eigen::Isometry3d& T : track.T_picture_keyframe) {
    const Eigen::Vector2d px = layout.pixelOf(T.translation().head<2>());
    cairo_line_to(cr, px.x(), px.y());
  }
  cairo_stroke(cr);
  // A white outline keeps the markers visible on top of dense points.
  const Eigen::Vector2d start =
      layout.pixelOf(track.T_picture_keyframe.front().translation().head<2>());
  const Eigen::Vector2d end =
      layout.pixelOf(track.T_picture_keyframe.back().translation().head<2>());
  cairo_new_sub_path(cr);
  cairo_arc(cr, start.x(), start.y(), 5.0, 0, 2 * M_PI);
  cairo_rectangle(cr, end.x() - 5.0, end.y() - 5.0, 10.0, 10.0);
  cairo_fill_preserve(cr);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_set_line_width(cr, 1.0);
  cairo_stroke(cr);
}

// `text` shortened with an ellipsis until it fits `max_width_px` at the current font.
std::string fitText(cairo_t* cr, std::string text, double max_width_px) {
  const auto width = [cr](const std::string& s) {
    cairo_text_extents_t extents;
    cairo_text_extents(cr, s.c_str(), &extents);
    return extents.x_advance;
  };
  if (width(text) <= max_width_px) return text;
  while (!text.empty() && width(text + "\u2026") > max_width_px) text.pop_back();
  return text + "\u2026";
}

// Session ids beside a stroke of their trajectory colour, one per row, in the right-hand band;
// unconnected sessions in grey without a stroke. Rows beyond the picture's height are summarised
// in a last "+N more" row.
void drawLegend(cairo_t* cr, const std::vector<LegendEntry>& legend,
                const SessionRenderLayout& layout) {
  const double x = layout.width_px - legendBandWidth(legend) + 14.0;
  const double text_x = x + kLegendSwatchPx + 6.0;
  const double text_width = layout.width_px - text_x - 6.0;
  cairo_set_source_rgb(cr, 0, 0, 0);
  render::setFont(cr, 12, true);
  render::drawText(cr, x - 4.0, kRightBandTopPx - 12.0, "sessions");
  render::setFont(cr, 12, false);
  const auto fitting_rows = static_cast<std::size_t>(
      std::max(1.0, (layout.height_px - kRightBandTopPx - kBottomBandPx) / kLegendRowPx));
  const std::size_t shown = legend.size() <= fitting_rows ? legend.size() : fitting_rows - 1;
  const auto baseline = [](std::size_t row) { return kRightBandTopPx + row * kLegendRowPx + 10.0; };
  for (std::size_t i = 0; i < shown; ++i) {
    const LegendEntry& entry = legend[i];
    const Rgb text_colour = entry.colour ? Rgb{0, 0, 0} : kUnconnectedTextColour;
    if (entry.colour) {
      cairo_set_source_rgb(cr, entry.colour->r, entry.colour->g, entry.colour->b);
      cairo_set_line_width(cr, 4.0);
      cairo_move_to(cr, x, baseline(i) - 4.0);
      cairo_line_to(cr, x + kLegendSwatchPx, baseline(i) - 4.0);
      cairo_stroke(cr);
    }
    cairo_set_source_rgb(cr, text_colour.r, text_colour.g, text_colour.b);
    render::drawText(cr, text_x, baseline(i), fitText(cr, entry.label, text_width));
  }
  if (shown < legend.size()) {
    cairo_set_source_rgb(cr, 0, 0, 0);
    render::drawText(cr, text_x, baseline(shown),
                     "+" + std::to_string(legend.size() - shown) + " more");
  }
}

void drawTitle(cairo_t* cr, const std::string& title) {
  cairo_set_source_rgb(cr, 0, 0, 0);
  render::setFont(cr, 16, true);
  render::drawText(cr, kSidePadPx, 24.0, title);
}

// Everything either picture shows, in drawing order: points under samples under trajectories.
void drawScene(const Scene& scene, const SessionRenderOptions& options,
               const std::filesystem::path& png_path) {
  const SessionRenderLayout layout = layoutFor(scene, options);
  const render::SurfacePtr surface(
      cairo_image_surface_create(CAIRO_FORMAT_RGB24, layout.width_px, layout.height_px));
  render::throwIfFailed(cairo_surface_status(surface.get()), png_path);
  const render::ContextPtr context(cairo_create(surface.get()));
  cairo_t* cr = context.get();
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);

  drawPointDensity(surface.get(), pointDensity(scene, options, layout), layout.width_px);
  std::optional<std::pair<double, double>> range;
  if (!scene.samples.empty()) {
    range = colourRange(scene.samples);
    drawSamples(cr, scene.samples, layout, *range);
  }
  for (const Track& track : scene.tracks) drawTrajectory(cr, track, layout);
  if (range) {
    const double height =
        std::clamp(layout.height_px - kRightBandTopPx - kBottomBandPx, 60.0, 400.0);
    render::drawColourBar(cr, layout.width_px - kColourBarBandPx + 14.0, kRightBandTopPx, height,
                          range->first, range->second, "|B| (\u00b5T)");
  }
  if (layout.has_legend) drawLegend(cr, scene.legend, layout);
  render::drawScaleBar(cr, kSidePadPx, layout.height_px - 18.0, layout.pixels_per_metre,
                       layout.map_area_m.sizes().x() * layout.pixels_per_metre);
  drawTitle(cr, scene.title);
  render::throwIfFailed(cairo_status(cr), png_path);
  cairo_surface_flush(surface.get());
  render::writePngAtomically(surface.get(), png_path);
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

Eigen::Vector2d SessionRenderLayout::pixelOf(const Eigen::Vector2d& xy_m) const {
  return map_corner_px + pixels_per_metre * Eigen::Vector2d(xy_m.x() - map_area_m.min().x(),
                                                            map_area_m.max().y() - xy_m.y());
}

SessionRenderLayout layoutSessionRender(const Session& session,
                                        const SessionRenderOptions& options) {
  return layoutFor(sessionScene(session, options), options);
}

void renderSessionPng(const Session& session, const SessionRenderOptions& options,
                      const std::filesystem::path& png_path) {
  drawScene(sessionScene(session, options), options, png_path);
}

std::array<std::uint8_t, 3> atlasSessionColour(std::size_t session_index) {
  return kAtlasPalette[session_index % kAtlasPalette.size()];
}

SessionRenderLayout layoutAtlasRender(
    const std::vector<const Session*>& sessions,
    const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
    const std::vector<bool>& connected, const SessionRenderOptions& options) {
  return layoutFor(atlasScene(sessions, T_atlas_keyframe, connected, options, ""), options);
}

void renderAtlasPng(const std::vector<const Session*>& sessions,
                    const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                    const std::vector<bool>& connected, const SessionRenderOptions& options,
                    const std::string& title, const std::filesystem::path& png_path) {
  drawScene(atlasScene(sessions, T_atlas_keyframe, connected, options, title), options, png_path);
}

}  // namespace mm4mm
