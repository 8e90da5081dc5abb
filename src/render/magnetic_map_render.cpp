#include "mm4mm/render/magnetic_map_render.hpp"

#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

#include "cairo_drawing.hpp"

namespace mm4mm {
namespace {

using render::kBottomBandPx;
using render::kColourBarBandPx;
using render::kMaxImageSidePx;
using render::kMinImageSidePx;
using render::kSidePadPx;
using render::Rgb;

// The title band (px); the rest of the furniture is every picture's (cairo_drawing.hpp).
constexpr int kTitleBandPx = 52;
// A tiny map still gets room for a legible title, scale bar and colour bar. Both stay below
// kMinImageSidePx so that the size limit can always be met.
constexpr int kMinWidthPx = 360;
constexpr int kMinHeightPx = 280;

// Inside the map area: uncovered cells light grey, so white page and missing data differ.
constexpr std::uint32_t kUncoveredPixel = 0xFFE4E4E4u;

const std::vector<float>& valuesOf(const MagneticMap& map, MagneticComponent component) {
  switch (component) {
    case MagneticComponent::kHorizontal:
      return map.horizontal_uT;
    case MagneticComponent::kVertical:
      return map.vertical_uT;
    case MagneticComponent::kTotal:
      break;
  }
  return map.total_uT;
}

// Bounding box of the covered cells (m); empty when no cell is covered.
Eigen::AlignedBox2d coveredBox(const MagneticMap& map) {
  Eigen::AlignedBox2d box;
  for (int iy = 0; iy < map.height; ++iy)
    for (int ix = 0; ix < map.width; ++ix)
      if (map.covered(ix, iy)) {
        box.extend(map.origin_m + map.cell_size_m * Eigen::Vector2d(ix, iy));
        box.extend(map.origin_m + map.cell_size_m * Eigen::Vector2d(ix + 1, iy + 1));
      }
  return box;
}

std::pair<double, double> colourRange(const MagneticMap& map, MagneticComponent component) {
  const std::vector<float>& values = valuesOf(map, component);
  std::vector<float> shown;
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!std::isnan(map.total_uT[i]) && std::isfinite(values[i])) shown.push_back(values[i]);
  if (shown.empty())
    throw std::invalid_argument("magnetic map has no covered cell with a finite " +
                                componentName(component));
  const auto percentile = [&](double q) {
    const auto nth = shown.begin() + std::lround(q * (shown.size() - 1));
    std::nth_element(shown.begin(), nth, shown.end());
    return static_cast<double>(*nth);
  };
  const double low = percentile(0.02);
  const double high = percentile(0.98);
  if (high - low < 1e-6) return {low - 0.5, high + 0.5};
  return {low, high};
}

std::uint32_t argbOf(const Rgb& colour) {
  const auto byte = [](double c) {
    return static_cast<std::uint32_t>(std::lround(255.0 * std::clamp(c, 0.0, 1.0)));
  };
  return 0xFF000000u | (byte(colour.r) << 16) | (byte(colour.g) << 8) | byte(colour.b);
}

// Each pixel of the map area takes the cell under its centre. Writing pixels directly costs one
// lookup per pixel; a cairo rectangle per cell would cost millions of fills.
void drawCells(cairo_surface_t* surface, const MagneticMap& map,
               const MagneticMapRenderOptions& options, const MagneticMapRenderLayout& layout) {
  const std::vector<float>& values = valuesOf(map, options.component);
  const double span = layout.colour_high_uT - layout.colour_low_uT;
  const Eigen::Vector2d sizes = layout.map_area_m.sizes() * layout.pixels_per_metre;
  const int col0 = static_cast<int>(std::floor(layout.map_corner_px.x()));
  const int row0 = static_cast<int>(std::floor(layout.map_corner_px.y()));
  const int cols = static_cast<int>(std::ceil(sizes.x()));
  const int rows = static_cast<int>(std::ceil(sizes.y()));
  cairo_surface_flush(surface);
  unsigned char* data = cairo_image_surface_get_data(surface);
  const int stride = cairo_image_surface_get_stride(surface);
  for (int row = 0; row < rows && row0 + row < layout.height_px; ++row) {
    const double y = layout.map_area_m.max().y() - (row + 0.5) / layout.pixels_per_metre;
    const int iy = static_cast<int>(std::floor((y - map.origin_m.y()) / map.cell_size_m));
    for (int col = 0; col < cols && col0 + col < layout.width_px; ++col) {
      const double x = layout.map_area_m.min().x() + (col + 0.5) / layout.pixels_per_metre;
      const int ix = static_cast<int>(std::floor((x - map.origin_m.x()) / map.cell_size_m));
      std::uint32_t pixel = kUncoveredPixel;
      if (map.covered(ix, iy)) {
        const float value = values[map.index(ix, iy)];
        if (std::isfinite(value))
          pixel = argbOf(render::viridis((value - layout.colour_low_uT) / span));
      }
      std::memcpy(data + static_cast<std::size_t>(row0 + row) * stride + (col0 + col) * 4, &pixel,
                  sizeof(pixel));
    }
  }
  cairo_surface_mark_dirty(surface);
}

void drawFrame(cairo_t* cr, const MagneticMapRenderLayout& layout) {
  const Eigen::Vector2d size = layout.map_area_m.sizes() * layout.pixels_per_metre;
  cairo_set_source_rgb(cr, 0.5, 0.5, 0.5);
  cairo_set_line_width(cr, 1.0);
  cairo_rectangle(cr, layout.map_corner_px.x() - 0.5, layout.map_corner_px.y() - 0.5,
                  size.x() + 1.0, size.y() + 1.0);
  cairo_stroke(cr);
}

std::string valueLabel(const MagneticMapRenderOptions& options) {
  return options.value_label.empty() ? componentName(options.component) : options.value_label;
}

void drawTitle(cairo_t* cr, const MagneticMap& map, const MagneticMapRenderOptions& options) {
  cairo_set_source_rgb(cr, 0, 0, 0);
  render::setFont(cr, 16, true);
  render::drawText(cr, kSidePadPx, 22.0,
                   (options.title.empty() ? std::string("magnetic map") : options.title) + ": " +
                       valueLabel(options));
  char detail[128];
  std::snprintf(detail, sizeof(detail), "%g cm cells, %zu covered (%.0f m\u00b2)",
                map.cell_size_m * 100.0, map.coveredCells(), map.coveredArea_m2());
  render::setFont(cr, 12, false);
  render::drawText(cr, kSidePadPx, 42.0, detail);
}

// Red lines along every cell edge where a region meets a cell outside it (or another region),
// then each region's number: the outline follows the cells the regions hold, not a hull.
void drawRegions(cairo_t* cr, const MagneticMap& map, const MapRegionOverlay& regions,
                 const MagneticMapRenderLayout& layout) {
  const auto label = [&](int ix, int iy) -> std::uint32_t {
    if (ix < 0 || iy < 0 || ix >= map.width || iy >= map.height) return 0;
    return regions.of_cell[map.index(ix, iy)];
  };
  const auto corner = [&](int ix, int iy) {
    return layout.pixelOf(map.origin_m + map.cell_size_m * Eigen::Vector2d(ix, iy));
  };
  const auto edge = [&](const Eigen::Vector2d& from, const Eigen::Vector2d& to) {
    cairo_move_to(cr, from.x(), from.y());
    cairo_line_to(cr, to.x(), to.y());
  };
  cairo_set_source_rgb(cr, 0.9, 0.05, 0.05);
  cairo_set_line_width(cr, 2.0);
  for (int iy = 0; iy <= map.height; ++iy)
    for (int ix = 0; ix <= map.width; ++ix) {
      const std::uint32_t here = label(ix, iy);
      if (here != label(ix - 1, iy)) edge(corner(ix, iy), corner(ix, iy + 1));
      if (here != label(ix, iy - 1)) edge(corner(ix, iy), corner(ix + 1, iy));
    }
  cairo_stroke(cr);
  // Two pairs often find one region (the session after a change against each one before it):
  // numbers whose places lie closer than a label is wide share one label, "1, 2".
  constexpr double kSamePlacePx = 40.0;
  std::vector<std::pair<Eigen::Vector2d, std::string>> labels;
  for (std::size_t k = 0; k < regions.label_at_m.size(); ++k) {
    if (!regions.label_at_m[k].allFinite()) continue;
    const Eigen::Vector2d at = layout.pixelOf(regions.label_at_m[k]);
    const auto near = std::find_if(labels.begin(), labels.end(), [&](const auto& label) {
      return (label.first - at).norm() < kSamePlacePx;
    });
    if (near != labels.end())
      near->second += ", " + std::to_string(k + 1);
    else
      labels.emplace_back(at, std::to_string(k + 1));
  }
  render::setFont(cr, 14, true);
  for (const auto& [at, text] : labels) {
    // White under red, so that the numbers read on any colour of the map.
    cairo_move_to(cr, at.x() + 4.0, at.y() - 4.0);
    cairo_text_path(cr, text.c_str());
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_set_line_width(cr, 3.0);
    cairo_stroke_preserve(cr);
    cairo_set_source_rgb(cr, 0.9, 0.05, 0.05);
    cairo_fill(cr);
  }
}

// Draws the whole picture on a new surface.
render::SurfacePtr drawPicture(const MagneticMap& map, const MagneticMapRenderOptions& options,
                               const MagneticMapRenderLayout& layout,
                               const std::filesystem::path& for_errors,
                               const MapRegionOverlay* regions = nullptr) {
  render::SurfacePtr surface(
      cairo_image_surface_create(CAIRO_FORMAT_RGB24, layout.width_px, layout.height_px));
  render::throwIfFailed(cairo_surface_status(surface.get()), for_errors);
  const render::ContextPtr context(cairo_create(surface.get()));
  cairo_t* cr = context.get();
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  drawCells(surface.get(), map, options, layout);
  if (regions != nullptr) drawRegions(cr, map, *regions, layout);
  drawFrame(cr, layout);
  const double top = kTitleBandPx + 28.0;
  const double bar_height = std::clamp(layout.height_px - top - kBottomBandPx - 8.0, 60.0, 400.0);
  render::drawColourBar(cr, layout.width_px - kColourBarBandPx + 14.0, top, bar_height,
                        layout.colour_low_uT, layout.colour_high_uT,
                        valueLabel(options) + " (\u00b5T)");
  render::drawScaleBar(cr, kSidePadPx, layout.height_px - 18.0, layout.pixels_per_metre,
                       layout.map_area_m.sizes().x() * layout.pixels_per_metre);
  drawTitle(cr, map, options);
  render::throwIfFailed(cairo_status(cr), for_errors);
  cairo_surface_flush(surface.get());
  return surface;
}

void checkRegions(const MagneticMap& map, const MapRegionOverlay* regions) {
  const std::size_t cells = static_cast<std::size_t>(std::max(0, map.width)) *
                            static_cast<std::size_t>(std::max(0, map.height));
  if (regions != nullptr && regions->of_cell.size() != cells)
    throw std::invalid_argument("region overlay: " + std::to_string(regions->of_cell.size()) +
                                " labels for " + std::to_string(cells) + " cells");
}

}  // namespace

