#include "mm4mm/merge/field_offsets.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <stdexcept>

namespace mm4mm {
namespace {

double medianOf(std::vector<double>& values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

// Whole cells from `origin` to `to` along one axis; throws unless they are (nearly) whole.
int latticeOffset(double to, double origin, double cell_m) {
  const double cells = (to - origin) / cell_m;
  const double whole = std::round(cells);
  if (std::abs(cells - whole) > 1e-3)
    throw std::invalid_argument("sharedCellDifferences: the layers are not on one grid (origins " +
                                std::to_string(cells - whole) + " cells apart)");
  return static_cast<int>(whole);
}

bool empty(const MagneticLayer& layer) { return layer.map.width <= 0 || layer.map.height <= 0; }

// The least-squares offsets of the linked layers (estimateFieldOffsets): o_a − o_b = −d per pair.
// The minimum-norm solution is orthogonal to the null space, which holds one constant per group
// of linked layers: each group's offsets sum to zero.
void solveDifferences(int n, FieldOffsets* result) {
  const int m = static_cast<int>(result->pairs.size());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(m, n);
  Eigen::MatrixXd rhs(m, 2);
  for (int k = 0; k < m; ++k) {
    const LayerDisagreement& d = result->pairs[k];
    const double w = std::sqrt(static_cast<double>(d.cells));
    A(k, d.a) = w;
    A(k, d.b) = -w;
    rhs(k, 0) = -w * d.horizontal_uT;
    rhs(k, 1) = -w * d.vertical_uT;
  }
  const Eigen::MatrixXd solution = A.completeOrthogonalDecomposition().solve(rhs);
  for (int s = 0; s < n; ++s)
    if (result->linked[s]) result->offsets[s] = {solution(s, 0), solution(s, 1)};
}

// Anchors each group's B_v on what knows it absolutely (see estimateFieldOffsets): the layers
// that observed their own vertical and the Earth's vertical field its layers state, each weighed
// by the inverse of its variance, and says in `result->anchor` how the groups were anchored.
void anchorVertical(const std::vector<MagneticLayer>& layers, const FieldOffsetConfig& config,
                    FieldOffsets* result) {
  const int n = static_cast<int>(layers.size());
  // Groups: connected components of the linked pairs; a layer with no partner is its own.
  std::vector<int> group(n);
  std::iota(group.begin(), group.end(), 0);
  const auto root = [&](int s) {
    while (group[s] != s) s = group[s] = group[group[s]];
    return s;
  };
  for (const LayerDisagreement& d : result->pairs) group[root(d.a)] = root(d.b);
  // An infinite sigma gives a reference no weight.
  const auto weight = [](double sigma) { return std::isinf(sigma) ? 0.0 : 1.0 / (sigma * sigma); };
  const double observed_weight = weight(config.observed_vertical_sigma_uT);
  const double earth_weight = weight(config.earth_vertical_sigma_uT);
  int earth_groups = 0, observed_groups = 0, both_groups = 0, free_groups = 0;
  std::string values;
  for (int g = 0; g < n; ++g) {
    if (root(g) != g) continue;
    double stated = 0.0;
    int statements = 0, observed = 0;
    double observed_shift = 0.0;  // the sum over them of the shift that keeps each one's B_v
    std::vector<double> vertical;
    for (int s = 0; s < n; ++s) {
      if (root(s) != g || empty(layers[s])) continue;
      if (layers[s].earth_vertical_uT) stated += *layers[s].earth_vertical_uT, ++statements;
      if (layers[s].vertical_observed) observed_shift -= result->offsets[s].vertical_uT, ++observed;
      const MagneticMap& m = layers[s].map;
      for (std::size_t i = 0; i < m.vertical_uT.size(); ++i)
        if (!std::isnan(m.total_uT[i]))
          vertical.push_back(m.vertical_uT[i] + result->offsets[s].vertical_uT);
    }
    if (vertical.empty()) continue;
    // A session alone that observed its vertical keeps it (a shift of 0) unless the Earth's field
    // is stated: with nothing to combine it with there is nothing to anchor.
    const double w_observed = observed * observed_weight;
    const double w_earth = statements > 0 ? earth_weight : 0.0;
    if (w_observed + w_earth == 0.0 || (w_earth == 0.0 && !result->linked[g])) {
      free_groups += result->linked[g] ? 1 : 0;
      continue;
    }
    double shift = observed_weight * observed_shift;
    if (w_earth > 0.0) {
      stated /= statements;
      shift += w_earth * (stated - medianOf(vertical));
      char value[32];
      std::snprintf(value, sizeof value, "%.2f", stated);
      if (values.find(value) == std::string::npos)
        values += (values.empty() ? "" : ", ") + std::string(value);
    }
    shift /= w_observed + w_earth;
    for (int s = 0; s < n; ++s)
      if (root(s) == g && !empty(layers[s])) {
        result->offsets[s].vertical_uT += shift;
        result->earth_anchored[s] = w_earth > 0.0;
        result->observed_anchored[s] = w_observed > 0.0;
      }
    if (w_earth > 0.0 && w_observed > 0.0)
      ++both_groups;
    else if (w_earth > 0.0)
      ++earth_groups;
    else
      ++observed_groups;
  }
  std::string anchor;
  const auto add = [&anchor](const std::string& part) {
    anchor += (anchor.empty() ? "" : "; elsewhere ") + part;
  };
  if (earth_groups > 0)
    add("B_v: each group's median put on the Earth's vertical field its sessions state (" + values +
        " uT, " + std::to_string(earth_groups) + " group(s))");
  if (observed_groups > 0)
    add("B_v: each group's offsets shifted so that those of its sessions that observed their own "
        "vertical hard iron (a tilting body) average zero (" +
        std::to_string(observed_groups) + " group(s))");
  if (both_groups > 0) {
    char sigmas[96];
    std::snprintf(sigmas, sizeof sigmas, "%.3g uT for each observing session, %.3g uT",
                  config.observed_vertical_sigma_uT, config.earth_vertical_sigma_uT);
    add("B_v: the sessions that observed their own vertical hard iron and the Earth's vertical "
        "field stated (" +
        values + " uT) combined, weighed by their variances (sigma " + sigmas +
        " for the Earth's, " + std::to_string(both_groups) + " group(s))");
  }
  if (free_groups > 0)
    add("the offsets of the sessions linked by shared cells sum to zero (no session states the "
        "Earth's vertical field: session.yaml earth_field.vertical_uT)");
  if (!anchor.empty() && (earth_groups > 0 || observed_groups > 0 || both_groups > 0))
    anchor += "; B_h: the linked sessions' offsets sum to zero";
  result->anchor =
      anchor.empty() ? "none (no session shares cells or states the Earth's field)" : anchor;
}

}  // namespace

bool FieldOffsetConfig::IsValid(std::string* error) const {
  const auto fail = [error](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (min_shared_cells < 1) return fail("min_shared_cells must be >= 1");
  if (!(observed_vertical_sigma_uT > 0.0))
    return fail("observed_vertical_sigma_uT must be > 0 (uT; .inf: not an anchor)");
  if (!(earth_vertical_sigma_uT > 0.0))
    return fail("earth_vertical_sigma_uT must be > 0 (uT; .inf: not an anchor)");
  return true;
}

std::vector<CellDifference> sharedCellDifferences(const MagneticLayer& a, const MagneticLayer& b) {
  std::vector<CellDifference> differences;
  if (empty(a) || empty(b)) return differences;
  const MagneticMap& ma = a.map;
  const MagneticMap& mb = b.map;
  if (std::abs(ma.cell_size_m - mb.cell_size_m) > 1e-9 * ma.cell_size_m)
    throw std::invalid_argument("sharedCellDifferences: cells of " +
                                std::to_string(ma.cell_size_m) + " m and " +
                                std::to_string(mb.cell_size_m) + " m");
  const int dx = latticeOffset(mb.origin_m.x(), ma.origin_m.x(), ma.cell_size_m);
  const int dy = latticeOffset(mb.origin_m.y(), ma.origin_m.y(), ma.cell_size_m);
  // Only the rectangle both grids span.
  const int x0 = std::max(0, -dx), x1 = std::min(mb.width, ma.width - dx);
  const int y0 = std::max(0, -dy), y1 = std::min(mb.height, ma.height - dy);
  for (int iy = y0; iy < y1; ++iy)
    for (int ix = x0; ix < x1; ++ix) {
      if (!mb.covered(ix, iy) || !ma.covered(ix + dx, iy + dy)) continue;
      const std::size_t i = ma.index(ix + dx, iy + dy), j = mb.index(ix, iy);
      differences.push_back({static_cast<double>(ma.horizontal_uT[i]) - mb.horizontal_uT[j],
                             static_cast<double>(ma.vertical_uT[i]) - mb.vertical_uT[j],
                             static_cast<double>(ma.total_uT[i]) - mb.total_uT[j]});
    }
  return differences;
}

LayerDisagreement layerDisagreement(const MagneticLayer& a, const MagneticLayer& b) {
  const std::vector<CellDifference> differences = sharedCellDifferences(a, b);
  std::vector<double> horizontal, vertical, total;
  for (const CellDifference& d : differences) {
    horizontal.push_back(d.horizontal_uT);
    vertical.push_back(d.vertical_uT);
    total.push_back(d.total_uT);
  }
  LayerDisagreement d;
  d.cells = static_cast<int>(differences.size());
  d.horizontal_uT = medianOf(horizontal);
  d.vertical_uT = medianOf(vertical);
  d.total_uT = medianOf(total);
  return d;
}

FieldOffsets estimateFieldOffsets(const std::vector<MagneticLayer>& layers,
                                  const FieldOffsetConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("FieldOffsetConfig: " + error);
  const int n = static_cast<int>(layers.size());
  FieldOffsets result;
  result.offsets.assign(n, FieldOffset{});
  result.linked.assign(n, false);
  result.earth_anchored.assign(n, false);
  result.observed_anchored.assign(n, false);
  if (!config.enabled) {
    result.anchor = "none (offsets off)";
    return result;
  }
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      LayerDisagreement d = layerDisagreement(layers[a], layers[b]);
      if (d.cells < config.min_shared_cells) continue;
      d.a = a;
      d.b = b;
      result.pairs.push_back(d);
      result.linked[a] = result.linked[b] = true;
    }
  if (!result.pairs.empty()) solveDifferences(n, &result);
  anchorVertical(layers, config, &result);
  return result;
}

MagneticLayer withFieldOffset(MagneticLayer layer, const FieldOffset& offset) {
  MagneticMap& m = layer.map;
  for (std::size_t i = 0; i < m.total_uT.size(); ++i) {
    if (std::isnan(m.total_uT[i])) continue;
    const double h = m.horizontal_uT[i], v = m.vertical_uT[i];
    const double h2 = h + offset.horizontal_uT, v2 = v + offset.vertical_uT;
    m.horizontal_uT[i] = static_cast<float>(h2);
    m.vertical_uT[i] = static_cast<float>(v2);
    m.total_uT[i] = static_cast<float>(m.total_uT[i] + std::hypot(h2, v2) - std::hypot(h, v));
  }
  return layer;
}

FieldOffsets applyFieldOffsets(std::vector<MagneticLayer>& layers,
                               const FieldOffsetConfig& config) {
  FieldOffsets offsets = estimateFieldOffsets(layers, config);
  for (std::size_t i = 0; i < layers.size(); ++i)
    if (offsets.linked[i] || offsets.earth_anchored[i])
      layers[i] = withFieldOffset(std::move(layers[i]), offsets.offsets[i]);
  return offsets;
}

}  // namespace mm4mm
