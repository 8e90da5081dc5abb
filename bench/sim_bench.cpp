// Simulator speed: ray casting and field evaluation throughput, and whole sessions per preset.
// Usage: sim_bench [seed]. Prints a markdown table.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include "mm4mm/core/timing.hpp"
#include "mm4mm/sim/lidar.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace {

using Clock = mm4mm::SteadyClock;
using mm4mm::secondsSince;

void benchWorld(const std::string& name, int sessions, std::uint64_t seed) {
  using namespace mm4mm::sim;
  SimulationConfig config;
  config.world = name;
  auto start = Clock::now();
  const SimulatedWorld world(config, seed);
  const double build_s = secondsSince(start);

  // One scan's worth of beams from lane nodes, single thread.
  const auto beams = lidarBeamDirections(config.lidar);
  std::mt19937_64 rng(seed);
  start = Clock::now();
  std::size_t rays = 0;
  for (std::size_t i = 0; i < world.world.lanes.nodes.size(); i += 3) {
    const auto& n = world.world.lanes.nodes[i];
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() << n.x(), n.y(), config.rig.lidar_height_m;
    simulateScan(world.raycaster, T, beams, config.lidar, &rng);
    rays += beams.size();
  }
  const double ray_rate = rays / secondsSince(start);

  start = Clock::now();
  std::uniform_real_distribution<double> ux(world.world.floor_xy.min().x(),
                                            world.world.floor_xy.max().x());
  std::uniform_real_distribution<double> uy(world.world.floor_xy.min().y(),
                                            world.world.floor_xy.max().y());
  Eigen::Vector3d sink = Eigen::Vector3d::Zero();
  const int queries = 20000;
  for (int i = 0; i < queries; ++i) sink += world.field.fieldAt({ux(rng), uy(rng), 0.3});
  const double field_rate = queries / secondsSince(start);

  const auto routes = planSessionRoutes(world.world, config, sessions, seed);
  double total_s = 0.0, total_m = 0.0;
  std::size_t points = 0, keyframes = 0;
  for (int k = 0; k < sessions; ++k) {
    start = Clock::now();
    const auto session = simulateSession(world, routes[k], config, "s", deriveSeed(seed, 100 + k));
    total_s += secondsSince(start);
    total_m += routes[k].length();
    keyframes += session.keyframes.size();
    for (const auto& scan : session.scans) points += scan.size();
  }
  std::printf(
      "| %s | %zu solids, %zu dipoles | %.2f | %.2f M rays/s | %.0f k field queries/s | "
      "%d | %.0f | %zu | %.1f M | %.2f |\n",
      name.c_str(), world.world.solids.size(), world.world.dipoles.size(), build_s, ray_rate / 1e6,
      field_rate / 1e3, sessions, total_m / sessions, keyframes / sessions, points / 1e6 / sessions,
      total_s / sessions);
  if (sink.norm() < 0) std::printf("unreachable\n");
}

}  // namespace

int main(int argc, char** argv) {
  const std::uint64_t seed = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 7;
  std::printf(
      "| world | content | build (s) | ray casting (1 thread) | field (1 thread) | sessions | "
      "route (m) | keyframes | points per session | seconds per session (all threads) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  benchWorld("warehouse", 4, seed);
  benchWorld("corridor", 3, seed);
  return 0;
}