std::string componentName(MagneticComponent component) {
  switch (component) {
    case MagneticComponent::kHorizontal:
      return "B_h";
    case MagneticComponent::kVertical:
      return "B_v";
    case MagneticComponent::kTotal:
      break;
  }
  return "B_F";
}

bool MagneticMapRenderOptions::IsValid(std::string* error) const {
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
  return true;
}

Eigen::Vector2d MagneticMapRenderLayout::pixelOf(const Eigen::Vector2d& xy_m) const {
  return map_corner_px + pixels_per_metre * Eigen::Vector2d(xy_m.x() - map_area_m.min().x(),
                                                            map_area_m.max().y() - xy_m.y());
}

MagneticMapRenderLayout layoutMagneticMapRender(const MagneticMap& map,
                                                const MagneticMapRenderOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument("MagneticMapRenderOptions: " + error);
  MagneticMapRenderLayout layout;
  layout.map_area_m = coveredBox(map);
  if (layout.map_area_m.isEmpty())
    throw std::invalid_argument("magnetic map has no covered cells to draw");
  if (std::isfinite(options.colour_low_uT) && std::isfinite(options.colour_high_uT) &&
      options.colour_low_uT < options.colour_high_uT)
    std::tie(layout.colour_low_uT, layout.colour_high_uT) =
        std::pair(options.colour_low_uT, options.colour_high_uT);
  else
    std::tie(layout.colour_low_uT, layout.colour_high_uT) = colourRange(map, options.component);
  layout.map_area_m.min().array() -= options.margin_m;
  layout.map_area_m.max().array() += options.margin_m;
  const Eigen::Vector2d extent_m = layout.map_area_m.sizes();
  const int fixed_w = kSidePadPx + kColourBarBandPx;
  const int fixed_h = kTitleBandPx + kBottomBandPx;
  const int side = options.max_image_side_px;
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

std::vector<std::uint8_t> renderMagneticMapRgb(const MagneticMap& map,
                                               const MagneticMapRenderOptions& options,
                                               const MapRegionOverlay* regions) {
  checkRegions(map, regions);
  const MagneticMapRenderLayout layout = layoutMagneticMapRender(map, options);
  const render::SurfacePtr surface = drawPicture(map, options, layout, "(in memory)", regions);
  const unsigned char* data = cairo_image_surface_get_data(surface.get());
  const int stride = cairo_image_surface_get_stride(surface.get());
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(layout.width_px) * layout.height_px * 3);
  for (int row = 0; row < layout.height_px; ++row)
    for (int col = 0; col < layout.width_px; ++col) {
      std::uint32_t pixel;
      std::memcpy(&pixel, data + static_cast<std::size_t>(row) * stride + col * 4, sizeof(pixel));
      std::uint8_t* out = &rgb[(static_cast<std::size_t>(row) * layout.width_px + col) * 3];
      out[0] = static_cast<std::uint8_t>(pixel >> 16);
      out[1] = static_cast<std::uint8_t>(pixel >> 8);
      out[2] = static_cast<std::uint8_t>(pixel);
    }
  return rgb;
}

