#pragma once
// Internal to magnetic/: what calibrateMagnetometers (self_calibration.cpp) solves with, chosen
// from a session's readings (self_calibration_data.cpp): the readings kept, the sensors the data
// can calibrate, the field's statistics along the tracks, the places read twice and the rows of
// the route's mean.

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/self_calibration.hpp"

namespace mm4mm::calibration_detail {

constexpr double kDeg = M_PI / 180.0;

// A reading kept for the solve.
struct Reading {
  int sensor = 0;
  double time_s = 0.0;
  Eigen::Vector3d position_m;
  Eigen::Matrix3d R;
  Eigen::Vector3d m;
  double v = 0.0;
  double heading = 0.0;
  double arc_m = 0.0;  ///< along its sensor's track
};

// Readings of the sensors to estimate, thinned per sensor: one per `spacing` of travel or
// `turn` of heading (a robot standing still adds nothing new; one turning in place adds the most).
std::vector<Reading> keptReadings(const std::vector<PlacedReading>& placed,
                                  const std::vector<bool>& estimate,
                                  const CalibrationConfig& config);

// A hard iron turns with the body: it shows only against readings at other headings. A sensor
// whose headings hardly vary (a straight drive) cannot be calibrated from its own data: it is
// no longer estimated, its record says why, and its readings are dropped.
void dropUnobservableSensors(const CalibrationConfig& config, std::vector<bool>* estimate,
                             std::vector<Reading>* readings,
                             std::vector<SensorCalibration>* sensors_out);

// The field's spread about its mean and its structure function along the tracks, from the raw
// world-frame readings: D(d) = E|w(s + d) − w(s)|² / 3 per axis.
struct FieldStatistics {
  double spread_uT = 5.0;
  double correlation_length_m = 3.0;
  std::vector<double> structure;  ///< at lags k · kLagStep_m
};
constexpr double kLagStep_m = 0.025;
constexpr double kMaxLag_m = 3.0;

FieldStatistics fieldStatistics(const std::vector<Reading>& readings, int sensors);

struct Pair {
  std::size_t i = 0, j = 0;
  double sigma_uT = 1.0;
};

// Readings within `radius` of each other at headings `min_heading` apart, at most `per_reading`
// nearest partners each; the hash grid and the scan order make the list the same every run.
std::vector<Pair> samePlacePairs(const std::vector<Reading>& readings, double radius,
                                 double min_heading, double min_separation_s, int per_reading,
                                 double noise_uT, const FieldStatistics& statistics);

// The route's mean: one reading per correlation length of each track (neighbours within it
// are not independent evidence).
std::vector<std::size_t> meanRows(const std::vector<Reading>& readings, int sensors,
                                  double correlation_length_m);

// RMS tilt of the body from level (deg): whether the vertical terms are observable.
double tiltRmsDeg(const std::vector<Reading>& readings);

// Whether the forward speed varies enough to tell the speed term from the hard iron (at constant
// speed the two are one).
bool speedTermObservable(const std::vector<Reading>& readings, const CalibrationConfig& config);

}  // namespace mm4mm::calibration_detail
