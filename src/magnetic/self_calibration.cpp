#include "mm4mm/magnetic/self_calibration.hpp"

#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "self_calibration_data.hpp"

namespace mm4mm {
namespace {

using calibration_detail::dropUnobservableSensors;
using calibration_detail::FieldStatistics;
using calibration_detail::fieldStatistics;
using calibration_detail::kDeg;
using calibration_detail::keptReadings;
using calibration_detail::meanRows;
using calibration_detail::Pair;
using calibration_detail::Reading;
using calibration_detail::samePlacePairs;
using calibration_detail::speedTermObservable;
using calibration_detail::tiltRmsDeg;

// Per sensor: C's six distinct entries, then c (3), then d (3).
enum Entry { kXX, kYY, kZZ, kXY, kXZ, kYZ, kCx, kCy, kCz, kDx, kDy, kDz, kPerSensor };
// Far stronger than any data row: holds C's trace at its identity value (the unit gauge) and
// pins what a level body cannot observe.
constexpr double kConstraintWeight = 1e4;
// Huber: rows whose whitened residual exceeds this keep a linear, not quadratic, influence.
constexpr double kHuber = 3.0;

// w = R (C m − c − v d) = J x over this sensor's block of x: the 3 × kPerSensor Jacobian.
Eigen::Matrix<double, 3, kPerSensor> worldJacobian(const Reading& r) {
  Eigen::Matrix<double, 3, kPerSensor> J = Eigen::Matrix<double, 3, kPerSensor>::Zero();
  Eigen::Matrix<double, 3, 6> dC = Eigen::Matrix<double, 3, 6>::Zero();
  const Eigen::Vector3d& m = r.m;
  dC(0, kXX) = m.x(), dC(1, kYY) = m.y(), dC(2, kZZ) = m.z();
  dC(0, kXY) = m.y(), dC(1, kXY) = m.x();
  dC(0, kXZ) = m.z(), dC(2, kXZ) = m.x();
  dC(1, kYZ) = m.z(), dC(2, kYZ) = m.y();
  J.block<3, 6>(0, 0) = r.R * dC;
  J.block<3, 3>(0, kCx) = -r.R;
  J.block<3, 3>(0, kDx) = -r.v * r.R;
  return J;
}

Eigen::Matrix3d symmetricOf(const Eigen::VectorXd& x, int offset) {
  Eigen::Matrix3d C;
  C << x[offset + kXX], x[offset + kXY], x[offset + kXZ], x[offset + kXY], x[offset + kYY],
      x[offset + kYZ], x[offset + kXZ], x[offset + kYZ], x[offset + kZZ];
  return C;
}

// Per sensor, the RMS per axis of the world-frame differences at the pairs it takes part in.
std::vector<double> pairRms(const std::vector<Reading>& readings, const std::vector<Pair>& pairs,
                            const Eigen::VectorXd& x, const std::vector<int>& slot, int sensors) {
  const auto world = [&](const Reading& r) -> Eigen::Vector3d {
    return worldJacobian(r) * x.segment<kPerSensor>(slot[r.sensor] * kPerSensor);
  };
  std::vector<double> sum(sensors, 0.0);
  std::vector<int> count(sensors, 0);
  for (const Pair& p : pairs) {
    const double e = (world(readings[p.i]) - world(readings[p.j])).squaredNorm() / 3.0;
    for (int s : {readings[p.i].sensor, readings[p.j].sensor}) sum[s] += e, ++count[s];
  }
  std::vector<double> rms(sensors, 0.0);
  for (int s = 0; s < sensors; ++s) rms[s] = count[s] ? std::sqrt(sum[s] / count[s]) : 0.0;
  return rms;
}

}  // namespace

std::string toString(CalibrationSource source) {
  switch (source) {
    case CalibrationSource::kGiven:
      return "given";
    case CalibrationSource::kEstimated:
      return "estimated";
    case CalibrationSource::kNotObservable:
      return "not observable";
    case CalibrationSource::kDisabled:
      return "disabled";
  }
  return "unknown";
}

bool CalibrationConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (!(sample_spacing_m >= 0.0) || !(sample_turn_deg >= 0.0))
    return fail("sample_spacing_m and sample_turn_deg must be >= 0");
  if (!(noise_uT > 0.0)) return fail("noise_uT must be > 0");
  if (!(pair_radius_m >= 0.0 && pair_radius_m <= 1.0))
    return fail("pair_radius_m must be in [0, 1]");
  if (!(min_pair_heading_deg >= 0.0 && min_pair_heading_deg <= 180.0))
    return fail("min_pair_heading_deg must be in [0, 180]");
  if (max_pairs_per_reading < 1) return fail("max_pairs_per_reading must be >= 1");
  if (!(min_pair_separation_s >= 0.0)) return fail("min_pair_separation_s must be >= 0");
  if (!(hard_iron_prior_uT > 0.0) || !(soft_iron_prior > 0.0) || !(speed_prior_uT_per_mps > 0.0))
    return fail("hard_iron_prior_uT, soft_iron_prior and speed_prior_uT_per_mps must be > 0");
  if (!(min_speed_spread_mps >= 0.0)) return fail("min_speed_spread_mps must be >= 0");
  if (!(min_tilt_deg >= 0.0)) return fail("min_tilt_deg must be >= 0");
  if (min_readings < 10) return fail("min_readings must be >= 10");
  if (!(max_heading_resultant > 0.0 && max_heading_resultant <= 1.0))
    return fail("max_heading_resultant must be in (0, 1]");
  if (robust_iterations < 1) return fail("robust_iterations must be >= 1");
  return true;
}

