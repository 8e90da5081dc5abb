#include "mm4mm/merge/fused_magnetic_map.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>

#include "mm4mm/merge/merged_cloud.hpp"

namespace mm4mm {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// Side of the square buckets (m) the readings are sorted into for nearest-reading queries.
constexpr double kBucket_m = 0.5;

// Per cell of `map`: the readings that fell inside it and the distance (m) from its centre to
// the nearest reading (NaN where the map is uncovered).
struct ReadingCoverage {
  std::vector<std::uint32_t> readings;
  std::vector<float> nearest_m;
};

ReadingCoverage readingCoverage(const MagneticMap& map,
                                const std::vector<PlacedFingerprint>& samples) {
  const std::size_t cells = static_cast<std::size_t>(map.width) * map.height;
  ReadingCoverage coverage;
  coverage.readings.assign(cells, 0);
  coverage.nearest_m.assign(cells, kNaN);
  const auto cellOf = [&](double v, double origin, double size) {
    return static_cast<int>(std::floor((v - origin) / size));
  };
  for (const PlacedFingerprint& s : samples) {
    const int ix = cellOf(s.position_m.x(), map.origin_m.x(), map.cell_size_m);
    const int iy = cellOf(s.position_m.y(), map.origin_m.y(), map.cell_size_m);
    if (ix >= 0 && iy >= 0 && ix < map.width && iy < map.height)
      ++coverage.readings[map.index(ix, iy)];
  }

  // Readings sorted into buckets (compressed rows: bucket b holds [start[b], start[b + 1])).
  const int bw = static_cast<int>(std::ceil(map.width * map.cell_size_m / kBucket_m)) + 1;
  const int bh = static_cast<int>(std::ceil(map.height * map.cell_size_m / kBucket_m)) + 1;
  const auto bucketOf = [&](const Eigen::Vector2d& p) {
    const int bx = std::clamp(cellOf(p.x(), map.origin_m.x(), kBucket_m), 0, bw - 1);
    const int by = std::clamp(cellOf(p.y(), map.origin_m.y(), kBucket_m), 0, bh - 1);
    return std::array<int, 2>{bx, by};
  };
  std::vector<std::size_t> start(static_cast<std::size_t>(bw) * bh + 1, 0);
  for (const PlacedFingerprint& s : samples) {
    const auto b = bucketOf(s.position_m.head<2>());
    ++start[static_cast<std::size_t>(b[1]) * bw + b[0] + 1];
  }
  for (std::size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
  std::vector<Eigen::Vector2d> sorted(samples.size());
  std::vector<std::size_t> fill(start.begin(), start.end() - 1);
  for (const PlacedFingerprint& s : samples) {
    const auto b = bucketOf(s.position_m.head<2>());
    sorted[fill[static_cast<std::size_t>(b[1]) * bw + b[0]]++] = s.position_m.head<2>();
  }

  // Rings of buckets around the cell's, until no farther bucket can hold a nearer reading.
  tbb::parallel_for(0, map.height, [&](int iy) {
    for (int ix = 0; ix < map.width; ++ix) {
      if (!map.covered(ix, iy)) continue;
      const Eigen::Vector2d c = map.cellCentre(ix, iy);
      const auto home = bucketOf(c);
      double best2 = std::numeric_limits<double>::infinity();
      for (int r = 0; r <= std::max(bw, bh); ++r) {
        for (int by = home[1] - r; by <= home[1] + r; ++by)
          for (int bx = home[0] - r; bx <= home[0] + r; ++bx) {
            if (std::max(std::abs(bx - home[0]), std::abs(by - home[1])) != r) continue;
            if (bx < 0 || by < 0 || bx >= bw || by >= bh) continue;
            const std::size_t b = static_cast<std::size_t>(by) * bw + bx;
            for (std::size_t i = start[b]; i < start[b + 1]; ++i)
              best2 = std::min(best2, (sorted[i] - c).squaredNorm());
          }
        // Readings in ring r + 1 or beyond lie at least r buckets away from the cell.
        if (best2 <= (r * kBucket_m) * (r * kBucket_m)) break;
      }
      coverage.nearest_m[map.index(ix, iy)] = static_cast<float>(std::sqrt(best2));
    }
  });
  return coverage;
}

void checkLayer(const MagneticLayer& layer, std::size_t index) {
  const MagneticMap& m = layer.map;
  const auto cells = static_cast<std::size_t>(std::max(0, m.width)) * std::max(0, m.height);
  for (const auto* values : {&m.horizontal_uT, &m.vertical_uT, &m.total_uT, &m.session_x_uT,
                             &m.session_y_uT, &layer.variance_uT2})
    if (values->size() != cells)
      throw std::invalid_argument("fuseMagneticLayers: layer " + std::to_string(index) + " holds " +
                                  std::to_string(values->size()) + " values for " +
                                  std::to_string(m.width) + " x " + std::to_string(m.height) +
                                  " cells");
  if (!(m.cell_size_m > 0.0) || !m.origin_m.allFinite())
    throw std::invalid_argument("fuseMagneticLayers: layer " + std::to_string(index) +
                                " has an invalid grid");
}

// Whole cells from `origin` to `to` along one axis; throws unless they are (nearly) whole.
int cellOffset(double to, double origin, double cell_m, std::size_t layer) {
  const double cells = (to - origin) / cell_m;
  const double whole = std::round(cells);
  if (std::abs(cells - whole) > 1e-3)
    throw std::invalid_argument("fuseMagneticLayers: layer " + std::to_string(layer) +
                                " is not on the common grid (origin off by " +
                                std::to_string(cells - whole) + " cells)");
  return static_cast<int>(whole);
}

}  // namespace

bool FusedMagneticMapConfig::IsValid(std::string* error) const {
  const auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  std::string inner;
  if (!map.IsValid(&inner)) return fail("map." + inner);
  if (!std::isfinite(sensor_noise_uT) || sensor_noise_uT < 0.0)
    return fail("sensor_noise_uT must be >= 0 (µT) and finite");
  if (!std::isfinite(sensor_bias_uT) || sensor_bias_uT < 0.0)
    return fail("sensor_bias_uT must be >= 0 (µT) and finite");
  if (!std::isfinite(gradient_uT_per_m) || gradient_uT_per_m < 0.0)
    return fail("gradient_uT_per_m must be >= 0 (µT/m) and finite");
  if (sensor_noise_uT == 0.0 && sensor_bias_uT == 0.0)
    return fail("sensor_noise_uT and sensor_bias_uT cannot both be 0");
  if (!offsets.IsValid(&inner)) return fail("offsets." + inner);
  if (!change.IsValid(&inner)) return fail("change." + inner);
  if (!(max_height_difference_m >= 0.0))
    return fail("max_height_difference_m must be >= 0 (m; .inf: every session fused)");
  return true;
}

MagneticLayer buildMagneticLayer(const Session& session,
                                 const std::vector<Eigen::Isometry3d>& T_atlas_keyframe,
                                 const FusedMagneticMapConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("FusedMagneticMapConfig: " + error);
  if (T_atlas_keyframe.size() != session.keyframes.size())
    throw std::invalid_argument("buildMagneticLayer: session '" + session.id + "' has " +
                                std::to_string(session.keyframes.size()) + " keyframes but " +
                                std::to_string(T_atlas_keyframe.size()) + " optimised poses");
  // The session without its scans, its keyframes at the optimised poses: readings between two
  // keyframes are then interpolated between the corrected poses.
  Session placed;
  placed.id = session.id;
  placed.rig = session.rig;
  placed.keyframes = session.keyframes;
  for (std::size_t k = 0; k < placed.keyframes.size(); ++k)
    placed.keyframes[k].T_frame_body = T_atlas_keyframe[k];
  placed.magnetometer = session.magnetometer;
  const std::vector<PlacedFingerprint> samples = placeFingerprints(placed);

  MagneticLayer layer;
  layer.earth_vertical_uT = session.rig.earth_field_vertical_uT;
  if (samples.empty()) return layer;
  layer.map = buildMagneticMap(samples, placed.rig, config.map);
  const ReadingCoverage coverage = readingCoverage(layer.map, samples);
  const double bias2 = config.sensor_bias_uT * config.sensor_bias_uT;
  const double noise2 = config.sensor_noise_uT * config.sensor_noise_uT;
  layer.variance_uT2.assign(coverage.nearest_m.size(), kNaN);
  for (std::size_t i = 0; i < layer.variance_uT2.size(); ++i) {
    if (std::isnan(coverage.nearest_m[i])) continue;
    const double interpolation = config.gradient_uT_per_m * coverage.nearest_m[i];
    layer.variance_uT2[i] =
        static_cast<float>(bias2 + noise2 / std::max<std::uint32_t>(1, coverage.readings[i]) +
                           interpolation * interpolation);
  }
  return layer;
}

FusedMagneticMap fuseMagneticLayers(const std::vector<MagneticLayer>& layers) {
  std::vector<std::size_t> used;
  for (std::size_t l = 0; l < layers.size(); ++l) {
    checkLayer(layers[l], l);
    if (layers[l].map.width > 0 && layers[l].map.height > 0) used.push_back(l);
  }
  FusedMagneticMap fused;
  if (used.empty()) return fused;

  MagneticMap& map = fused.map;
  map.cell_size_m = layers[used[0]].map.cell_size_m;
  map.origin_m = layers[used[0]].map.origin_m;
  for (const std::size_t l : used) {
    if (std::abs(layers[l].map.cell_size_m - map.cell_size_m) > 1e-9 * map.cell_size_m)
      throw std::invalid_argument("fuseMagneticLayers: layer " + std::to_string(l) +
                                  " has cells of " + std::to_string(layers[l].map.cell_size_m) +
                                  " m, layer " + std::to_string(used[0]) + " of " +
                                  std::to_string(map.cell_size_m) + " m");
    map.origin_m = map.origin_m.cwiseMin(layers[l].map.origin_m);
  }
  // Offsets (cells) of each layer's first cell on the common grid.
  std::vector<std::array<int, 2>> offsets;
  double height_sum = 0.0, height_weight = 0.0;
  for (const std::size_t l : used) {
    const MagneticMap& m = layers[l].map;
    offsets.push_back({cellOffset(m.origin_m.x(), map.origin_m.x(), map.cell_size_m, l),
                       cellOffset(m.origin_m.y(), map.origin_m.y(), map.cell_size_m, l)});
    map.width = std::max(map.width, offsets.back()[0] + m.width);
    map.height = std::max(map.height, offsets.back()[1] + m.height);
    const double weight = static_cast<double>(m.coveredCells());
    height_sum += weight * m.height_m;
    height_weight += weight;
  }
  map.height_m = height_weight > 0.0 ? height_sum / height_weight : 0.0;

  const std::size_t cells = static_cast<std::size_t>(map.width) * map.height;
  for (auto* values : {&map.horizontal_uT, &map.vertical_uT, &map.total_uT, &map.session_x_uT,
                       &map.session_y_uT, &fused.variance_uT2, &fused.spread_total_uT})
    values->assign(cells, kNaN);
  fused.session_count.assign(cells, 0);

  tbb::parallel_for(0, map.height, [&](int iy) {
    for (int ix = 0; ix < map.width; ++ix) {
      std::array<double, 5> weighted{};
      double weight_sum = 0.0;
      std::uint16_t count = 0;
      float lowest = std::numeric_limits<float>::infinity(), highest = -lowest;
      for (std::size_t u = 0; u < used.size(); ++u) {
        const MagneticLayer& layer = layers[used[u]];
        const int lx = ix - offsets[u][0], ly = iy - offsets[u][1];
        if (!layer.map.covered(lx, ly)) continue;
        const std::size_t i = layer.map.index(lx, ly);
        const double variance = layer.variance_uT2[i];
        if (!(variance > 0.0) || !std::isfinite(variance)) continue;
        const double w = 1.0 / variance;
        const std::array<float, 5> values{layer.map.horizontal_uT[i], layer.map.vertical_uT[i],
                                          layer.map.total_uT[i], layer.map.session_x_uT[i],
                                          layer.map.session_y_uT[i]};
        for (int c = 0; c < 5; ++c) weighted[c] += w * values[c];
        weight_sum += w;
        ++count;
        lowest = std::min(lowest, values[2]);
        highest = std::max(highest, values[2]);
      }
      if (count == 0) continue;
      const std::size_t i = map.index(ix, iy);
      map.horizontal_uT[i] = static_cast<float>(weighted[0] / weight_sum);
      map.vertical_uT[i] = static_cast<float>(weighted[1] / weight_sum);
      map.total_uT[i] = static_cast<float>(weighted[2] / weight_sum);
      map.session_x_uT[i] = static_cast<float>(weighted[3] / weight_sum);
      map.session_y_uT[i] = static_cast<float>(weighted[4] / weight_sum);
      fused.variance_uT2[i] = static_cast<float>(1.0 / weight_sum);
      fused.session_count[i] = count;
      if (count >= 2) fused.spread_total_uT[i] = highest - lowest;
    }
  });
  return fused;
}

namespace {

// Folds one pair's comparison (on layer a's grid) into the atlas's change map. Each cell keeps
// the largest chi-square, ties to the earlier pair, and the earliest region by (pair, region):
// both are the same whatever order the pairs arrive in. `first_region` holds (pair << 32 |
// region) + 1 per cell, 0 for none; it is numbered once every pair is in.
void foldPair(const MagneticChange& change, std::size_t pair, const MagneticLayer& a,
              std::size_t a_index, ChangeMap* cells, std::vector<std::uint32_t>* best_pair,
              std::vector<std::uint64_t>* first_region) {
  const int dx = cellOffset(a.map.origin_m.x(), cells->origin_m.x(), cells->cell_size_m, a_index);
  const int dy = cellOffset(a.map.origin_m.y(), cells->origin_m.y(), cells->cell_size_m, a_index);
  if (dx < 0 || dy < 0 || dx + change.width > cells->width || dy + change.height > cells->height)
    throw std::invalid_argument("layerChanges: a compared layer reaches outside the change map");
  for (int iy = 0; iy < change.height; ++iy)
    for (int ix = 0; ix < change.width; ++ix) {
      const std::size_t at = static_cast<std::size_t>(iy) * change.width + ix;
      const float chi2 = change.chi2[at];
      if (std::isnan(chi2)) continue;
      const std::size_t i = static_cast<std::size_t>(iy + dy) * cells->width + (ix + dx);
      ++cells->pairs[i];
      const bool first = std::isnan(cells->chi2[i]);
      if (first || chi2 > cells->chi2[i] || (chi2 == cells->chi2[i] && pair < (*best_pair)[i])) {
        cells->chi2[i] = chi2;
        cells->delta_uT[i] = change.delta_uT[at];
        (*best_pair)[i] = static_cast<std::uint32_t>(pair);
      }
      if (change.region[at] < 0) continue;
      const std::uint64_t key = (static_cast<std::uint64_t>(pair) << 32 | change.region[at]) + 1;
      std::uint64_t& held = (*first_region)[i];
      if (held == 0 || key < held) held = key;
    }
}

}  // namespace

std::vector<LayerChange> layerChanges(const std::vector<MagneticLayer>& layers,
                                      const MagneticChangeConfig& config,
                                      const std::vector<bool>& of, ChangeMap* cells) {
  if (!of.empty() && of.size() != layers.size())
    throw std::invalid_argument("layerChanges: " + std::to_string(of.size()) + " flags for " +
                                std::to_string(layers.size()) + " layers");
  const auto bounds = [](const MagneticMap& map) {
    return Eigen::AlignedBox2d(
        map.origin_m, map.origin_m + map.cell_size_m * Eigen::Vector2d(map.width, map.height));
  };
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t a = 0; a < layers.size(); ++a)
    for (std::size_t b = a + 1; b < layers.size(); ++b)
      if ((of.empty() || of[a] || of[b]) && layers[a].calibration_checked &&
          layers[b].calibration_checked && layers[a].map.coveredCells() > 0 &&
          layers[b].map.coveredCells() > 0 &&
          bounds(layers[a].map).intersects(bounds(layers[b].map)))
        pairs.emplace_back(static_cast<int>(a), static_cast<int>(b));
  std::vector<LayerChange> changes(pairs.size());
  std::vector<std::uint32_t> best_pair;
  std::vector<std::uint64_t> first_region;
  if (cells != nullptr) {
    const std::size_t n = static_cast<std::size_t>(std::max(0, cells->width)) *
                          static_cast<std::size_t>(std::max(0, cells->height));
    cells->pairs.assign(n, 0);
    cells->chi2.assign(n, std::numeric_limits<float>::quiet_NaN());
    cells->delta_uT.assign(n, std::numeric_limits<float>::quiet_NaN());
    cells->region.assign(n, 0);
    best_pair.assign(n, 0);
    first_region.assign(n, 0);
  }
  std::mutex folding;
  tbb::parallel_for(std::size_t{0}, pairs.size(), [&](std::size_t p) {
    const auto [a, b] = pairs[p];
    const MagneticChange change = magneticChange(layers[a], layers[b], config);
    changes[p] = {
        a, b, static_cast<double>(change.compared_cells) * change.cell_size_m * change.cell_size_m,
        change.regions};
    if (cells == nullptr) return;
    const std::lock_guard<std::mutex> lock(folding);
    foldPair(change, p, layers[a], static_cast<std::size_t>(a), cells, &best_pair, &first_region);
  });
  if (cells != nullptr) {
    // Regions are numbered as the pairs list them, from 1; pairs that compared nothing have none.
    std::vector<std::uint32_t> first_number(pairs.size() + 1, 1);
    for (std::size_t p = 0; p < pairs.size(); ++p)
      first_number[p + 1] = first_number[p] + static_cast<std::uint32_t>(changes[p].regions.size());
    for (std::size_t i = 0; i < first_region.size(); ++i)
      if (first_region[i] != 0) {
        const std::uint64_t key = first_region[i] - 1;
        cells->region[i] = first_number[key >> 32] + static_cast<std::uint32_t>(key & 0xffffffffu);
      }
  }
  changes.erase(std::remove_if(changes.begin(), changes.end(),
                               [](const LayerChange& c) { return c.compared_m2 == 0.0; }),
                changes.end());
  return changes;
}

