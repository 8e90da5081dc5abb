#pragma once
// Magnetic change between two placed sessions (issue 18, its first slice: the per-cell score and
// the regions it makes). Where both sessions' layers (magnetic_layer.hpp, in the atlas frame)
// cover a cell, the difference of their levelled field ΔB = (ΔB_h, ΔB_v) is weighed against what
// the two maps' uncertainty explains: each cell's posterior variance, plus a floor for what a
// layer's variance leaves out (the calibration's residual, the sensor's noise where a map is
// interpolated between sensor tracks). Steel brought in or taken away between two sessions moves
// the field by several µT over metres; a cell whose difference the uncertainty cannot explain is
// changed, and connected changed cells make a region.
//
// The layers are compared as given: field offsets between sessions (field_offsets.hpp) must be
// applied first, or an offset reads as a change everywhere.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/merge/magnetic_layer.hpp"

namespace mm4mm {

struct MagneticChangeConfig {
  // The four settings were chosen together by scripts/choose_change_settings.py on the tuning
  // sweep (scripts/change_sweep.sh: the changed warehouse at seeds 1-10 and the unchanged one at
  // 1-5, the array and one IMU magnetometer; docs/bench/change_settings.md): the most recall of
  // the area changed by 5 µT or more with no false region, also one chi-square step looser, and
  // precision at least 80 %. Tuning figures: recall 74 % (was 53 % with 1 µT, 13.8, 1 m² and the
  // whole calibration residual), precision 91 %.

  /// Added to both layers' variance (µT, as a standard deviation): what a cell's posterior
  /// variance does not hold.
  double noise_floor_uT = 0.5;
  /// A cell has changed where |ΔB|² / (σ²_a + σ²_b + floor²) exceeds this: a chi-square of two
  /// degrees of freedom, 18.4 at p = 1e-4.
  double min_chi2 = 18.4;
  /// Connected changed cells (8-neighbourhood) covering less than this are left out (m²): cells
  /// past the threshold by chance or by a calibration's heading error along one pass, not steel
  /// that moved.
  double min_region_area_m2 = 4.0;
  /// Each layer's calibration_uT enters the variance times this: how much of a calibration's
  /// residual at the places read twice (calibrationEvidence) stands for its error elsewhere.
  double calibration_scale = 0.5;

  /// False, with the offending field named in `error`, when a setting is out of range.
  bool IsValid(std::string* error) const;
};

/// Connected cells where the field changed between the two layers.
struct MagneticChangeRegion {
  double area_m2 = 0.0;
  Eigen::Vector2d centroid_m = Eigen::Vector2d::Zero();  ///< atlas frame
  double mean_delta_uT = 0.0;                            ///< mean |ΔB| over its cells
  double max_delta_uT = 0.0;
};

/// The comparison on layer a's grid.
struct MagneticChange {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
  double cell_size_m = 0.0;
  int width = 0;
  int height = 0;
  /// |ΔB| (µT) and the chi-square per cell, row-major (iy * width + ix); NaN where either layer
  /// does not cover the cell.
  std::vector<float> delta_uT;
  std::vector<float> chi2;
  std::size_t compared_cells = 0;  ///< cells both layers cover
  std::size_t changed_cells = 0;   ///< of those, past min_chi2 (in a region or not)
  /// Largest first.
  std::vector<MagneticChangeRegion> regions;
  /// Per cell, the index in `regions` of the region holding it; -1 for a cell in none (unchanged,
  /// not compared, or in a component smaller than min_region_area_m2).
  std::vector<int> region;
};

/// Every pair an atlas compared, on one grid (the fused map's): what changes/magnetic_change.pcd
/// holds and changes/magnetic_change.png draws. A cell two or more pairs compared shows the pair
/// that differs most there by its chi-square.
struct ChangeMap {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
  double cell_size_m = 0.0;
  int width = 0;
  int height = 0;
  double height_m = 0.0;  ///< the fused map's height (m), for the cells' z
  /// Per cell, row-major (iy * width + ix): how many pairs compared it (0: none);
  std::vector<std::uint16_t> pairs;
  /// the largest chi-square among them and that pair's |ΔB| (µT), NaN where none compared it;
  std::vector<float> chi2;
  std::vector<float> delta_uT;
  /// the number of the region holding it (1 for the first region report.json lists, in the order
  /// of the pairs and, per pair, largest first); where several regions hold it, the first of
  /// them; 0 in none.
  std::vector<std::uint32_t> region;

  std::size_t comparedCells() const {
    std::size_t compared = 0;
    for (const std::uint16_t n : pairs) compared += n > 0;
    return compared;
  }
  /// The grid with |ΔB| in every fingerprint channel where a pair compared the cell (uncovered
  /// elsewhere), for the renderer.
  MagneticMap deltaMap() const;
};

/// The places of the change regions flagged in `shown` (entry k - 1 for region k), for a picture
/// of one session's changes: each 8-connected group of cells in some region labelled with the
/// first shown number in it, 0 where it holds none. A cell holds the first region (by pair) of
/// those there, and the pairs of one session after a change with each one before it find one place
/// each, so a session's own region may lie under another pair's number: the place is drawn whole.
std::vector<std::uint32_t> placesOfRegions(const ChangeMap& cells, const std::vector<bool>& shown);

/// Compares layer b with layer a at a's cell centres (b's value is that of the cell of b holding
/// the centre). A cell's variance is both layers' cell variances, both layers' calibration_uT²
/// times calibration_scale², and the floor². Throws std::invalid_argument on an invalid config,
/// layers of different cell sizes, or a layer whose variance is not one per cell.
MagneticChange magneticChange(const MagneticLayer& a, const MagneticLayer& b,
                              const MagneticChangeConfig& config);

}  // namespace mm4mm
