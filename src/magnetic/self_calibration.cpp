#include "mm4mm/magnetic/self_calibration.hpp"

#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <utility>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"

namespace mm4mm {
namespace {

constexpr double kDeg = M_PI / 180.0;
// Per sensor: C's six distinct entries, then c (3), then d (3).
enum Entry { kXX, kYY, kZZ, kXY, kXZ, kYZ, kCx, kCy, kCz, kDx, kDy, kDz, kPerSensor };
// Far stronger than any data row: holds C's trace at its identity value (the unit gauge) and
// pins what a level body cannot observe.
constexpr double kConstraintWeight = 1e4;
// Huber: rows whose whitened residual exceeds this keep a linear, not quadratic, influence.
constexpr double kHuber = 3.0;

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

// Readings of the sensors to estimate, thinned per sensor: one per `spacing` of travel or
// `turn` of heading (a robot standing still adds nothing new; one turning in place adds the most).
std::vector<Reading> keptReadings(const std::vector<PlacedReading>& placed,
                                  const std::vector<bool>& estimate,
                                  const CalibrationConfig& config) {
  std::vector<Reading> kept;
  std::vector<int> last(estimate.size(), -1);
  for (const PlacedReading& p : placed) {
    if (!estimate[p.sensor]) continue;
    double arc = 0.0;
    if (last[p.sensor] >= 0) {
      const Reading& previous = kept[last[p.sensor]];
      const double travel = (p.position_m - previous.position_m).head<2>().norm();
      const double turn = std::abs(wrapAngle(yawOf(p.R_frame_body) - previous.heading));
      if (travel < config.sample_spacing_m && turn < config.sample_turn_deg * kDeg) continue;
      arc = previous.arc_m + travel;
    }
    last[p.sensor] = static_cast<int>(kept.size());
    kept.push_back({p.sensor, p.time_s, p.position_m, p.R_frame_body, p.reading_uT, p.speed_mps,
                    yawOf(p.R_frame_body), arc});
  }
  return kept;
}

// The field's spread about its mean and its structure function along the tracks, from the raw
// world-frame readings: D(d) = E|w(s + d) − w(s)|² / 3 per axis.
struct FieldStatistics {
  double spread_uT = 5.0;
  double correlation_length_m = 3.0;
  std::vector<double> structure;  ///< at lags k · kLagStep_m
};
constexpr double kLagStep_m = 0.025;
constexpr double kMaxLag_m = 3.0;

FieldStatistics fieldStatistics(const std::vector<Reading>& readings, int sensors) {
  FieldStatistics out;
  if (readings.size() < 10) return out;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Reading& r : readings) mean += r.R * r.m;
  mean /= static_cast<double>(readings.size());
  double variance = 0.0;
  for (const Reading& r : readings) variance += (r.R * r.m - mean).squaredNorm() / 3.0;
  variance /= static_cast<double>(readings.size());
  const int lags = static_cast<int>(kMaxLag_m / kLagStep_m);
  std::vector<double> sum(lags + 1, 0.0);
  std::vector<int> count(lags + 1, 0);
  std::vector<std::vector<const Reading*>> tracks(sensors);
  for (const Reading& r : readings) tracks[r.sensor].push_back(&r);
  for (const auto& track : tracks)
    for (std::size_t i = 0; i < track.size(); i += 2)
      for (std::size_t j = i + 1; j < track.size(); ++j) {
        const double lag = track[j]->arc_m - track[i]->arc_m;
        if (lag > kMaxLag_m) break;
        const int k = static_cast<int>(std::lround(lag / kLagStep_m));
        sum[k] += (track[j]->R * track[j]->m - track[i]->R * track[i]->m).squaredNorm() / 3.0;
        ++count[k];
      }
  out.structure.assign(lags + 1, 2.0 * variance);
  out.structure[0] = 0.0;
  for (int k = 1; k <= lags; ++k)
    if (count[k] > 0) out.structure[k] = sum[k] / count[k];
  out.spread_uT = std::max(0.5, std::sqrt(variance));
  for (int k = 1; k <= lags; ++k)
    if (count[k] > 0 && out.structure[k] >= variance) {  // correlation one half
      out.correlation_length_m = k * kLagStep_m;
      break;
    }
  return out;
}

double structureAt(const FieldStatistics& s, double lag_m) {
  const int k = std::clamp(static_cast<int>(std::lround(lag_m / kLagStep_m)), 0,
                           static_cast<int>(s.structure.size()) - 1);
  return s.structure.empty() ? 0.0 : s.structure[k];
}

struct Pair {
  std::size_t i = 0, j = 0;
  double sigma_uT = 1.0;
};

// Readings within `radius` of each other at headings `min_heading` apart, at most `per_reading`
// nearest partners each; the hash grid and the scan order make the list the same every run.
std::vector<Pair> samePlacePairs(const std::vector<Reading>& readings, double radius,
                                 double min_heading, double min_separation_s, int per_reading,
                                 double noise_uT, const FieldStatistics& statistics) {
  std::map<std::pair<long, long>, std::vector<std::size_t>> cells;
  for (std::size_t i = 0; i < readings.size(); ++i) {
    const Eigen::Vector2d g = readings[i].position_m.head<2>() / radius;
    cells[{static_cast<long>(std::floor(g.x())), static_cast<long>(std::floor(g.y()))}].push_back(
        i);
  }
  std::vector<Pair> pairs;
  std::vector<std::pair<double, std::size_t>> near;
  for (std::size_t i = 0; i < readings.size(); ++i) {
    const Reading& a = readings[i];
    const Eigen::Vector2d g = a.position_m.head<2>() / radius;
    const long cx = static_cast<long>(std::floor(g.x())), cy = static_cast<long>(std::floor(g.y()));
    near.clear();
    for (long dy = -1; dy <= 1; ++dy)
      for (long dx = -1; dx <= 1; ++dx) {
        const auto it = cells.find({cx + dx, cy + dy});
        if (it == cells.end()) continue;
        for (std::size_t j : it->second) {
          if (j <= i) continue;
          const Reading& b = readings[j];
          const double d = (a.position_m - b.position_m).head<2>().norm();
          if (d > radius || std::abs(wrapAngle(a.heading - b.heading)) < min_heading ||
              std::abs(a.time_s - b.time_s) < min_separation_s)
            continue;
          near.emplace_back(d, j);
        }
      }
    std::sort(near.begin(), near.end());
    for (std::size_t k = 0; k < near.size() && static_cast<int>(k) < per_reading; ++k) {
      const double sigma =
          std::sqrt(2.0 * noise_uT * noise_uT + structureAt(statistics, near[k].first));
      pairs.push_back({i, near[k].second, sigma});
    }
  }
  return pairs;
}

double tiltRmsDeg(const std::vector<Reading>& readings) {
  if (readings.empty()) return 0.0;
  double sum = 0.0;
  for (const Reading& r : readings) {
    const double tilt = std::acos(std::clamp(r.R(2, 2), -1.0, 1.0));
    sum += tilt * tilt;
  }
  return std::sqrt(sum / readings.size()) / kDeg;
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
  // A hard iron turns with the body: it shows only against readings at other headings. A sensor
  // whose headings hardly vary (a straight drive) cannot be calibrated from its own data.
  {
    std::vector<Eigen::Vector2d> heading_sum(sensors, Eigen::Vector2d::Zero());
    std::vector<int> heading_count(sensors, 0);
    for (const Reading& r : readings) {
      heading_sum[r.sensor] += Eigen::Vector2d(std::cos(r.heading), std::sin(r.heading));
      ++heading_count[r.sensor];
    }
    for (int s = 0; s < sensors; ++s) {
      if (!estimate[s]) continue;
      const double resultant = heading_count[s] ? heading_sum[s].norm() / heading_count[s] : 1.0;
      if (heading_count[s] >= config.min_readings && resultant <= config.max_heading_resultant)
        continue;
      estimate[s] = false;
      result.sensors[s].source = CalibrationSource::kNotObservable;
      char text[200];
      std::snprintf(text, sizeof text,
                    "%d readings at headings that hardly vary (mean resultant length %.2f, at most "
                    "%.2f needed); uncalibrated",
                    heading_count[s], resultant, config.max_heading_resultant);
      result.sensors[s].note = text;
    }
    readings.erase(std::remove_if(readings.begin(), readings.end(),
                                  [&](const Reading& r) { return !estimate[r.sensor]; }),
                   readings.end());
  }
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
  // The route's mean: one reading per correlation length of each track (neighbours within it
  // are not independent evidence).
  std::vector<std::size_t> mean_rows;
  {
    std::vector<double> next(sensors, 0.0);
    for (std::size_t i = 0; i < readings.size(); ++i)
      if (readings[i].arc_m >= next[readings[i].sensor]) {
        mean_rows.push_back(i);
        next[readings[i].sensor] = readings[i].arc_m + statistics.correlation_length_m;
      }
  }

  const bool vertical = tiltRmsDeg(readings) >= config.min_tilt_deg;
  double speed_sum = 0.0, speed_squares = 0.0;
  for (const Reading& r : readings) speed_sum += r.v, speed_squares += r.v * r.v;
  const double speed_mean = speed_sum / readings.size();
  const bool with_speed =
      config.estimate_speed_term &&
      std::sqrt(std::max(0.0, speed_squares / readings.size() - speed_mean * speed_mean)) >=
          config.min_speed_spread_mps;
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

std::string describe(const SensorCalibration& c) {
  char text[400];
  const Eigen::Vector3d& h = c.calibration.hard_iron_uT;
  const Eigen::Matrix3d& S = c.calibration.soft_iron;
  if (c.source == CalibrationSource::kEstimated) {
    std::snprintf(text, sizeof text,
                  "estimated: hard iron (%.2f, %.2f, %.2f) µT ± %.2f, soft iron diagonal (%.3f, "
                  "%.3f, %.3f), off-diagonal max %.3f; readings at %d places read twice disagree "
                  "%.2f -> %.2f µT",
                  h.x(), h.y(), h.z(), c.hard_iron_sigma_uT, S(0, 0), S(1, 1), S(2, 2),
                  std::max({std::abs(S(0, 1)), std::abs(S(0, 2)), std::abs(S(1, 2))}), c.pairs,
                  c.residual_before_uT, c.residual_after_uT);
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