void renderMagneticMapPng(const MagneticMap& map, const MagneticMapRenderOptions& options,
                          const std::filesystem::path& png_path, const MapRegionOverlay* regions) {
  checkRegions(map, regions);
  const MagneticMapRenderLayout layout = layoutMagneticMapRender(map, options);
  const render::SurfacePtr surface = drawPicture(map, options, layout, png_path, regions);
  render::writePngAtomically(surface.get(), png_path);
}

std::string encodeMagneticMapPng(const MagneticMap& map, const MagneticMapRenderOptions& options,
                                 const MapRegionOverlay* regions) {
  checkRegions(map, regions);
  const MagneticMapRenderLayout layout = layoutMagneticMapRender(map, options);
  const render::SurfacePtr surface = drawPicture(map, options, layout, "(in memory)", regions);
  std::string png;
  const cairo_write_func_t append = [](void* closure, const unsigned char* data,
                                       unsigned int length) {
    static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
    return CAIRO_STATUS_SUCCESS;
  };
  render::throwIfFailed(cairo_surface_write_to_png_stream(surface.get(), append, &png),
                        "(in memory)");
  return png;
}

std::map<std::string, std::string> atlasPictures(const MagneticMap& fused,
                                                 std::size_t placed_sessions) {
  if (fused.coveredCells() == 0) return {};
  MagneticMapRenderOptions options;
  options.title = "fused magnetic map, " + std::to_string(placed_sessions) + " sessions";
  return {{"magnetic_map.png", encodeMagneticMapPng(fused, options)}};
}

std::string encodeChangePicture(const MagneticMap& delta, const MapRegionOverlay& regions,
                                std::size_t pairs_compared) {
  MagneticMapRenderOptions options;
  options.title = "change between sessions, " + std::to_string(pairs_compared) +
                  (pairs_compared == 1 ? " pair" : " pairs") + " compared (regions in red)";
  options.value_label = "|\u0394B|";
  options.colour_low_uT = 0.0;
  options.colour_high_uT = 10.0;
  return encodeMagneticMapPng(delta, options, &regions);
}

}  // namespace mm4mm