std::vector<MagnetometerCalibration> SessionCalibration::calibrations() const {
  std::vector<MagnetometerCalibration> out;
  for (const SensorCalibration& s : sensors) out.push_back(s.calibration);
  return out;
}

bool SessionCalibration::verticalObserved() const {
  return !sensors.empty() &&
         std::all_of(sensors.begin(), sensors.end(),
                     [](const SensorCalibration& s) { return s.vertical_estimated; });
}

SessionCalibration calibrateMagnetometers(const Session& session, const CalibrationConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("calibrateMagnetometers: " + error);
  const auto start = std::chrono::steady_clock::now();
  const int sensors = static_cast<int>(session.rig.magnetometers_body.size());
  SessionCalibration result;
  result.sensors.resize(sensors);
  std::vector<bool> estimate(sensors, false);
  for (int s = 0; s < sensors; ++s) {
    SensorCalibration& out = result.sensors[s];
    if (static_cast<std::size_t>(s) < session.rig.calibrations.size() &&
        session.rig.calibrations[s]) {
      out.calibration = *session.rig.calibrations[s];
      out.source = CalibrationSource::kGiven;
      out.note = "stated in session.yaml";
    } else if (!config.enabled) {
      out.source = CalibrationSource::kDisabled;
      out.note = "estimation disabled; uncalibrated";
    } else {
      estimate[s] = true;
    }
  }
  const auto finish = [&] {
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };

  std::vector<Reading> readings = keptReadings(placeReadings(session), estimate, config);
  dropUnobservableSensors(config, &estimate, &readings, &result.sensors);
  if (readings.empty()) return finish();

  const FieldStatistics statistics = fieldStatistics(readings, sensors);
  const double radius = config.pair_radius_m > 0.0
                            ? config.pair_radius_m
                            : std::clamp(0.1 * statistics.correlation_length_m, 0.02, 0.1);
  result.field_spread_uT = statistics.spread_uT;
  result.field_correlation_length_m = statistics.correlation_length_m;
  result.pair_radius_m = radius;
  const std::vector<Pair> pairs = samePlacePairs(
      readings, radius, config.min_pair_heading_deg * kDeg, config.min_pair_separation_s,
      config.max_pairs_per_reading, config.noise_uT, statistics);
  const std::vector<std::size_t> mean_rows =
      meanRows(readings, sensors, statistics.correlation_length_m);

  const bool vertical = tiltRmsDeg(readings) >= config.min_tilt_deg;
  const bool with_speed = speedTermObservable(readings, config);
  std::vector<int> slot(sensors, -1);
  int estimated = 0, reference = -1;
  for (int s = 0; s < sensors; ++s)
    if (estimate[s]) {
      slot[s] = estimated++;
      if (reference < 0) reference = s;
    }
  const int n = estimated * kPerSensor + 3;  // + F, the route's mean field
  const int f = estimated * kPerSensor;

  // Normal equations of the weighted rows, rebuilt each robust iteration.
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  for (int k = 0; k < estimated; ++k)
    x[k * kPerSensor + kXX] = x[k * kPerSensor + kYY] = x[k * kPerSensor + kZZ] = 1.0;
  const auto pin = [&](Eigen::MatrixXd* A, Eigen::VectorXd* b, int index, double value,
                       double weight) {
    (*A)(index, index) += weight * weight;
    (*b)[index] += weight * weight * value;
  };
  Eigen::VectorXd before_x = x;
  const auto build_and_solve = [&](bool calibrate, Eigen::MatrixXd* information) {
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(n);
    // Pairs: (J_i − J_j) x = 0, over the two sensors' blocks.
    for (const Pair& p : pairs) {
      const Reading& ri = readings[p.i];
      const Reading& rj = readings[p.j];
      const int oi = slot[ri.sensor] * kPerSensor, oj = slot[rj.sensor] * kPerSensor;
      const Eigen::Matrix<double, 3, kPerSensor> Ji = worldJacobian(ri), Jj = worldJacobian(rj);
      const Eigen::Vector3d e = Ji * x.segment<kPerSensor>(oi) - Jj * x.segment<kPerSensor>(oj);
      const double u = e.norm() / p.sigma_uT;
      const double w = (u <= kHuber ? 1.0 : kHuber / u) / (p.sigma_uT * p.sigma_uT);
      A.block<kPerSensor, kPerSensor>(oi, oi) += w * Ji.transpose() * Ji;
      A.block<kPerSensor, kPerSensor>(oj, oj) += w * Jj.transpose() * Jj;
      A.block<kPerSensor, kPerSensor>(oi, oj) -= w * Ji.transpose() * Jj;
      A.block<kPerSensor, kPerSensor>(oj, oi) -= w * Jj.transpose() * Ji;
    }
    // The route's mean: J_i x − F = 0.
    for (std::size_t i : mean_rows) {
      const Reading& r = readings[i];
      const int o = slot[r.sensor] * kPerSensor;
      const Eigen::Matrix<double, 3, kPerSensor> J = worldJacobian(r);
      const Eigen::Vector3d e = J * x.segment<kPerSensor>(o) - x.segment<3>(f);
      const double sigma = statistics.spread_uT;
      const double u = e.norm() / sigma;
      const double w = (u <= kHuber ? 1.0 : kHuber / u) / (sigma * sigma);
      A.block<kPerSensor, kPerSensor>(o, o) += w * J.transpose() * J;
      A.block<kPerSensor, 3>(o, f) -= w * J.transpose();
      A.block<3, kPerSensor>(f, o) -= w * J;
      A.block<3, 3>(f, f) += w * Eigen::Matrix3d::Identity();
    }
    for (int s = 0; s < sensors; ++s) {
      if (!estimate[s]) continue;
      const int o = slot[s] * kPerSensor;
      // Priors, then what is fixed.
      for (int e = 0; e < 6; ++e)
        pin(&A, &b, o + e, e < 3 ? 1.0 : 0.0, 1.0 / config.soft_iron_prior);
      for (int e = kCx; e <= kCz; ++e) pin(&A, &b, o + e, 0.0, 1.0 / config.hard_iron_prior_uT);
      for (int e = kDx; e <= kDz; ++e) pin(&A, &b, o + e, 0.0, 1.0 / config.speed_prior_uT_per_mps);
      if (!calibrate) {
        for (int e = 0; e < kPerSensor; ++e)
          pin(&A, &b, o + e, e < 3 ? 1.0 : 0.0, kConstraintWeight);
        continue;
      }
      // Unit gauge: the trace of C (its horizontal block for a level body) at its identity value.
      const int span = vertical ? 3 : 2;
      for (int p = 0; p < span; ++p)
        for (int q = 0; q < span; ++q) A(o + p, o + q) += kConstraintWeight * kConstraintWeight;
      for (int p = 0; p < span; ++p) b[o + p] += kConstraintWeight * kConstraintWeight * span;
      if (!vertical) {
        // A level body's C_xz, C_yz act on a nearly constant B_z: indistinguishable from the
        // hard iron, which then carries them (exactly, up to B_z's variation times a few %).
        pin(&A, &b, o + kZZ, 1.0, kConstraintWeight);
        pin(&A, &b, o + kXZ, 0.0, kConstraintWeight);
        pin(&A, &b, o + kYZ, 0.0, kConstraintWeight);
        if (s == reference) {
          pin(&A, &b, o + kCz, 0.0, kConstraintWeight);
          pin(&A, &b, o + kDz, 0.0, kConstraintWeight);
        }
      }
      if (!with_speed)
        for (int e = kDx; e <= kDz; ++e) pin(&A, &b, o + e, 0.0, kConstraintWeight);
    }
    x = A.ldlt().solve(b);
    if (information) *information = A;
  };
  for (int it = 0; it < config.robust_iterations; ++it) build_and_solve(false, nullptr);
  before_x = x;
  const std::vector<double> before = pairRms(readings, pairs, before_x, slot, sensors);
  Eigen::MatrixXd information;
  for (int it = 0; it < config.robust_iterations; ++it) build_and_solve(true, &information);
  const std::vector<double> after = pairRms(readings, pairs, x, slot, sensors);
  const Eigen::MatrixXd covariance = information.ldlt().solve(Eigen::MatrixXd::Identity(n, n));

  // The unit: the route's mean horizontal field against the site's Earth field, where known.
  double scale = 1.0;
  const std::optional<double> earth = session.rig.earth_field_horizontal_uT;
  if (earth && x.segment<2>(f).norm() > 1e-6) scale = x.segment<2>(f).norm() / *earth;

  for (int s = 0; s < sensors; ++s) {
    if (!estimate[s]) continue;
    SensorCalibration& out = result.sensors[s];
    const int o = slot[s] * kPerSensor;
    const Eigen::Matrix3d C = symmetricOf(x, o);
    const Eigen::Matrix3d S = C.inverse();
    out.source = CalibrationSource::kEstimated;
    out.vertical_estimated = vertical;
    out.speed_estimated = with_speed;
    out.scaled_to_earth_field = earth.has_value();
    out.calibration.soft_iron = scale * 0.5 * (S + S.transpose());
    out.calibration.hard_iron_uT = S * x.segment<3>(o + kCx);
    out.calibration.speed_uT_per_mps = S * x.segment<3>(o + kDx);
    out.residual_before_uT = before[s];
    out.residual_after_uT = after[s];
    // h ≈ S c: its horizontal spread from c's (S is near identity).
    const Eigen::Matrix2d c_covariance = covariance.block<2, 2>(o + kCx, o + kCx);
    out.hard_iron_sigma_uT = std::sqrt(std::max(c_covariance(0, 0), c_covariance(1, 1)));
    out.readings = static_cast<int>(std::count_if(readings.begin(), readings.end(),
                                                  [&](const Reading& r) { return r.sensor == s; }));
    out.pairs = static_cast<int>(std::count_if(pairs.begin(), pairs.end(), [&](const Pair& p) {
      return readings[p.i].sensor == s || readings[p.j].sensor == s;
    }));
    std::vector<std::string> notes;
    if (!vertical)
      notes.push_back(s == reference
                          ? "level body: vertical offset, gain and couplings held at 0, 1, 0"
                          : "level body: vertical gain and couplings held at 1, 0, offset "
                            "relative to magnetometer " +
                                std::to_string(reference));
    if (!with_speed) notes.push_back("speed hardly varies: speed term folded into the hard iron");
    if (!earth)
      notes.push_back(std::string("no earth_field given: soft iron's unit kept at trace ") +
                      (vertical ? "3" : "2 (horizontal)"));
    for (const std::string& note : notes) out.note += (out.note.empty() ? "" : "; ") + note;
  }
  return finish();
}

