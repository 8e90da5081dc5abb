#pragma once
// A single-session magnetic map: a regular grid of rotation-invariant fingerprints over the
// area the magnetometers swept, with a coverage mask (paper Section III-A.1). Frame: the
// session frame, cells in x-y; values in µT.

#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/magnetic/fingerprint.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// One magnetometer reading placed in the session frame: where the sensor was and what
/// heading-free field it measured.
struct PlacedFingerprint {
  double time_s = 0.0;
  int sensor = 0;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  ///< sensor position, session frame
  double yaw_rad = 0.0;  ///< heading of the body at that time, session frame
  Eigen::Vector3d levelled_uT = Eigen::Vector3d::Zero();  ///< field in the levelled body frame
  MagneticFingerprint fingerprint;
};

/// The values a map cell holds, in this order: B_h, B_v, B_F, session-frame B_x, B_y.
using MapChannels = Eigen::Matrix<double, 5, 1>;
MapChannels mapChannelsOf(const PlacedFingerprint& sample);

/// One raw magnetometer reading placed in the session frame, before calibration.
struct PlacedReading {
  double time_s = 0.0;
  int sensor = 0;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();        ///< sensor position, session frame
  Eigen::Matrix3d R_frame_body = Eigen::Matrix3d::Identity();  ///< body attitude, session frame
  double speed_mps = 0.0;                                      ///< forward speed of the body
  Eigen::Vector3d reading_uT = Eigen::Vector3d::Zero();        ///< as the sensor gave it, body axes
};

/// Places every magnetometer sample by interpolating the odometry's pose stream at its time (the
/// keyframes where the session has no stream); samples outside the keyframes' time span are
/// dropped.
std::vector<PlacedReading> placeReadings(const Session& session);

/// Fingerprints of placed readings, each corrected by its sensor's calibration where
/// `calibrations` has one (indexed by sensor) and levelled with its pose's roll and pitch.
std::vector<PlacedFingerprint> fingerprintsOf(
    const std::vector<PlacedReading>& readings,
    const std::vector<std::optional<MagnetometerCalibration>>& calibrations);

/// placeReadings, then fingerprintsOf with `calibration` (one per magnetometer) or, when it is
/// null, with the calibrations the rig states.
std::vector<PlacedFingerprint> placeFingerprints(
    const Session& session, const std::vector<MagnetometerCalibration>* calibration = nullptr);

/// Gaussian-process regression of a single sensor's track (Solin et al. 2018 model the ambient
/// field this way): a squared-exponential kernel, the fingerprints' mean as the prior mean, and
/// a cell counts as covered only where the posterior is confident. Unlike a painted footprint it
/// fills between neighbouring passes and says where it does not know.
struct GaussianProcessMapConfig {
  /// Chosen by scripts/choose_gp_length_scale.sh on the procedural tuning worlds (seeds 1-20, one
  /// magnetometer, docs/bench/gp_length_scale.md): 0.25 m gives the most aligned best modes and
  /// the lowest z a separate pair reaches (0.4 m, copied from a config chosen on the Aalto
  /// recordings, was the default until then).
  double length_scale_m = 0.25;
  double noise_ratio = 0.05;        ///< measurement noise variance over the field's variance
  double max_std_ratio = 0.5;       ///< covered where posterior std < this × prior std
  double tile_size_m = 3.0;         ///< solved tile by tile with the samples within reach
  double sample_spacing_m = 0.05;   ///< readings averaged per square of this side first
  int max_samples_per_tile = 2500;  ///< bounds each tile's Cholesky; more are thinned evenly

  bool IsValid(std::string* error) const;
};

enum class SingleSensorInterpolation { kFootprint, kGaussianProcess };

struct MagneticMapConfig {
  double cell_size_m = 0.05;
  /// Triangles between neighbouring sensor tracks are filled only when their sides are shorter
  /// than this (m): longer sides mean a gap in time or a turn in place, not a swath.
  double max_triangle_side_m = 1.5;
  /// Width of the strip painted along the track of a rig with a single magnetometer (m).
  double single_sensor_footprint_m = 0.3;
  /// How a rig of one magnetometer is mapped: the Gaussian process by default (a single track is
  /// too narrow for a painted strip to overlap another session's), the footprint on request.
  SingleSensorInterpolation single_sensor_interpolation =
      SingleSensorInterpolation::kGaussianProcess;
  GaussianProcessMapConfig gaussian_process;
  /// Lateral distance above which two sensors of a rig are not neighbours (m).
  double max_sensor_gap_m = 1.0;

  bool IsValid(std::string* error) const;
};

/// Grid of fingerprints. Cell (ix, iy) covers [origin + (ix, iy) * cell, origin + (ix+1, iy+1) *
/// cell) and its value is the one at the cell centre. Uncovered cells hold NaN.
struct MagneticMap {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
  double cell_size_m = 0.05;
  int width = 0;          ///< cells along x
  int height = 0;         ///< cells along y
  double height_m = 0.0;  ///< mean sensor height of the samples (z of the map)
  /// Built from one magnetometer's track (a swath about a metre wide), not a sensor array's:
  /// the matcher searches it at a finer coarse resolution.
  bool single_track = false;
  std::vector<float> horizontal_uT;  ///< B_h, row-major (iy * width + ix)
  std::vector<float> vertical_uT;    ///< B_v
  std::vector<float> total_uT;       ///< B_F
  /// Horizontal field along the session frame's x and y axes: heading-dependent, for matching
  /// where the relative heading is trusted.
  std::vector<float> session_x_uT;
  std::vector<float> session_y_uT;

  bool covered(int ix, int iy) const {
    return ix >= 0 && iy >= 0 && ix < width && iy < height && !std::isnan(total_uT[index(ix, iy)]);
  }
  std::size_t index(int ix, int iy) const { return static_cast<std::size_t>(iy) * width + ix; }
  Eigen::Vector2d cellCentre(int ix, int iy) const;
  std::size_t coveredCells() const;
  double coveredArea_m2() const { return coveredCells() * cell_size_m * cell_size_m; }
};

/// Linear interpolation between the sensor tracks (a single sensor: its footprint, or the
/// Gaussian-process map when so configured): the rig's parallel tracks form strips, and
/// each cell inside a triangle between neighbouring sensors at consecutive samples takes the
/// barycentric blend of the three fingerprints. Cells swept more than once average.
MagneticMap buildMagneticMap(const std::vector<PlacedFingerprint>& samples, const SensorRig& rig,
                             const MagneticMapConfig& config);

/// Averages `map` over blocks of `factor` x `factor` cells (covered cells only); a block is
/// covered when at least a quarter of its cells are.
MagneticMap downsample(const MagneticMap& map, int factor);

}  // namespace mm4mm
