#pragma once
// One session's magnetic map placed in the atlas frame, with the variance of each cell: what the
// fused map (fused_magnetic_map.hpp) is made of and what field offsets (field_offsets.hpp) are
// estimated from.

#include <optional>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"

namespace mm4mm {

/// One session's magnetic map in the atlas frame and the variance of each cell (µT^2, NaN where
/// the map is uncovered). Parallel to the map's cells (row-major, iy * width + ix).
struct MagneticLayer {
  MagneticMap map;
  std::vector<float> variance_uT2;
  /// The Earth's vertical field the session states (SensorRig::earth_field_vertical_uT, z up):
  /// what anchors B_v across sessions (field_offsets.hpp).
  std::optional<double> earth_vertical_uT;
  /// The session's calibration estimated the vertical hard iron from its own readings (a body that
  /// tilts: SensorCalibration::vertical_estimated for every magnetometer), so its B_v is absolute:
  /// what anchors B_v where no session states the Earth's field (field_offsets.hpp).
  bool vertical_observed = false;
  /// The session's magnetometers' mean height above the floor (m: its frame's height above the
  /// floor plus their mean height in its own frame; MergeResult::magnetometer_heights_m), where
  /// known: unlike the map's height in the atlas frame, not moved by an odometry's tilt carried
  /// along a chain of sessions.
  std::optional<double> height_above_floor_m;
  /// What the session's calibration leaves in its readings, from its own evidence
  /// (calibrationEvidence): a heading-dependent error of about this much per axis (µT), which the
  /// cells' variance does not hold; and whether the calibration had anything to check itself
  /// against (false where a magnetometer was calibrated, or left uncalibrated, without a place
  /// read twice at headings apart: its error is then unknown, and several µT in the worlds
  /// measured). Used by the change score (magnetic_change.hpp).
  double calibration_uT = 0.0;
  bool calibration_checked = true;
};

}  // namespace mm4mm
