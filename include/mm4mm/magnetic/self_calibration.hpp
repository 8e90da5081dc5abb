#pragma once
// Calibrating a session's magnetometers from the session itself (MagnetometerCalibration's model:
// m = S · B + h + v · k per sensor). Three facts of the data fix the calibration: the same place
// seen at different headings must read the same world field; a turn in place sweeps the reading
// round an ellipse; and the field's mean over a long route is the Earth's. All three are one
// least-squares problem: the world field on a grid of nodes over the session's swath, f(p) by
// bilinear interpolation, is estimated jointly with every sensor's S, h and k, from
//
//   m_i = S · R_iᵀ f(p_i) + h + v_i · k + noise        (reading i at p_i, attitude R_i, speed v_i)
//
// with a prior that the field is the route's mean (the Earth's field) plus anomalies of a few µT
// that change smoothly between neighbouring nodes (a robust loss absorbs what the model leaves
// out: the acceleration current, drift, misaligned axes). Ceres solves it with sparse
// Cholesky (SuiteSparse). The data alone cannot say:
//  - the field's unit: S, h, k and f scaled together explain the readings equally; the solve holds
//    the soft iron's trace at its identity value and, where the site's horizontal Earth field is
//    known (SensorRig::earth_field_horizontal_uT), rescales S so the route's mean horizontal field
//    has that magnitude;
//  - for a level body, the vertical hard iron, the vertical gain and the soft iron's couplings of
//    the vertical axis (a constant on B_z or a gain on it looks like the field): they are held at
//    zero and one unless the body tilts by more than CalibrationConfig::min_tilt_deg, and said
//    so. They shift B_v by a constant and scale it, which the matching's correlation does not see.

#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct CalibrationConfig {
  bool enabled = true;               ///< false: use only calibrations the session states
  double field_cell_size_m = 0.4;    ///< node spacing of the field estimated with it
  double sample_spacing_m = 0.1;     ///< a sensor's readings kept one per this much travel ...
  double sample_turn_deg = 3.0;      ///< ... or this much turn (turns in place carry the most)
  double noise_uT = 1.0;             ///< scale of the robust (Huber) loss of a reading
  double smoothness_uT = 2.0;        ///< σ of the field's change between neighbouring nodes
  double anomaly_uT = 5.0;           ///< σ of the field's departure from the route's mean
  double hard_iron_prior_uT = 50.0;  ///< σ of the prior towards zero
  double soft_iron_prior = 0.2;      ///< σ of the prior towards identity
  double speed_prior_uT_per_mps = 5.0;
  /// The speed term is estimated only where the forward speed varies by at least this standard
  /// deviation (m/s): at constant speed it is indistinguishable from the hard iron, which then
  /// holds both (right for every reading taken at that speed).
  bool estimate_speed_term = true;
  double min_speed_spread_mps = 0.3;
  /// Vertical terms are estimated only when the body's tilt from level has at least this
  /// standard deviation (deg): a hand-held device, not a wheeled base.
  double min_tilt_deg = 3.0;
  /// A field node is "revisited" when readings at headings this far apart touch it (deg): how
  /// much of the evidence comes from the same place seen twice (reported, not required).
  double revisit_heading_deg = 90.0;
  /// A sensor is calibrated only with at least `min_readings` readings whose headings vary: the
  /// mean resultant length of their heading unit vectors at most `max_heading_resultant` (1: a
  /// straight drive, 0: every heading alike).
  int min_readings = 100;
  double max_heading_resultant = 0.8;
  int max_iterations = 40;

  bool IsValid(std::string* error) const;
};

enum class CalibrationSource {
  kGiven,          ///< stated in session.yaml, used as it is
  kEstimated,      ///< estimated from the session's own readings
  kNotObservable,  ///< the data cannot fix it (see note): left uncalibrated
  kDisabled,       ///< CalibrationConfig::enabled is false and none was given
};
std::string toString(CalibrationSource source);

/// One magnetometer's calibration and how it was reached.
struct SensorCalibration {
  MagnetometerCalibration calibration;
  CalibrationSource source = CalibrationSource::kDisabled;
  bool vertical_estimated = false;  ///< vertical terms estimated (a tilting body)
  bool scaled_to_earth_field = false;
  int readings = 0;         ///< readings the estimate used
  int revisited_nodes = 0;  ///< field nodes seen from headings revisit_heading_deg apart
  bool speed_estimated = false;  ///< the speed term estimated (else folded into the hard iron)
  /// RMS per axis of the readings against the best-fitting field map (µT), uncalibrated and with
  /// this calibration: how much of the readings' disagreement with themselves it explains.
  double residual_before_uT = 0.0;
  double residual_after_uT = 0.0;
  std::string note;  ///< why it is not estimated, or what was held fixed
};

struct SessionCalibration {
  std::vector<SensorCalibration> sensors;  ///< one per magnetometer
  double seconds = 0.0;

  /// The calibration of every sensor (identity where there is none), for placeFingerprints.
  std::vector<MagnetometerCalibration> calibrations() const;
};

/// Calibrates every magnetometer of `session`: a calibration the rig states is used as given; the
/// others are estimated together (they share the field) when `config.enabled`. Deterministic.
/// Throws std::invalid_argument for an invalid config.
SessionCalibration calibrateMagnetometers(const Session& session, const CalibrationConfig& config);

}  // namespace mm4mm
