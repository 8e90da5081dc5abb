#pragma once
// Internal to the renderers: cairo helpers every picture shares (colour map, colour bar, scale
// bar, text, atomic PNG output). Cairo stays out of the public headers.

#include <cairo.h>

#include <filesystem>
#include <memory>
#include <string>

namespace mm4mm::render {

// Picture furniture every picture shares around its map area (px); each picture adds its own
// title band and minimum size.
constexpr int kBottomBandPx = 40;
constexpr int kSidePadPx = 12;
constexpr int kColourBarBandPx = 110;
// Pictures are at least this big on their longer side, so that the size limit can always be met.
constexpr int kMinImageSidePx = 400;
constexpr int kMaxImageSidePx = 32767;  // cairo's image surface limit

struct Rgb {
  double r, g, b;
};

/// Matplotlib's viridis at t in [0, 1] (clamped): perceptually uniform and readable in grey.
Rgb viridis(double t);

struct SurfaceDeleter {
  void operator()(cairo_surface_t* surface) const { cairo_surface_destroy(surface); }
};
struct ContextDeleter {
  void operator()(cairo_t* cr) const { cairo_destroy(cr); }
};
using SurfacePtr = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using ContextPtr = std::unique_ptr<cairo_t, ContextDeleter>;

void setFont(cairo_t* cr, double size_px, bool bold);
void drawText(cairo_t* cr, double x, double y, const std::string& text);

/// A vertical viridis bar with its top-left corner at (x, top), ticks labelled from `low` to
/// `high` and `title` above it.
void drawColourBar(cairo_t* cr, double x, double top, double height, double low, double high,
                   const std::string& title);

/// A scale bar of a round length, starting at (x, y), for a map drawn at `pixels_per_metre`
/// whose drawn width is `map_width_px`.
void drawScaleBar(cairo_t* cr, double x, double y, double pixels_per_metre, double map_width_px);

/// Throws std::runtime_error naming `png_path` when `status` is not success.
void throwIfFailed(cairo_status_t status, const std::filesystem::path& png_path);

/// Writes beside the target and renames, so a failed render never leaves a half-written file.
void writePngAtomically(cairo_surface_t* surface, const std::filesystem::path& png_path);

}  // namespace mm4mm::render