std::vector<SessionCalibration> calibrateSessions(const std::vector<Session*>& sessions,
                                                  const CalibrationConfig& config) {
  std::vector<SessionCalibration> records(sessions.size());
  tbb::parallel_for(std::size_t{0}, sessions.size(), [&](std::size_t i) {
    records[i] = calibrateMagnetometers(*sessions[i], config);
  });
  for (std::size_t i = 0; i < sessions.size(); ++i) {
    SensorRig& rig = sessions[i]->rig;
    const std::vector<SensorCalibration>& sensors = records[i].sensors;
    rig.calibrations.resize(sensors.size());
    for (std::size_t k = 0; k < sensors.size(); ++k)
      if (sensors[k].source == CalibrationSource::kEstimated)
        rig.calibrations[k] = sensors[k].calibration;
    if (std::none_of(rig.calibrations.begin(), rig.calibrations.end(),
                     [](const auto& c) { return c.has_value(); }))
      rig.calibrations.clear();
  }
  return records;
}

CalibrationEvidence calibrationEvidence(const SessionCalibration& calibration) {
  CalibrationEvidence evidence;
  double sum2 = 0.0;
  int estimated = 0;
  for (const SensorCalibration& sensor : calibration.sensors) {
    if (sensor.source == CalibrationSource::kNotObservable) evidence.checked = false;
    if (sensor.source != CalibrationSource::kEstimated) continue;
    if (sensor.pairs == 0) evidence.checked = false;
    sum2 += 0.5 * sensor.residual_after_uT * sensor.residual_after_uT;
    ++estimated;
  }
  if (estimated > 0) evidence.residual_uT = std::sqrt(sum2 / estimated);
  return evidence;
}

