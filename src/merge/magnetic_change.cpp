#include "mm4mm/merge/magnetic_change.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

namespace mm4mm {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

void checkLayer(const MagneticLayer& layer, const char* name) {
  const std::size_t cells = static_cast<std::size_t>(layer.map.width) * layer.map.height;
  if (layer.variance_uT2.size() != cells || layer.map.total_uT.size() != cells)
    throw std::invalid_argument(std::string("magneticChange: layer ") + name + " has " +
                                std::to_string(layer.variance_uT2.size()) + " variances for " +
                                std::to_string(cells) + " cells");
}

// Calls visit(cells) with each 8-connected component of the w x h grid's cells that `in` holds
// (row-major indices, the component's first cell first), components in the order of their first
// cell.
template <typename In, typename Visit>
void eachComponent(int w, int h, const In& in, const Visit& visit) {
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  std::vector<char> seen(n, 0);
  std::vector<std::size_t> stack, members;
  for (std::size_t start = 0; start < n; ++start) {
    if (!in(start) || seen[start]) continue;
    stack.assign(1, start);
    members.clear();
    seen[start] = 1;
    while (!stack.empty()) {
      const std::size_t at = stack.back();
      stack.pop_back();
      members.push_back(at);
      const int ix = static_cast<int>(at % w), iy = static_cast<int>(at / w);
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = ix + dx, ny = iy + dy;
          if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
          const std::size_t next = static_cast<std::size_t>(ny) * w + nx;
          if (in(next) && !seen[next]) {
            seen[next] = 1;
            stack.push_back(next);
          }
        }
    }
    visit(members);
  }
}

// Labels the 8-connected components of `changed`, sums each into a region and marks its cells
// in change->region.
void labelRegions(const std::vector<char>& changed, const MagneticChangeConfig& config,
                  MagneticChange* change) {
  const int w = change->width;
  const double cell_area = change->cell_size_m * change->cell_size_m;
  std::vector<int>& label = change->region;
  label.assign(changed.size(), -1);
  std::vector<MagneticChangeRegion> regions;
  eachComponent(
      w, change->height, [&](std::size_t i) { return changed[i] != 0; },
      [&](const std::vector<std::size_t>& members) {
        MagneticChangeRegion region;
        double delta_sum = 0.0;
        Eigen::Vector2d centre_sum = Eigen::Vector2d::Zero();
        for (const std::size_t at : members) {
          const int ix = static_cast<int>(at % w), iy = static_cast<int>(at / w);
          const double delta = change->delta_uT[at];
          delta_sum += delta;
          region.max_delta_uT = std::max(region.max_delta_uT, delta);
          centre_sum +=
              change->origin_m + change->cell_size_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
        }
        const double cells = static_cast<double>(members.size());
        region.area_m2 = cells * cell_area;
        if (region.area_m2 < config.min_region_area_m2) return;
        region.centroid_m = centre_sum / cells;
        region.mean_delta_uT = delta_sum / cells;
        for (const std::size_t at : members) label[at] = static_cast<int>(regions.size());
        regions.push_back(region);
      });
  // Largest first; the labels follow their regions.
  std::vector<int> order(regions.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::stable_sort(order.begin(), order.end(),
                   [&](int p, int q) { return regions[p].area_m2 > regions[q].area_m2; });
  std::vector<int> rank(regions.size());
  change->regions.clear();
  for (std::size_t k = 0; k < order.size(); ++k) {
    rank[order[k]] = static_cast<int>(k);
    change->regions.push_back(regions[order[k]]);
  }
  for (int& l : label)
    if (l >= 0) l = rank[l];
}

}  // namespace

bool MagneticChangeConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (!(noise_floor_uT >= 0.0) || !std::isfinite(noise_floor_uT))
    return fail("noise_floor_uT must be >= 0 (uT)");
  if (!(min_chi2 > 0.0) || !std::isfinite(min_chi2)) return fail("min_chi2 must be > 0");
  if (!(min_region_area_m2 >= 0.0) || !std::isfinite(min_region_area_m2))
    return fail("min_region_area_m2 must be >= 0 (m^2)");
  if (!(calibration_scale >= 0.0) || !std::isfinite(calibration_scale))
    return fail("calibration_scale must be >= 0");
  return true;
}

