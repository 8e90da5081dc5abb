#pragma once
// The relative heading of two calibrated sessions from their magnetic fields alone: each
// session's mean horizontal field direction in its own frame points to the same (magnetic) north,
// so their difference is the yaw between the frames. Steel turns the field locally; averaged over
// a session's coverage the building's anomalies mostly cancel, and how much they do not is read
// from how well the directions agree (their mean resultant length).

#include "mm4mm/magnetic/magnetic_map.hpp"

namespace mm4mm {

struct CompassHeading {
  double yaw_rad = 0.0;  ///< the yaw that turns b's mean field direction onto a's
  /// The smaller of the two maps' mean resultant lengths: |Σ h| / Σ |h| over the covered cells'
  /// horizontal session-frame field h. 1 when every cell's field points one way; near 0 for a
  /// field turned every way (steel everywhere, or an uncalibrated offset that turns with heading).
  double resultant = 0.0;
};

/// A map's mean horizontal field direction (rad, session frame) and its mean resultant length
/// (0 for a map without covered cells).
double meanFieldDirection(const MagneticMap& map, double* resultant);

/// Relative heading of maps a and b and how far it can be trusted.
CompassHeading compassHeading(const MagneticMap& a, const MagneticMap& b);

}  // namespace mm4mm
