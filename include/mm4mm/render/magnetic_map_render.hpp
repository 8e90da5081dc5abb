#pragma once
// Top-down picture of a magnetic map: one fingerprint component per cell in viridis, uncovered
// cells light grey, with a colour bar in µT, a scale bar and a title.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"

namespace mm4mm {

/// Which fingerprint component a picture shows.
enum class MagneticComponent {
  kTotal,       ///< B_F, the field's magnitude
  kHorizontal,  ///< B_h, the magnitude of its horizontal part
  kVertical,    ///< B_v, its component along z up (negative in the northern hemisphere)
};

/// "B_F", "B_h" or "B_v".
std::string componentName(MagneticComponent component);

struct MagneticMapRenderOptions {
  MagneticComponent component = MagneticComponent::kTotal;
  /// Picture scale (px/m); 20 draws a 5 cm cell as one pixel. Lowered when the picture would
  /// exceed `max_image_side_px`; cells smaller than a pixel are then sampled at pixel centres.
  double pixels_per_metre = 20.0;
  /// Upper bound on the picture's width and height (px), title and colour bar included.
  int max_image_side_px = 4000;
  /// Border around the covered cells' bounding box (m).
  double margin_m = 1.0;
  /// First line of the title; empty gives "magnetic map".
  std::string title;
  /// What the cells hold, in the title and on the colour bar; empty gives the component's name.
  /// (A map of differences between sessions holds them in the component's place.)
  std::string value_label;
  /// The colour bar's ends (µT) when both are finite and low < high; otherwise the percentiles
  /// below. Two pictures to be compared need the same ends.
  double colour_low_uT = std::numeric_limits<double>::quiet_NaN();
  double colour_high_uT = std::numeric_limits<double>::quiet_NaN();

  /// False, with the offending field named in `error`, when an option is out of range.
  bool IsValid(std::string* error) const;
};

/// Regions drawn over a picture (an atlas's change regions): each outlined in red where its cells
/// meet others, and numbered at its label position.
struct MapRegionOverlay {
  /// Per cell of the map drawn, row-major: the number of the region holding it, 0 for none.
  std::vector<std::uint32_t> of_cell;
  /// Where region k's number is written (map frame, m): entry k - 1; regions beyond it, or at a
  /// position that is not finite, go unnumbered.
  std::vector<Eigen::Vector2d> label_at_m;
};

/// Where the map lands in the picture and how values map to colours.
struct MagneticMapRenderLayout {
  int width_px = 0;
  int height_px = 0;
  /// The scale actually used (px/m), after any scaling down to the size limit.
  double pixels_per_metre = 0.0;
  /// Map-frame area drawn (covered cells' bounding box plus margin), m.
  Eigen::AlignedBox2d map_area_m;
  /// Picture position (px) of the area's top-left corner (min x, max y).
  Eigen::Vector2d map_corner_px = Eigen::Vector2d::Zero();
  /// Values at the two ends of the colour bar (µT): the options' ends where given, else the 2nd
  /// and 98th percentiles of the shown component over the covered cells, so a few cells next to
  /// steel do not flatten the rest.
  double colour_low_uT = 0.0;
  double colour_high_uT = 0.0;

  /// Picture position (px; x right, y down; pixel (i, j) covers [i, i+1) x [j, j+1)) of a
  /// map-frame point (m; x right, y up in the picture).
  Eigen::Vector2d pixelOf(const Eigen::Vector2d& xy_m) const;
};

/// The layout the renderers below use. Throws std::invalid_argument for invalid options or a
/// map without covered cells.
MagneticMapRenderLayout layoutMagneticMapRender(const MagneticMap& map,
                                                const MagneticMapRenderOptions& options);

/// The picture in memory: 8-bit RGB, row-major from the top-left pixel, width_px * height_px * 3
/// bytes for the layout's size. Same errors as layoutMagneticMapRender.
/// `regions`, where given, drawn over the cells (its of_cell must hold one entry per cell;
/// std::invalid_argument otherwise).
std::vector<std::uint8_t> renderMagneticMapRgb(const MagneticMap& map,
                                               const MagneticMapRenderOptions& options,
                                               const MapRegionOverlay* regions = nullptr);

/// Draws the picture and writes it to `png_path` (under a temporary name, then renamed). Same
/// errors as layoutMagneticMapRender, plus std::runtime_error (naming the path) when the
/// picture cannot be written.
void renderMagneticMapPng(const MagneticMap& map, const MagneticMapRenderOptions& options,
                          const std::filesystem::path& png_path,
                          const MapRegionOverlay* regions = nullptr);

/// The same picture as the bytes of a PNG file. Same errors as layoutMagneticMapRender, plus
/// std::runtime_error when cairo cannot encode it.
std::string encodeMagneticMapPng(const MagneticMap& map, const MagneticMapRenderOptions& options,
                                 const MapRegionOverlay* regions = nullptr);

/// The pictures an atlas carries beside its data, by file name, for writeAtlas (io writes them
/// and draws nothing): "magnetic_map.png", the fused map of `placed_sessions` sessions, when
/// `fused` has a covered cell; none otherwise.
std::map<std::string, std::string> atlasPictures(const MagneticMap& fused,
                                                 std::size_t placed_sessions);

/// The picture of an atlas's change map ("changes/magnetic_change.png"): `delta`, |ΔB| between
/// sessions where a pair compared a cell (ChangeMap::deltaMap), on a fixed 0-10 µT scale so that
/// pictures of two atlases compare and a change of several µT stands out, with the change regions
/// outlined and numbered as report.json lists them. Same errors as renderMagneticMapRgb.
std::string encodeChangePicture(const MagneticMap& delta, const MapRegionOverlay& regions,
                                std::size_t pairs_compared);

}  // namespace mm4mm
