// Choosing what the self-calibration solves with (self_calibration_data.hpp).

#include "self_calibration_data.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <utility>

#include "mm4mm/core/pose.hpp"

namespace mm4mm::calibration_detail {

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

void dropUnobservableSensors(const CalibrationConfig& config, std::vector<bool>* estimate,
                             std::vector<Reading>* readings,
                             std::vector<SensorCalibration>* sensors_out) {
  const int sensors = static_cast<int>(estimate->size());
  std::vector<Eigen::Vector2d> heading_sum(sensors, Eigen::Vector2d::Zero());
  std::vector<int> heading_count(sensors, 0);
  for (const Reading& r : *readings) {
    heading_sum[r.sensor] += Eigen::Vector2d(std::cos(r.heading), std::sin(r.heading));
    ++heading_count[r.sensor];
  }
  for (int s = 0; s < sensors; ++s) {
    if (!(*estimate)[s]) continue;
    const double resultant = heading_count[s] ? heading_sum[s].norm() / heading_count[s] : 1.0;
    if (heading_count[s] >= config.min_readings && resultant <= config.max_heading_resultant)
      continue;
    (*estimate)[s] = false;
    (*sensors_out)[s].source = CalibrationSource::kNotObservable;
    char text[200];
    std::snprintf(text, sizeof text,
                  "%d readings at headings that hardly vary (mean resultant length %.2f, at most "
                  "%.2f needed); uncalibrated",
                  heading_count[s], resultant, config.max_heading_resultant);
    (*sensors_out)[s].note = text;
  }
  readings->erase(std::remove_if(readings->begin(), readings->end(),
                                 [&](const Reading& r) { return !(*estimate)[r.sensor]; }),
                  readings->end());
}

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

namespace {

double structureAt(const FieldStatistics& s, double lag_m) {
  const int k = std::clamp(static_cast<int>(std::lround(lag_m / kLagStep_m)), 0,
                           static_cast<int>(s.structure.size()) - 1);
  return s.structure.empty() ? 0.0 : s.structure[k];
}

}  // namespace

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

std::vector<std::size_t> meanRows(const std::vector<Reading>& readings, int sensors,
                                  double correlation_length_m) {
  std::vector<std::size_t> mean_rows;
  std::vector<double> next(sensors, 0.0);
  for (std::size_t i = 0; i < readings.size(); ++i)
    if (readings[i].arc_m >= next[readings[i].sensor]) {
      mean_rows.push_back(i);
      next[readings[i].sensor] = readings[i].arc_m + correlation_length_m;
    }
  return mean_rows;
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

bool speedTermObservable(const std::vector<Reading>& readings, const CalibrationConfig& config) {
  if (!config.estimate_speed_term) return false;
  double speed_sum = 0.0, speed_squares = 0.0;
  for (const Reading& r : readings) speed_sum += r.v, speed_squares += r.v * r.v;
  const double speed_mean = speed_sum / readings.size();
  return std::sqrt(std::max(0.0, speed_squares / readings.size() - speed_mean * speed_mean)) >=
         config.min_speed_spread_mps;
}

}  // namespace mm4mm::calibration_detail