FusedMagneticMap fuseMagneticMaps(
    const std::vector<Session>& sessions,
    const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
    const FusedMagneticMapConfig& config, const std::vector<SessionFacts>& given) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("FusedMagneticMapConfig: " + error);
  checkAtlasPoses(sessions, T_atlas_keyframe, "fuseMagneticMaps");
  if (!given.empty() && given.size() != sessions.size())
    throw std::invalid_argument("fuseMagneticMaps: facts of " + std::to_string(given.size()) +
                                " sessions for " + std::to_string(sessions.size()) + " sessions");
  const std::vector<SessionFacts> facts =
      given.empty() ? std::vector<SessionFacts>(sessions.size()) : given;
  std::vector<MagneticLayer> layers(sessions.size());
  tbb::parallel_for(std::size_t{0}, sessions.size(), [&](std::size_t i) {
    layers[i] = buildMagneticLayer(sessions[i], T_atlas_keyframe[i], config);
    layers[i].vertical_observed = facts[i].vertical_observed;
    layers[i].height_above_floor_m = facts[i].height_above_floor_m;
    layers[i].calibration_uT = facts[i].calibration.residual_uT;
    layers[i].calibration_checked = facts[i].calibration.checked;
  });
  const std::vector<bool> kept = layersAtOneHeight(layers, config.max_height_difference_m);
  const std::vector<double> heights = layerHeights(layers);
  std::vector<std::optional<double>> other_height(layers.size());
  const auto reference = std::find(kept.begin(), kept.end(), true);
  for (std::size_t i = 0; i < layers.size(); ++i)
    if (!kept[i] && layers[i].map.coveredCells() > 0) {
      other_height[i] = heights[i] - heights[reference - kept.begin()];
      layers[i] = MagneticLayer{};
    }
  FieldOffsets offsets = applyFieldOffsets(layers, config.offsets);
  FusedMagneticMap fused = fuseMagneticLayers(layers);
  fused.offsets = std::move(offsets);
  fused.other_height_m = std::move(other_height);
  fused.changes_of.assign(sessions.size(), false);
  fused.change_unchecked.assign(sessions.size(), false);
  if (config.detect_changes) {
    for (std::size_t i = 0; i < sessions.size(); ++i) {
      fused.changes_of[i] = facts[i].compare_changes;
      fused.change_unchecked[i] = layers[i].map.coveredCells() > 0 && !facts[i].calibration.checked;
    }
    ChangeMap& cells = fused.change_map;
    cells.origin_m = fused.map.origin_m;
    cells.cell_size_m = fused.map.cell_size_m;
    cells.width = fused.map.width;
    cells.height = fused.map.height;
    cells.height_m = fused.map.height_m;
    fused.changes = layerChanges(layers, config.change, fused.changes_of, &cells);
  }
  return fused;
}

