#include "mm4mm/core/planar_region.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace mm4mm {
namespace {

// Squared Euclidean distance transform of one line (Felzenszwalb & Huttenlocher 2012): the lower
// envelope of the parabolas (q - p)² + f(p). `v` and `z` are scratch of size n and n + 1.
void distanceTransform1d(const std::vector<double>& f, std::vector<double>* d, std::vector<int>* v,
                         std::vector<double>* z) {
  const int n = static_cast<int>(f.size());
  const auto intersection = [&](int q, int p) {
    return ((f[q] + double(q) * q) - (f[p] + double(p) * p)) / (2.0 * q - 2.0 * p);
  };
  int k = 0;
  (*v)[0] = 0;
  (*z)[0] = -std::numeric_limits<double>::infinity();
  (*z)[1] = std::numeric_limits<double>::infinity();
  for (int q = 1; q < n; ++q) {
    double s = intersection(q, (*v)[k]);
    while (s <= (*z)[k]) s = intersection(q, (*v)[--k]);
    ++k;
    (*v)[k] = q;
    (*z)[k] = s;
    (*z)[k + 1] = std::numeric_limits<double>::infinity();
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while ((*z)[k + 1] < q) ++k;
    const double dq = q - (*v)[k];
    (*d)[q] = dq * dq + f[(*v)[k]];
  }
}

}  // namespace

bool PlanarRegion::contains(const Eigen::Vector2d& p_a) const {
  if (width <= 0 || height <= 0) return false;
  const double fx = std::floor((p_a.x() - origin_m.x()) / cell_size_m);
  const double fy = std::floor((p_a.y() - origin_m.y()) / cell_size_m);
  if (!(fx >= 0.0 && fy >= 0.0 && fx < width && fy < height)) return false;  // NaN: outside
  return inside[static_cast<std::size_t>(fy) * width + static_cast<std::size_t>(fx)] != 0;
}

std::size_t PlanarRegion::insideCells() const {
  return static_cast<std::size_t>(
      std::count_if(inside.begin(), inside.end(), [](std::uint8_t v) { return v != 0; }));
}

PlanarRegion dilateRegion(const PlanarRegion& region, double margin_m) {
  if (!std::isfinite(margin_m) || margin_m < 0.0)
    throw std::invalid_argument("dilateRegion: margin_m must be >= 0 (m) and finite");
  if (!(region.cell_size_m > 0.0) ||
      region.inside.size() != static_cast<std::size_t>(std::max(region.width, 0)) *
                                  static_cast<std::size_t>(std::max(region.height, 0)))
    throw std::invalid_argument("dilateRegion: region's cell size or cell count is inconsistent");
  const double radius_cells = margin_m / region.cell_size_m;
  const int pad = static_cast<int>(std::ceil(radius_cells));
  PlanarRegion grown;
  grown.cell_size_m = region.cell_size_m;
  grown.origin_m = region.origin_m - Eigen::Vector2d::Constant(pad * region.cell_size_m);
  grown.width = region.width + 2 * pad;
  grown.height = region.height + 2 * pad;
  const std::size_t W = grown.width, H = grown.height;
  grown.inside.assign(W * H, 0);
  if (region.width <= 0 || region.height <= 0) return grown;

  // Squared distance (cells²) of every cell centre to the nearest inside cell's centre, by two
  // separable passes; "far" is finite so that the envelope arithmetic stays finite.
  constexpr double kFar = 1e20;
  std::vector<double> distance2(W * H, kFar);
  for (int y = 0; y < region.height; ++y)
    for (int x = 0; x < region.width; ++x)
      if (region.inside[static_cast<std::size_t>(y) * region.width + x] != 0)
        distance2[(y + pad) * W + (x + pad)] = 0.0;
  const std::size_t longest = std::max(W, H);
  std::vector<double> f(longest), d(longest), z(longest + 1);
  std::vector<int> v(longest);
  for (std::size_t x = 0; x < W; ++x) {
    f.resize(H), d.resize(H);
    for (std::size_t y = 0; y < H; ++y) f[y] = distance2[y * W + x];
    distanceTransform1d(f, &d, &v, &z);
    for (std::size_t y = 0; y < H; ++y) distance2[y * W + x] = d[y];
  }
  for (std::size_t y = 0; y < H; ++y) {
    f.assign(distance2.begin() + y * W, distance2.begin() + (y + 1) * W);
    d.resize(W);
    distanceTransform1d(f, &d, &v, &z);
    for (std::size_t x = 0; x < W; ++x)
      grown.inside[y * W + x] = d[x] <= radius_cells * radius_cells + 1e-9;
  }
  return grown;
}

}  // namespace mm4mm
