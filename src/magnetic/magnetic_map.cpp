#include "mm4mm/magnetic/magnetic_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/core/trajectory.hpp"
#include "mm4mm/magnetic/gaussian_process_map.hpp"

namespace mm4mm {
namespace {

constexpr float kUncovered = std::numeric_limits<float>::quiet_NaN();

// Sums of fingerprints per cell, averaged at the end.
struct Accumulator {
  MagneticMap map;
  std::vector<double> sum_h, sum_v, sum_f, sum_x, sum_y;
  std::vector<int> count;

  Accumulator(const Eigen::AlignedBox2d& bounds, double cell_size_m) {
    map.cell_size_m = cell_size_m;
    map.origin_m = bounds.min();
    map.width = static_cast<int>(std::ceil(bounds.sizes().x() / cell_size_m)) + 1;
    map.height = static_cast<int>(std::ceil(bounds.sizes().y() / cell_size_m)) + 1;
    const std::size_t cells = static_cast<std::size_t>(map.width) * map.height;
    for (auto* sum : {&sum_h, &sum_v, &sum_f, &sum_x, &sum_y}) sum->assign(cells, 0.0);
    count.assign(cells, 0);
  }

  // Adds the barycentric blend of three fingerprints to every cell whose centre lies inside
  // the triangle (a, b, c).
  using Values = MapChannels;

  void addTriangle(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                   const Values& fa, const Values& fb, const Values& fc) {
    const double area2 = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    if (std::abs(area2) < 1e-9) return;
    const double cs = map.cell_size_m;
    const Eigen::Vector2d lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
    const int x0 =
        std::max(0, static_cast<int>(std::floor((lo.x() - map.origin_m.x()) / cs - 0.5)));
    const int y0 =
        std::max(0, static_cast<int>(std::floor((lo.y() - map.origin_m.y()) / cs - 0.5)));
    const int x1 =
        std::min(map.width - 1, static_cast<int>(std::ceil((hi.x() - map.origin_m.x()) / cs)));
    const int y1 =
        std::min(map.height - 1, static_cast<int>(std::ceil((hi.y() - map.origin_m.y()) / cs)));
    constexpr double kEdge = -1e-9;
    for (int iy = y0; iy <= y1; ++iy)
      for (int ix = x0; ix <= x1; ++ix) {
        const Eigen::Vector2d p = map.cellCentre(ix, iy);
        const double wa = ((b - p).x() * (c - p).y() - (b - p).y() * (c - p).x()) / area2;
        const double wb = ((c - p).x() * (a - p).y() - (c - p).y() * (a - p).x()) / area2;
        const double wc = 1.0 - wa - wb;
        if (wa < kEdge || wb < kEdge || wc < kEdge) continue;
        const Values f = wa * fa + wb * fb + wc * fc;
        const std::size_t i = map.index(ix, iy);
        sum_h[i] += f[0], sum_v[i] += f[1], sum_f[i] += f[2], sum_x[i] += f[3], sum_y[i] += f[4];
        ++count[i];
      }
  }

  MagneticMap finish() {
    const std::size_t cells = count.size();
    map.horizontal_uT.assign(cells, kUncovered);
    map.vertical_uT.assign(cells, kUncovered);
    map.total_uT.assign(cells, kUncovered);
    map.session_x_uT.assign(cells, kUncovered);
    map.session_y_uT.assign(cells, kUncovered);
    for (std::size_t i = 0; i < cells; ++i) {
      if (count[i] == 0) continue;
      map.horizontal_uT[i] = static_cast<float>(sum_h[i] / count[i]);
      map.vertical_uT[i] = static_cast<float>(sum_v[i] / count[i]);
      map.total_uT[i] = static_cast<float>(sum_f[i] / count[i]);
      map.session_x_uT[i] = static_cast<float>(sum_x[i] / count[i]);
      map.session_y_uT[i] = static_cast<float>(sum_y[i] / count[i]);
    }
    return std::move(map);
  }
};

Accumulator::Values valuesOf(const PlacedFingerprint& s) { return mapChannelsOf(s); }

bool shortSides(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                double max_side) {
  return (a - b).norm() <= max_side && (b - c).norm() <= max_side && (c - a).norm() <= max_side;
}

// Pairs of sensors that are lateral neighbours on the rig, ordered by body y.
std::vector<std::pair<int, int>> neighbourSensors(const SensorRig& rig, double max_gap_m) {
  std::vector<int> order(rig.magnetometers_body.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return rig.magnetometers_body[a].y() < rig.magnetometers_body[b].y();
  });
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t i = 0; i + 1 < order.size(); ++i)
    if ((rig.magnetometers_body[order[i]] - rig.magnetometers_body[order[i + 1]]).norm() <=
        max_gap_m)
      pairs.emplace_back(order[i], order[i + 1]);
  return pairs;
}

