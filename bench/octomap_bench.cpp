// Atlas export speed on simulated sessions placed at their ground-truth poses: the OctoMap
// (octomap.bt), the merged point cloud with its PLY and PCD files, and the fused magnetic map.
// Usage: octomap_bench [config.yaml] [sessions] [seed] [resolution_m]
//   (defaults: configs/warehouse.yaml if it exists, else the built-in warehouse; 4; 7; 0.1).
// Prints markdown tables; the simulation itself is not timed. The files go to a scratch directory
// that is removed at the end.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <string>
#include <vector>

#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/octomap_io.hpp"
#include "mm4mm/io/ply_io.hpp"
#include "mm4mm/merge/fused_magnetic_map.hpp"
#include "mm4mm/merge/merged_cloud.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Wall and processor time of a piece of work: their ratio shows how many cores it kept busy
// (the machine may be shared, so wall time alone can mislead).
struct Timer {
  Clock::time_point wall = Clock::now();
  std::clock_t cpu = std::clock();
  double wallSeconds() const { return std::chrono::duration<double>(Clock::now() - wall).count(); }
  double cpuSeconds() const { return static_cast<double>(std::clock() - cpu) / CLOCKS_PER_SEC; }
};

double megabytes(const fs::path& file) {
  return static_cast<double>(fs::file_size(file)) / (1024.0 * 1024.0);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string config_path = argc > 1 ? argv[1] : "configs/warehouse.yaml";
  const int count = argc > 2 ? std::atoi(argv[2]) : 4;
  const std::uint64_t seed = argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 7;
  const double resolution = argc > 4 ? std::atof(argv[4]) : 0.1;

  mm4mm::sim::SimulationConfig sim;
  if (fs::exists(config_path)) sim = mm4mm::loadSimulationConfig(config_path);
  std::fprintf(stderr, "simulating %d %s sessions (seed %llu)...\n", count, sim.world.c_str(),
               static_cast<unsigned long long>(seed));
  const std::vector<mm4mm::Session> sessions = mm4mm::sim::simulateSessions(sim, count, seed);
  std::vector<std::vector<Eigen::Isometry3d>> poses;
  std::size_t keyframes = 0, returns = 0;
  for (const mm4mm::Session& s : sessions) {
    poses.emplace_back();
    for (const mm4mm::StampedPose& g : *s.ground_truth) poses.back().push_back(g.T_frame_body);
    keyframes += s.keyframes.size();
    for (const auto& scan : s.scans) returns += scan.size();
  }
  const fs::path dir = fs::temp_directory_path() / ("octomap_bench_" + std::to_string(seed));
  fs::create_directories(dir);

  mm4mm::OctoMapConfig octomap;
  octomap.resolution_m = resolution;
  Timer timer;
  const mm4mm::OctoMapTree tree = mm4mm::buildOctoMap(sessions, poses, octomap);
  mm4mm::writeOctoMap(dir / "octomap.bt", tree);
  const mm4mm::OctoMapStats& stats = tree.stats;
  const double octomap_cpu = timer.cpuSeconds();
  std::printf(
      "| world | sessions | scans | returns | resolution (m) | max range (m) | rays cast | "
      "OctoMap s (wall) | CPU s | nodes | occupied / free leaves | occupied / free m^3 | "
      ".bt MB |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::printf(
      "| %s | %d | %zu | %.1f M | %.2f | %.0f | %.1f M | %.2f | %.2f | %.2f M | %zu k / %zu k "
      "| %.0f / %.0f | %.1f |\n",
      sim.world.c_str(), count, stats.scans, returns / 1e6, resolution, octomap.max_range_m,
      stats.endpoints / 1e6, stats.seconds, octomap_cpu, stats.nodes / 1e6,
      stats.occupied_leaves / 1000, stats.free_leaves / 1000, stats.occupied_volume_m3,
      stats.free_volume_m3, megabytes(dir / "octomap.bt"));

  std::printf("\n| output | wall s | CPU s | size |\n|---|---|---|---|\n");
  timer = Timer();
  const mm4mm::MergedCloud cloud = mm4mm::buildMergedCloud(sessions, poses);
  std::printf(
      "| merged cloud (%.1f M returns, %.2f M session points -> %.2f M points) | %.2f | "
      "%.2f | |\n",
      cloud.input_points / 1e6, cloud.session_points / 1e6, cloud.size() / 1e6, timer.wallSeconds(),
      timer.cpuSeconds());
  timer = Timer();
  mm4mm::writePly(dir / "merged.ply", cloud.points);
  std::printf("| merged.ply | %.2f | %.2f | %.1f MB |\n", timer.wallSeconds(), timer.cpuSeconds(),
              megabytes(dir / "merged.ply"));
  timer = Timer();
  mm4mm::writeMergedCloudPcd(dir / "merged.pcd", cloud);
  std::printf("| merged.pcd | %.2f | %.2f | %.1f MB |\n", timer.wallSeconds(), timer.cpuSeconds(),
              megabytes(dir / "merged.pcd"));
  timer = Timer();
  const mm4mm::FusedMagneticMap fused = mm4mm::fuseMagneticMaps(sessions, poses);
  std::size_t shared = 0;
  for (const auto c : fused.session_count) shared += c > 1;
  std::printf(
      "| fused magnetic map (%zu cells covered, %zu by more than one session) | %.2f | "
      "%.2f | |\n",
      fused.map.coveredCells(), shared, timer.wallSeconds(), timer.cpuSeconds());
  std::printf("\n%zu keyframes in %d sessions\n", keyframes, count);
  fs::remove_all(dir);
  return 0;
}