MagneticChange magneticChange(const MagneticLayer& a, const MagneticLayer& b,
                              const MagneticChangeConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("magneticChange: " + error);
  checkLayer(a, "a");
  checkLayer(b, "b");
  if (std::abs(a.map.cell_size_m - b.map.cell_size_m) > 1e-9)
    throw std::invalid_argument("magneticChange: layers of different cell sizes");
  MagneticChange change;
  change.origin_m = a.map.origin_m;
  change.cell_size_m = a.map.cell_size_m;
  change.width = a.map.width;
  change.height = a.map.height;
  const std::size_t cells = static_cast<std::size_t>(a.map.width) * a.map.height;
  change.delta_uT.assign(cells, kNaN);
  change.chi2.assign(cells, kNaN);
  std::vector<char> changed(cells, 0);
  const double scale2 = config.calibration_scale * config.calibration_scale;
  const double floor2 =
      config.noise_floor_uT * config.noise_floor_uT +
      scale2 * (a.calibration_uT * a.calibration_uT + b.calibration_uT * b.calibration_uT);
  for (int iy = 0; iy < a.map.height; ++iy)
    for (int ix = 0; ix < a.map.width; ++ix) {
      if (!a.map.covered(ix, iy)) continue;
      const Eigen::Vector2d c = (a.map.cellCentre(ix, iy) - b.map.origin_m) / b.map.cell_size_m;
      const int bx = static_cast<int>(std::floor(c.x())), by = static_cast<int>(std::floor(c.y()));
      if (!b.map.covered(bx, by)) continue;
      const std::size_t i = a.map.index(ix, iy), j = b.map.index(bx, by);
      const double variance = static_cast<double>(a.variance_uT2[i]) + b.variance_uT2[j] + floor2;
      if (!std::isfinite(variance) || variance <= 0.0) continue;
      const double dh = static_cast<double>(b.map.horizontal_uT[j]) - a.map.horizontal_uT[i];
      const double dv = static_cast<double>(b.map.vertical_uT[j]) - a.map.vertical_uT[i];
      const double delta2 = dh * dh + dv * dv;
      change.delta_uT[i] = static_cast<float>(std::sqrt(delta2));
      change.chi2[i] = static_cast<float>(delta2 / variance);
      ++change.compared_cells;
      if (delta2 / variance > config.min_chi2) {
        changed[i] = 1;
        ++change.changed_cells;
      }
    }
  labelRegions(changed, config, &change);
  return change;
}

MagneticMap ChangeMap::deltaMap() const {
  MagneticMap map;
  map.origin_m = origin_m;
  map.cell_size_m = cell_size_m;
  map.width = width;
  map.height = height;
  map.height_m = height_m;
  std::vector<float> values(pairs.size(), kNaN);
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (pairs[i] > 0) values[i] = delta_uT[i];
  map.horizontal_uT = map.vertical_uT = map.session_x_uT = map.session_y_uT = values;
  map.total_uT = std::move(values);
  return map;
}

std::vector<std::uint32_t> placesOfRegions(const ChangeMap& cells, const std::vector<bool>& shown) {
  std::vector<std::uint32_t> label(cells.region.size(), 0);
  eachComponent(
      cells.width, cells.height, [&](std::size_t i) { return cells.region[i] != 0; },
      [&](const std::vector<std::size_t>& members) {
        std::uint32_t first_shown = 0;
        for (const std::size_t at : members) {
          const std::uint32_t number = cells.region[at];
          if (number <= shown.size() && shown[number - 1] &&
              (first_shown == 0 || number < first_shown))
            first_shown = number;
        }
        for (const std::size_t at : members) label[at] = first_shown;
      });
  return label;
}

}  // namespace mm4mm
