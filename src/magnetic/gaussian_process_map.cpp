#include "mm4mm/magnetic/gaussian_process_map.hpp"

#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>

namespace mm4mm {
namespace {

struct Support {
  Eigen::Vector2d position_m = Eigen::Vector2d::Zero();
  MapChannels values = MapChannels::Zero();
};

// One support point per square of `spacing_m`: a robot that stands still or crawls would
// otherwise put hundreds of nearly equal rows into the kernel matrix. Ordered map: the same
// samples give the same support in the same order.
std::vector<Support> averagePerSquare(const std::vector<PlacedFingerprint>& samples,
                                      double spacing_m) {
  std::map<std::pair<long, long>, std::pair<Support, int>> squares;
  for (const auto& s : samples) {
    const Eigen::Vector2d p = s.position_m.head<2>();
    auto& [sum, count] = squares[{static_cast<long>(std::floor(p.x() / spacing_m)),
                                  static_cast<long>(std::floor(p.y() / spacing_m))}];
    sum.position_m += p;
    sum.values += mapChannelsOf(s);
    ++count;
  }
  std::vector<Support> support;
  support.reserve(squares.size());
  for (const auto& [key, entry] : squares)
    support.push_back({entry.first.position_m / entry.second, entry.first.values / entry.second});
  return support;
}

double kernel(const Eigen::Vector2d& a, const Eigen::Vector2d& b, double inv_two_l2) {
  return std::exp(-(a - b).squaredNorm() * inv_two_l2);
}

}  // namespace

bool GaussianProcessMapConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (!(length_scale_m > 0.0)) return fail("length_scale_m must be > 0");
  if (!(noise_ratio > 0.0)) return fail("noise_ratio must be > 0");
  if (!(max_std_ratio > 0.0 && max_std_ratio < 1.0)) return fail("max_std_ratio must be in (0, 1)");
  if (!(tile_size_m > 0.0)) return fail("tile_size_m must be > 0");
  if (!(sample_spacing_m > 0.0)) return fail("sample_spacing_m must be > 0");
  if (max_samples_per_tile < 10) return fail("max_samples_per_tile must be >= 10");
  return true;
}