std::string describe(const SensorCalibration& c) {
  char text[400];
  const Eigen::Vector3d& h = c.calibration.hard_iron_uT;
  const Eigen::Matrix3d& S = c.calibration.soft_iron;
  if (c.source == CalibrationSource::kEstimated) {
    char twice[120];
    // "readings at 0 places read twice disagree 0.00 -> 0.00 µT" reads as a perfect fit.
    if (c.pairs > 0)
      std::snprintf(twice, sizeof twice,
                    "readings at %d places read twice disagree %.2f -> %.2f µT", c.pairs,
                    c.residual_before_uT, c.residual_after_uT);
    else
      std::snprintf(twice, sizeof twice, "no place read twice at headings apart");
    std::snprintf(text, sizeof text,
                  "estimated: hard iron (%.2f, %.2f, %.2f) µT ± %.2f, soft iron diagonal (%.3f, "
                  "%.3f, %.3f), off-diagonal max %.3f; %s",
                  h.x(), h.y(), h.z(), c.hard_iron_sigma_uT, S(0, 0), S(1, 1), S(2, 2),
                  std::max({std::abs(S(0, 1)), std::abs(S(0, 2)), std::abs(S(1, 2))}), twice);
  } else if (c.source == CalibrationSource::kGiven) {
    std::snprintf(text, sizeof text,
                  "given: hard iron (%.2f, %.2f, %.2f) µT, soft iron diagonal (%.3f, %.3f, %.3f)",
                  h.x(), h.y(), h.z(), S(0, 0), S(1, 1), S(2, 2));
  } else {
    std::snprintf(text, sizeof text, "%s", toString(c.source).c_str());
  }
  std::string out = text;
  if (!c.note.empty() && c.source != CalibrationSource::kGiven) out += " (" + c.note + ")";
  return out;
}

}  // namespace mm4mm
