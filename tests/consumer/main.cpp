// Links the installed library and calls into it: simulates a tiny world and checks one value.
#include <cmath>
#include <cstdio>

#include "mm4mm/magnetic/fingerprint.hpp"
#include "mm4mm/sim/simulator.hpp"

int main() {
  mm4mm::sim::SimulationConfig config;
  config.world = "corridor";
  const mm4mm::sim::SimulatedWorld world(config, 1);
  const Eigen::Vector3d field = world.field.fieldAt(Eigen::Vector3d(20.0, 10.0, 0.3));
  const auto fingerprint = mm4mm::fingerprintOf(Eigen::Matrix3d::Identity(), field);
  std::printf("consumer: |B| = %.2f uT at (20, 10, 0.3)\n", fingerprint.total_uT);
  return std::abs(fingerprint.total_uT - field.norm()) < 1e-9 && field.norm() > 20.0 ? 0 : 1;
}
