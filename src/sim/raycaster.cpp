#include "mm4mm/sim/raycaster.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace mm4mm::sim {

Raycaster::Raycaster(const World& world, double cell_size_m)
    : world_(world), cell_size_m_(cell_size_m) {
  Eigen::AlignedBox2d bounds = world.floor_xy;
  for (const Solid& solid : world.solids) bounds.extend(solid.planBounds());
  origin_ = bounds.min();
  nx_ = static_cast<int>(std::ceil(bounds.sizes().x() / cell_size_m_)) + 1;
  ny_ = static_cast<int>(std::ceil(bounds.sizes().y() / cell_size_m_)) + 1;
  cells_.assign(static_cast<std::size_t>(nx_) * ny_, {});
  for (std::size_t i = 0; i < world.solids.size(); ++i) {
    const Eigen::AlignedBox2d box = world.solids[i].planBounds();
    const int x0 = static_cast<int>((box.min().x() - origin_.x()) / cell_size_m_);
    const int y0 = static_cast<int>((box.min().y() - origin_.y()) / cell_size_m_);
    const int x1 = static_cast<int>((box.max().x() - origin_.x()) / cell_size_m_);
    const int y1 = static_cast<int>((box.max().y() - origin_.y()) / cell_size_m_);
    for (int cy = y0; cy <= y1; ++cy)
      for (int cx = x0; cx <= x1; ++cx)
        cells_[static_cast<std::size_t>(cy) * nx_ + cx].push_back(static_cast<int>(i));
  }
}

std::optional<double> Raycaster::cast(const Eigen::Vector3d& origin,
                                      const Eigen::Vector3d& direction, double max_range_m) const {
  // Floor and ceiling are unbounded planes (walls close the world), so they cap the walk.
  double t_limit = max_range_m;
  bool limit_is_surface = false;
  if (direction.z() < -1e-12) {
    const double t = -origin.z() / direction.z();
    if (t < t_limit) t_limit = t, limit_is_surface = true;
  } else if (direction.z() > 1e-12) {
    const double t = (world_.ceiling_height_m - origin.z()) / direction.z();
    if (t < t_limit) t_limit = t, limit_is_surface = true;
  }

  const Eigen::Vector2d start = (origin.head<2>() - origin_) / cell_size_m_;
  int cx = static_cast<int>(std::floor(start.x()));
  int cy = static_cast<int>(std::floor(start.y()));
  const int step_x = direction.x() >= 0.0 ? 1 : -1;
  const int step_y = direction.y() >= 0.0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  // Ray parameter at which the walk crosses the next cell boundary in x and in y.
  const double delta_x =
      std::abs(direction.x()) > 1e-12 ? cell_size_m_ / std::abs(direction.x()) : inf;
  const double delta_y =
      std::abs(direction.y()) > 1e-12 ? cell_size_m_ / std::abs(direction.y()) : inf;
  double next_x = std::abs(direction.x()) > 1e-12
                      ? ((step_x > 0 ? cx + 1 - start.x() : start.x() - cx) * delta_x)
                      : inf;
  double next_y = std::abs(direction.y()) > 1e-12
                      ? ((step_y > 0 ? cy + 1 - start.y() : start.y() - cy) * delta_y)
                      : inf;

  double best = inf;
  double cell_entry = 0.0;
  while (cell_entry <= t_limit && cell_entry < best) {
    if (cx < 0 || cy < 0 || cx >= nx_ || cy >= ny_) break;
    for (int index : cell(cx, cy)) {
      const double t =
          world_.solids[index].intersect(origin, direction, 0.0, std::min(best, t_limit));
      if (t >= 0.0 && t < best) best = t;
    }
    if (next_x < next_y) {
      cell_entry = next_x;
      next_x += delta_x;
      cx += step_x;
    } else {
      cell_entry = next_y;
      next_y += delta_y;
      cy += step_y;
    }
  }
  if (best <= t_limit) return best;
  if (limit_is_surface) return t_limit;
  return std::nullopt;
}

double Raycaster::clearance(const Eigen::Vector2d& point, double z_min_m, double z_max_m,
                            double search_radius_m) const {
  double best = search_radius_m;
  const Eigen::Vector2d lo = (point - origin_).array() - search_radius_m;
  const Eigen::Vector2d hi = (point - origin_).array() + search_radius_m;
  const int x0 = std::max(0, static_cast<int>(lo.x() / cell_size_m_));
  const int y0 = std::max(0, static_cast<int>(lo.y() / cell_size_m_));
  const int x1 = std::min(nx_ - 1, static_cast<int>(hi.x() / cell_size_m_));
  const int y1 = std::min(ny_ - 1, static_cast<int>(hi.y() / cell_size_m_));
  for (int cy = y0; cy <= y1; ++cy)
    for (int cx = x0; cx <= x1; ++cx)
      for (int index : cell(cx, cy)) {
        const Solid& solid = world_.solids[index];
        if (solid.z_max_m < z_min_m || solid.z_min_m > z_max_m) continue;
        best = std::min(best, solid.planDistance(point));
      }
  return best;
}

}  // namespace mm4mm::sim
