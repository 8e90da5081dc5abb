#include "cairo_drawing.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <system_error>

namespace mm4mm::render {
namespace {

// Matplotlib's viridis at 9 evenly spaced stops; perceptually uniform and readable in grey.
constexpr std::array<Rgb, 9> kViridis{{{68, 1, 84},
                                       {71, 44, 122},
                                       {59, 81, 139},
                                       {44, 113, 142},
                                       {33, 144, 141},
                                       {39, 173, 129},
                                       {92, 200, 99},
                                       {170, 220, 50},
                                       {253, 231, 37}}};

}  // namespace

Rgb viridis(double t) {
  const double s = std::clamp(t, 0.0, 1.0) * (kViridis.size() - 1);
  const size_t i = std::min(static_cast<size_t>(s), kViridis.size() - 2);
  const double f = s - i;
  const Rgb& a = kViridis[i];
  const Rgb& b = kViridis[i + 1];
  return {(a.r + f * (b.r - a.r)) / 255.0, (a.g + f * (b.g - a.g)) / 255.0,
          (a.b + f * (b.b - a.b)) / 255.0};
}

namespace {

// 1, 2 or 5 times a power of ten, nearest to `raw`.
double niceStep(double raw) {
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / power;
  return power * (f < 1.5 ? 1.0 : f < 3.5 ? 2.0 : f < 7.5 ? 5.0 : 10.0);
}

// 1, 2 or 5 times a power of ten, at most `limit`.
double niceFloor(double limit) {
  const double power = std::pow(10.0, std::floor(std::log10(limit)));
  const double f = limit / power;
  return power * (f >= 5.0 ? 5.0 : f >= 2.0 ? 2.0 : 1.0);
}

}  // namespace

void setFont(cairo_t* cr, double size_px, bool bold) {
  cairo_select_font_face(cr, "Sans", CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size_px);
}

void drawText(cairo_t* cr, double x, double y, const std::string& text) {
  cairo_move_to(cr, x, y);
  cairo_show_text(cr, text.c_str());
}

void drawColourBar(cairo_t* cr, double x, double top, double bar_h, double low, double high,
                   const std::string& title) {
  const double bar_w = 18.0;
  // Cairo interpolates linearly between stops, exactly as viridis() does.
  cairo_pattern_t* gradient = cairo_pattern_create_linear(0, top + bar_h, 0, top);
  for (size_t i = 0; i < kViridis.size(); ++i) {
    const Rgb c = viridis(static_cast<double>(i) / (kViridis.size() - 1));
    cairo_pattern_add_color_stop_rgb(gradient, static_cast<double>(i) / (kViridis.size() - 1), c.r,
                                     c.g, c.b);
  }
  cairo_rectangle(cr, x, top, bar_w, bar_h);
  cairo_set_source(cr, gradient);
  cairo_fill_preserve(cr);
  cairo_pattern_destroy(gradient);
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_set_line_width(cr, 1.0);
  cairo_stroke(cr);

  setFont(cr, 12, false);
  const double step = niceStep((high - low) / 5.0);
  const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step))));
  for (double value = std::ceil(low / step) * step; value <= high + 1e-9 * step; value += step) {
    const double y = top + bar_h * (1.0 - (value - low) / (high - low));
    cairo_move_to(cr, x + bar_w, y);
    cairo_line_to(cr, x + bar_w + 4.0, y);
    cairo_stroke(cr);
    char label[32];
    std::snprintf(label, sizeof(label), "%.*f", decimals, value);
    drawText(cr, x + bar_w + 7.0, y + 4.0, label);
  }
  setFont(cr, 12, true);
  drawText(cr, x - 4.0, top - 12.0, title);
}

void drawScaleBar(cairo_t* cr, double x, double y, double pixels_per_metre, double map_width_px) {
  const double length_m = niceFloor(std::clamp(0.3 * map_width_px, 60.0, 200.0) / pixels_per_metre);
  const double length_px = length_m * pixels_per_metre;
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_set_line_width(cr, 2.0);
  cairo_move_to(cr, x, y - 5.0);
  cairo_line_to(cr, x, y);
  cairo_line_to(cr, x + length_px, y);
  cairo_line_to(cr, x + length_px, y - 5.0);
  cairo_stroke(cr);
  char label[32];
  std::snprintf(label, sizeof(label), "%g m", length_m);
  setFont(cr, 12, false);
  drawText(cr, x + length_px + 8.0, y + 4.0, label);
}

void throwIfFailed(cairo_status_t status, const std::filesystem::path& png_path) {
  if (status != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error("cannot draw PNG " + png_path.string() + ": " +
                             cairo_status_to_string(status));
}

// Writes beside the target and renames, so a failed render never leaves a half-written file.
void writePngAtomically(cairo_surface_t* surface, const std::filesystem::path& png_path) {
  std::filesystem::path temporary = png_path;
  temporary += ".tmp";
  std::error_code ignored;
  const cairo_status_t status = cairo_surface_write_to_png(surface, temporary.c_str());
  if (status != CAIRO_STATUS_SUCCESS) {
    std::filesystem::remove(temporary, ignored);
    throw std::runtime_error("cannot write PNG " + png_path.string() + ": " +
                             cairo_status_to_string(status));
  }
  std::error_code error;
  std::filesystem::rename(temporary, png_path, error);
  if (error) {
    std::filesystem::remove(temporary, ignored);
    throw std::runtime_error("cannot write PNG " + png_path.string() + ": " + error.message());
  }
}

}  // namespace mm4mm::render