// The samples taken at one instant, indexed by sensor (-1 where a sensor has no sample).
std::vector<std::vector<int>> groupByTime(const std::vector<PlacedFingerprint>& samples,
                                          int sensors) {
  std::vector<std::vector<int>> groups;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const bool same_time =
        !groups.empty() && std::abs(samples[i].time_s - samples[i - 1].time_s) < 1e-9;
    if (!same_time) groups.emplace_back(sensors, -1);
    groups.back()[samples[i].sensor] = static_cast<int>(i);
  }
  return groups;
}

void addStrips(const std::vector<PlacedFingerprint>& samples, const SensorRig& rig,
               const MagneticMapConfig& config, Accumulator* acc) {
  const auto groups = groupByTime(samples, static_cast<int>(rig.magnetometers_body.size()));
  const auto pairs = neighbourSensors(rig, config.max_sensor_gap_m);
  for (std::size_t j = 0; j + 1 < groups.size(); ++j)
    for (const auto& [k, l] : pairs) {
      const int a = groups[j][k], b = groups[j][l], c = groups[j + 1][l], d = groups[j + 1][k];
      if (a < 0 || b < 0 || c < 0 || d < 0) continue;
      const Eigen::Vector2d pa = samples[a].position_m.head<2>(),
                            pb = samples[b].position_m.head<2>(),
                            pc = samples[c].position_m.head<2>(),
                            pd = samples[d].position_m.head<2>();
      if (shortSides(pa, pb, pc, config.max_triangle_side_m))
        acc->addTriangle(pa, pb, pc, valuesOf(samples[a]), valuesOf(samples[b]),
                         valuesOf(samples[c]));
      if (shortSides(pa, pc, pd, config.max_triangle_side_m))
        acc->addTriangle(pa, pc, pd, valuesOf(samples[a]), valuesOf(samples[c]),
                         valuesOf(samples[d]));
    }
}

// A lone sensor sweeps a strip of the configured width: each step between consecutive samples
// becomes a rectangle across the track, interpolated along it.
void addFootprint(const std::vector<PlacedFingerprint>& samples, int sensor,
                  const MagneticMapConfig& config, Accumulator* acc) {
  const double half = 0.5 * config.single_sensor_footprint_m;
  int previous = -1;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (samples[i].sensor != sensor) continue;
    if (previous >= 0) {
      const Eigen::Vector2d p0 = samples[previous].position_m.head<2>();
      const Eigen::Vector2d p1 = samples[i].position_m.head<2>();
      const Eigen::Vector2d step = p1 - p0;
      if (step.norm() > 1e-6 && step.norm() <= config.max_triangle_side_m) {
        const Eigen::Vector2d side = half * Eigen::Vector2d(-step.y(), step.x()).normalized();
        const Accumulator::Values f0 = valuesOf(samples[previous]), f1 = valuesOf(samples[i]);
        acc->addTriangle(p0 - side, p0 + side, p1 + side, f0, f0, f1);
        acc->addTriangle(p0 - side, p1 + side, p1 - side, f0, f1, f1);
      }
    }
    previous = static_cast<int>(i);
  }
}

}  // namespace

MapChannels mapChannelsOf(const PlacedFingerprint& s) {
  const Eigen::Vector2d horizontal = Eigen::Rotation2Dd(s.yaw_rad) * s.levelled_uT.head<2>();
  MapChannels v;
  v << s.fingerprint.horizontal_uT, s.fingerprint.vertical_uT, s.fingerprint.total_uT,
      horizontal.x(), horizontal.y();
  return v;
}

std::vector<PlacedReading> placeReadings(const Session& session) {
  std::vector<PlacedReading> placed;
  const auto& kf = session.keyframes;
  if (kf.empty()) return placed;
  const std::vector<StampedPose>& stream = session.odometry.empty() ? kf : session.odometry;
  placed.reserve(session.magnetometer.size());
  for (const MagnetometerSample& m : session.magnetometer) {
    if (m.time_s < kf.front().time_s || m.time_s > kf.back().time_s) continue;
    const Eigen::Isometry3d pose = poseAt(stream, m.time_s);
    PlacedReading p;
    p.time_s = m.time_s;
    p.sensor = m.sensor;
    p.position_m = pose * session.rig.magnetometers_body.at(m.sensor);
    p.R_frame_body = pose.linear();
    p.speed_mps = forwardSpeedAt(stream, m.time_s);
    p.reading_uT = m.field_body_uT;
    placed.push_back(p);
  }
  return placed;
}

std::vector<PlacedFingerprint> fingerprintsOf(
    const std::vector<PlacedReading>& readings,
    const std::vector<std::optional<MagnetometerCalibration>>& calibrations) {
  std::vector<PlacedFingerprint> placed;
  placed.reserve(readings.size());
  for (const PlacedReading& r : readings) {
    const Eigen::Vector3d field_body =
        static_cast<std::size_t>(r.sensor) < calibrations.size() && calibrations[r.sensor]
            ? calibrations[r.sensor]->correct(r.reading_uT, r.speed_mps)
            : r.reading_uT;
    PlacedFingerprint p;
    p.time_s = r.time_s;
    p.sensor = r.sensor;
    p.position_m = r.position_m;
    p.yaw_rad = yawOf(r.R_frame_body);
    p.levelled_uT = levelReading(r.R_frame_body, field_body);
    p.fingerprint = fingerprintOf(r.R_frame_body, field_body);
    placed.push_back(p);
  }
  return placed;
}