MagneticMap buildGaussianProcessMap(const std::vector<PlacedFingerprint>& samples,
                                    double cell_size_m, const GaussianProcessMapConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument(error);
  if (!(cell_size_m > 0.0)) throw std::invalid_argument("magnetic map cell size must be > 0");
  const std::vector<Support> support = averagePerSquare(samples, config.sample_spacing_m);
  if (support.empty()) return MagneticMap{};

  MapChannels prior_mean = MapChannels::Zero();
  for (const auto& s : support) prior_mean += s.values;
  prior_mean /= static_cast<double>(support.size());
  const double l = config.length_scale_m;
  const double inv_two_l2 = 0.5 / (l * l);
  // Beyond two length scales a sample explains under 2 % of a cell's variance: no mix of
  // samples there reaches a useful confidence, so those cells are never computed.
  const double cell_reach_m = 2.0 * l;
  // Samples up to three length scales outside a tile still weigh on its cells (kernel 1 %).
  const double support_reach_m = 3.0 * l;

  Eigen::AlignedBox2d bounds;
  double height_sum = 0.0;
  for (const auto& s : support) bounds.extend(s.position_m);
  for (const auto& s : samples) height_sum += s.position_m.z();
  bounds.min().array() -= cell_reach_m + cell_size_m;
  bounds.max().array() += cell_reach_m + cell_size_m;
  // Snapped to the cell grid like the strip maps, so maps of one frame share cell boundaries.
  bounds.min() = (bounds.min() / cell_size_m).array().floor() * cell_size_m;

  MagneticMap map;
  map.cell_size_m = cell_size_m;
  map.origin_m = bounds.min();
  map.width = static_cast<int>(std::ceil(bounds.sizes().x() / cell_size_m)) + 1;
  map.height = static_cast<int>(std::ceil(bounds.sizes().y() / cell_size_m)) + 1;
  map.height_m = height_sum / samples.size();
  const std::size_t cells = static_cast<std::size_t>(map.width) * map.height;
  std::vector<float>* channels[5] = {&map.horizontal_uT, &map.vertical_uT, &map.total_uT,
                                     &map.session_x_uT, &map.session_y_uT};
  for (auto* channel : channels) channel->assign(cells, std::numeric_limits<float>::quiet_NaN());

  std::vector<std::uint8_t> within_reach(cells, 0);
  const int reach_cells = static_cast<int>(std::ceil(cell_reach_m / cell_size_m));
  for (const auto& s : support) {
    const Eigen::Vector2d g = (s.position_m - map.origin_m) / cell_size_m;
    const int cx = static_cast<int>(std::floor(g.x())), cy = static_cast<int>(std::floor(g.y()));
    for (int iy = std::max(0, cy - reach_cells); iy <= std::min(map.height - 1, cy + reach_cells);
         ++iy)
      for (int ix = std::max(0, cx - reach_cells); ix <= std::min(map.width - 1, cx + reach_cells);
           ++ix)
        if ((map.cellCentre(ix, iy) - s.position_m).norm() <= cell_reach_m)
          within_reach[map.index(ix, iy)] = 1;
  }

  const int tile_cells =
      std::max(1, static_cast<int>(std::round(config.tile_size_m / cell_size_m)));
  const int tiles_x = (map.width + tile_cells - 1) / tile_cells;
  const int tiles_y = (map.height + tile_cells - 1) / tile_cells;
  const double max_variance = config.max_std_ratio * config.max_std_ratio;
  // Each tile writes only its own cells: the result does not depend on the thread count.
  tbb::parallel_for(0, tiles_x * tiles_y, [&](int tile) {
    const int x0 = (tile % tiles_x) * tile_cells, y0 = (tile / tiles_x) * tile_cells;
    const int x1 = std::min(map.width, x0 + tile_cells), y1 = std::min(map.height, y0 + tile_cells);
    std::vector<std::size_t> targets;
    for (int iy = y0; iy < y1; ++iy)
      for (int ix = x0; ix < x1; ++ix)
        if (within_reach[map.index(ix, iy)]) targets.push_back(map.index(ix, iy));
    if (targets.empty()) return;

    Eigen::AlignedBox2d reach(map.cellCentre(x0, y0), map.cellCentre(x1 - 1, y1 - 1));
    reach.min().array() -= support_reach_m;
    reach.max().array() += support_reach_m;
    std::vector<int> nearby;
    for (std::size_t i = 0; i < support.size(); ++i)
      if (reach.contains(support[i].position_m)) nearby.push_back(static_cast<int>(i));
    if (nearby.empty()) return;
    if (static_cast<int>(nearby.size()) > config.max_samples_per_tile) {
      std::vector<int> thinned(config.max_samples_per_tile);
      for (int k = 0; k < config.max_samples_per_tile; ++k)
        thinned[k] =
            nearby[static_cast<std::size_t>(k) * nearby.size() / config.max_samples_per_tile];
      nearby.swap(thinned);
    }

    const int n = static_cast<int>(nearby.size());
    Eigen::MatrixXd K(n, n);
    Eigen::MatrixXd Y(n, 5);
    for (int i = 0; i < n; ++i) {
      const Support& si = support[nearby[i]];
      Y.row(i) = (si.values - prior_mean).transpose();
      for (int j = 0; j <= i; ++j)
        K(i, j) = K(j, i) = kernel(si.position_m, support[nearby[j]].position_m, inv_two_l2);
      K(i, i) += config.noise_ratio;
    }
    const Eigen::LLT<Eigen::MatrixXd> llt(K);
    if (llt.info() != Eigen::Success)
      throw std::runtime_error("Gaussian-process map: kernel matrix not positive definite");
    const Eigen::MatrixXd alpha = llt.solve(Y);

    const int m = static_cast<int>(targets.size());
    Eigen::MatrixXd Ks(n, m);
    for (int c = 0; c < m; ++c) {
      const std::size_t cell = targets[c];
      const Eigen::Vector2d p =
          map.cellCentre(static_cast<int>(cell % map.width), static_cast<int>(cell / map.width));
      for (int i = 0; i < n; ++i) Ks(i, c) = kernel(p, support[nearby[i]].position_m, inv_two_l2);
    }
    const Eigen::MatrixXd mean = Ks.transpose() * alpha;
    // Prior variance 1: the kernel is normalised, the noise given relative to it.
    const Eigen::MatrixXd explained = llt.matrixL().solve(Ks);
    for (int c = 0; c < m; ++c) {
      if (1.0 - explained.col(c).squaredNorm() >= max_variance) continue;
      for (int k = 0; k < 5; ++k)
        (*channels[k])[targets[c]] = static_cast<float>(prior_mean[k] + mean(c, k));
    }
  });
  return map;
}

}  // namespace mm4mm