std::vector<double> layerHeights(const std::vector<MagneticLayer>& layers) {
  const auto used = [&](const MagneticLayer& layer) { return layer.map.coveredCells() > 0; };
  const bool above_floor =
      std::all_of(layers.begin(), layers.end(), [&](const MagneticLayer& layer) {
        return !used(layer) || layer.height_above_floor_m.has_value();
      });
  std::vector<double> heights;
  for (const MagneticLayer& layer : layers)
    heights.push_back(above_floor && used(layer) ? *layer.height_above_floor_m
                                                 : layer.map.height_m);
  return heights;
}

std::vector<bool> atOneHeight(const std::vector<std::optional<double>>& heights,
                              double max_difference_m) {
  const auto near = [&](std::size_t i, std::size_t j) {
    return heights[i] && heights[j] && std::abs(*heights[i] - *heights[j]) <= max_difference_m;
  };
  std::size_t reference = heights.size(), most = 0;
  for (std::size_t i = 0; i < heights.size(); ++i) {
    std::size_t count = 0;
    for (std::size_t j = 0; j < heights.size(); ++j) count += near(i, j) ? 1 : 0;
    if (count > most) most = count, reference = i;
  }
  std::vector<bool> kept(heights.size(), false);
  for (std::size_t i = 0; reference < heights.size() && i < heights.size(); ++i)
    kept[i] = near(i, reference);
  return kept;
}

std::vector<bool> layersAtOneHeight(const std::vector<MagneticLayer>& layers,
                                    double max_difference_m) {
  const std::vector<double> heights = layerHeights(layers);
  std::vector<std::optional<double>> given(layers.size());
  for (std::size_t i = 0; i < layers.size(); ++i)
    if (layers[i].map.coveredCells() > 0) given[i] = heights[i];
  return atOneHeight(given, max_difference_m);
}

}  // namespace mm4mm
