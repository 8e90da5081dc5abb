#pragma once
// Calibrating a session's magnetometers from the session itself (MagnetometerCalibration's model:
// m = S · B + h + v · k per sensor). Written with C = S⁻¹, c = C h, d = C k, the field a reading
// says is there, in the session frame,
//
//   w_i = R_i (C m_i − c − v_i d)              (reading m_i at p_i, attitude R_i, speed v_i)
//
// is linear in the unknowns. Three facts of the data fix them, each a set of linear equations:
//  - the same place seen at other headings reads the same field: w_i = w_j for readings within a
//    few centimetres of each other, of this sensor or another, taken at headings at least
//    `min_pair_heading_deg` apart (passes in opposite directions, crossings, turns in place,
//    whose readings lie round an ellipse). Noise σ² = 2σ_n² plus the field's change over the
//    pair's distance (its structure function, measured along the tracks);
//  - the field's mean over a long route is the Earth's: w_i = F for one reading per correlation
//    length of track, F unknown and common, σ the field's own spread about its mean;
//  - weak priors pull C towards identity and c, d towards zero.
// This is the joint estimate of the field and the calibration with the field eliminated: a place
// read twice is the field's self-overlap, the mean its prior. The solve is a small dense weighted
// least-squares problem (Eigen), iterated with Huber weights against what the model leaves out
// (the acceleration current, drift, misaligned axes, a pair across a steep gradient).
// The data alone cannot say:
//  - the field's unit: C, c, d and F scaled together fit equally well; the solve holds the trace
//    of C's horizontal block (all of C when tilting) at its identity value and, where the site's
//    horizontal Earth field is known (SensorRig::earth_field_horizontal_uT), rescales S so the
//    route's mean horizontal field has that magnitude;
//  - for a level body, the vertical offset and gain (a constant on B_z or a gain on it looks like
//    the field): held at zero and one for one sensor, the others' offsets fixed relative to it by
//    the places they share, unless the body tilts by more than `min_tilt_deg`. They shift B_v by a
//    constant and scale it, which the matching's correlation does not see. The soft iron's
//    couplings of the vertical axis act on a nearly constant B_z there, so the hard iron carries
//    them; what is left turns a few per cent of the horizontal field into B_v.

#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct CalibrationConfig {
  bool enabled = true;              ///< false: use only calibrations the session states
  double sample_spacing_m = 0.025;  ///< a sensor's readings kept one per this much travel ...
  double sample_turn_deg = 3.0;     ///< ... or this much turn (turns in place carry the most)
  double noise_uT = 1.0;            ///< σ of one reading
  /// Readings this close (m) are "the same place"; 0: a tenth of the field's correlation length
  /// along the tracks, within [0.02, 0.1].
  double pair_radius_m = 0.0;
  double min_pair_heading_deg = 20.0;  ///< pairs at nearly one heading carry no information
  /// Pairs are at least this far apart in time (s): within one turn the attitude and the readings
  /// share their timing errors (a clock offset, an odometry that lags the turn), and a heading
  /// taken from the direction of travel is wrong while pivoting; separate passes are not.
  double min_pair_separation_s = 3.0;
  int max_pairs_per_reading = 6;
  double hard_iron_prior_uT = 50.0;  ///< σ of the prior towards zero
  /// σ of the prior of C towards identity: real soft iron is a few per cent.
  double soft_iron_prior = 0.05;
  double speed_prior_uT_per_mps = 5.0;
  /// The speed term is estimated only where the forward speed varies by at least this standard
  /// deviation (m/s): at constant speed it is indistinguishable from the hard iron, which then
  /// holds both (right for every reading taken at that speed).
  bool estimate_speed_term = true;
  double min_speed_spread_mps = 0.3;
  /// Vertical terms are estimated only when the body's tilt from level has at least this
  /// RMS (deg): a hand-held device, not a wheeled base.
  double min_tilt_deg = 3.0;
  /// A sensor is calibrated only with at least `min_readings` readings whose headings vary: the
  /// mean resultant length of their heading unit vectors at most `max_heading_resultant` (1: a
  /// straight drive, 0: every heading alike).
  int min_readings = 100;
  double max_heading_resultant = 0.8;
  int robust_iterations = 6;

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
  bool speed_estimated = false;     ///< the speed term estimated (else folded into the hard iron)
  bool scaled_to_earth_field = false;
  int readings = 0;  ///< readings the estimate used
  int pairs = 0;     ///< places it read twice at headings apart (with any sensor)
  /// RMS per axis of the world-frame difference of its readings at places read twice (µT),
  /// uncalibrated and calibrated: how much of the readings' disagreement with themselves the
  /// calibration explains (what is left is noise and the field's change over the pair distance).
  double residual_before_uT = 0.0;
  double residual_after_uT = 0.0;
  /// Standard deviation of the horizontal hard iron from the solve's covariance (µT, per axis,
  /// the larger): how well the data fixed it.
  double hard_iron_sigma_uT = 0.0;
  std::string note;  ///< why it is not estimated, or what was held fixed
};

struct SessionCalibration {
  std::vector<SensorCalibration> sensors;  ///< one per magnetometer
  /// The field's statistics along the tracks that weighted the solve: spread about its mean (µT),
  /// correlation length (m), the pair radius (m).
  double field_spread_uT = 0.0;
  double field_correlation_length_m = 0.0;
  double pair_radius_m = 0.0;
  double seconds = 0.0;

  /// The calibration of every sensor (identity where there is none), for placeFingerprints.
  std::vector<MagnetometerCalibration> calibrations() const;
  /// Every magnetometer's vertical terms were estimated (a tilting body), so the session's B_v is
  /// absolute and can anchor the fused map's vertical (MagneticLayer::vertical_observed).
  bool verticalObserved() const;
};

/// Calibrates every magnetometer of `session`: a calibration the rig states is used as given; the
/// others are estimated together (they share the field) when `config.enabled`. Deterministic.
/// Throws std::invalid_argument for an invalid config.
SessionCalibration calibrateMagnetometers(const Session& session, const CalibrationConfig& config);

/// The pipeline's calibration step: calibrates every session (in parallel) and states each
/// estimated calibration in its rig, so that every later stage (maps, matching, the graph's
/// magnetic residuals, the fused map) applies it. Returns how each was reached, per session.
std::vector<SessionCalibration> calibrateSessions(const std::vector<Session*>& sessions,
                                                  const CalibrationConfig& config);

/// What a session's calibration leaves in its readings, by its own evidence (the places it read
/// twice at headings apart): what the change score allows for (merge/magnetic_change.hpp).
struct CalibrationEvidence {
  /// Per axis (µT): the RMS over its estimated magnetometers of residual_after_uT / √2 (a
  /// difference of two readings holds two readings' errors); 0 where none was estimated. An upper
  /// bound of sorts: the residual also holds the noise and the field's change over a pair.
  double residual_uT = 0.0;
  /// False where a magnetometer was estimated without a place read twice at headings apart, or
  /// could not be calibrated at all: its heading-dependent error is then unknown (several µT in
  /// the simulated warehouses, against 1-2 µT where the calibration could check itself).
  bool checked = true;
};
CalibrationEvidence calibrationEvidence(const SessionCalibration& calibration);

/// One line about a sensor's calibration for logs and the command line, for example
/// "estimated: hard iron (-3.1, 0.5, 0.0) µT ± 0.1, soft iron diag (0.99, 1.01, 1.00), readings
/// disagree 3.6 -> 1.6 µT at 134 places read twice".
std::string describe(const SensorCalibration& calibration);

}  // namespace mm4mm