std::vector<PlacedFingerprint> placeFingerprints(
    const Session& session, const std::vector<MagnetometerCalibration>* calibration) {
  if (!calibration) return fingerprintsOf(placeReadings(session), session.rig.calibrations);
  std::vector<std::optional<MagnetometerCalibration>> given(calibration->begin(),
                                                            calibration->end());
  return fingerprintsOf(placeReadings(session), given);
}

bool MagneticMapConfig::IsValid(std::string* error) const {
  const auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!(cell_size_m > 0.0)) return fail("cell_size_m must be > 0");
  if (!(max_triangle_side_m > 0.0)) return fail("max_triangle_side_m must be > 0");
  if (!(single_sensor_footprint_m > 0.0)) return fail("single_sensor_footprint_m must be > 0");
  if (!(max_sensor_gap_m > 0.0)) return fail("max_sensor_gap_m must be > 0");
  std::string inner;
  if (!gaussian_process.IsValid(&inner)) return fail("gaussian_process." + inner);
  return true;
}

Eigen::Vector2d MagneticMap::cellCentre(int ix, int iy) const {
  return origin_m + cell_size_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
}

std::size_t MagneticMap::coveredCells() const {
  return static_cast<std::size_t>(
      std::count_if(total_uT.begin(), total_uT.end(), [](float v) { return !std::isnan(v); }));
}

MagneticMap buildMagneticMap(const std::vector<PlacedFingerprint>& samples, const SensorRig& rig,
                             const MagneticMapConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument(error);
  if (samples.empty()) return MagneticMap{};
  if (rig.magnetometers_body.size() == 1 &&
      config.single_sensor_interpolation == SingleSensorInterpolation::kGaussianProcess) {
    MagneticMap map = buildGaussianProcessMap(samples, config.cell_size_m, config.gaussian_process);
    map.single_track = true;
    return map;
  }
  Eigen::AlignedBox2d bounds;
  double height_sum = 0.0;
  for (const auto& s : samples)
    bounds.extend(s.position_m.head<2>()), height_sum += s.position_m.z();
  const double margin = config.single_sensor_footprint_m + config.cell_size_m;
  bounds.min().array() -= margin;
  bounds.max().array() += margin;
  // Snap the origin to the cell grid so maps of one frame share cell boundaries.
  bounds.min() = (bounds.min() / config.cell_size_m).array().floor() * config.cell_size_m;
  Accumulator acc(bounds, config.cell_size_m);
  if (rig.magnetometers_body.size() == 1)
    addFootprint(samples, 0, config, &acc);
  else
    addStrips(samples, rig, config, &acc);
  MagneticMap map = acc.finish();
  map.height_m = height_sum / samples.size();
  map.single_track = rig.magnetometers_body.size() == 1;
  return map;
}

MagneticMap downsample(const MagneticMap& map, int factor) {
  if (factor < 1) throw std::invalid_argument("downsample factor must be >= 1");
  MagneticMap coarse;
  coarse.origin_m = map.origin_m;
  coarse.cell_size_m = map.cell_size_m * factor;
  coarse.width = (map.width + factor - 1) / factor;
  coarse.height = (map.height + factor - 1) / factor;
  coarse.height_m = map.height_m;
  coarse.single_track = map.single_track;
  const std::size_t cells = static_cast<std::size_t>(coarse.width) * coarse.height;
  coarse.horizontal_uT.assign(cells, kUncovered);
  coarse.vertical_uT.assign(cells, kUncovered);
  coarse.total_uT.assign(cells, kUncovered);
  coarse.session_x_uT.assign(cells, kUncovered);
  coarse.session_y_uT.assign(cells, kUncovered);
  const int needed = std::max(1, factor * factor / 4);
  for (int cy = 0; cy < coarse.height; ++cy)
    for (int cx = 0; cx < coarse.width; ++cx) {
      double h = 0, v = 0, f = 0, x = 0, y = 0;
      int n = 0;
      for (int iy = cy * factor; iy < std::min(map.height, (cy + 1) * factor); ++iy)
        for (int ix = cx * factor; ix < std::min(map.width, (cx + 1) * factor); ++ix) {
          if (!map.covered(ix, iy)) continue;
          const std::size_t i = map.index(ix, iy);
          h += map.horizontal_uT[i], v += map.vertical_uT[i], f += map.total_uT[i];
          x += map.session_x_uT[i], y += map.session_y_uT[i];
          ++n;
        }
      if (n < needed) continue;
      const std::size_t i = coarse.index(cx, cy);
      coarse.horizontal_uT[i] = static_cast<float>(h / n);
      coarse.vertical_uT[i] = static_cast<float>(v / n);
      coarse.total_uT[i] = static_cast<float>(f / n);
      coarse.session_x_uT[i] = static_cast<float>(x / n);
      coarse.session_y_uT[i] = static_cast<float>(y / n);
    }
  return coarse;
}

}  // namespace mm4mm
