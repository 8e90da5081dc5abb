#pragma once
// Internal to the simulator: random vectors drawn in a fixed order.
//
// The order in which a constructor's arguments are evaluated is unspecified: GCC evaluates them
// last to first, clang first to last, so Vector3d(gauss(rng), gauss(rng), gauss(rng)) simulated
// a different world with each compiler from the same seed. The draws here are sequenced, last
// coordinate first as GCC did, so the worlds (and the figures measured on them) stay as they were.

#include <Eigen/Core>

namespace mm4mm::sim {

template <typename Distribution, typename Engine>
Eigen::Vector2d drawVector2(Distribution& distribution, Engine& rng) {
  const double y = distribution(rng);
  const double x = distribution(rng);
  return {x, y};
}

template <typename Distribution, typename Engine>
Eigen::Vector3d drawVector3(Distribution& distribution, Engine& rng) {
  const double z = distribution(rng);
  const double y = distribution(rng);
  const double x = distribution(rng);
  return {x, y, z};
}

}  // namespace mm4mm::sim
