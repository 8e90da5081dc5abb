// ICP-EM (paper Eq. 7-11) against PCL's Generalized-ICP on the same clouds from the same seeds, in
// one process: wall time, errors against the reference transform, iterations, and how often
// ICP-EM flags the geometry as degenerate. Cases: the real LiDAR pair of koide3/fast_gicp
// (skipped when the shared data is absent), and pairs of simulated sessions' point maps
// (warehouse; corridor with and without pillars), with and without the magnetic overlap region.
// Every method gets the clouds voxelised at 0.25 m; each seed is the reference moved by 0.5 m and
// turned by 3° about a random axis (of frame b). Translation errors are taken at the source
// cloud's centroid. In a corridor without pillars nothing fixes the position along the axis:
// there ICP-EM keeps where the seed puts the overlap (the seed's error along the axis) and says
// so.
//
// GICP also runs on the clouds ICP-EM registers with the overlap region, so that each speed and
// accuracy comparison is on the same input (both cropped or both not).
//
// Usage: icp_bench [--seeds N] [--route M] [--csv FILE]   (defaults: 5 seeds, 150 m routes)
// Prints markdown; --csv writes the same rows unrounded.

// GCC 12 flags Eigen's SSE loads inside PCL's Umeyama (instantiated here by GICP) as out of
// bounds: a known false positive of -Warray-bounds on Eigen's fixed-size vectors.
#pragma GCC diagnostic ignored "-Warray-bounds"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "bench_util.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/geometry/icp_em.hpp"
#include "mm4mm/geometry/point_map.hpp"
#include "mm4mm/io/pcd_io.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/overlap_region.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace {

using namespace mm4mm;
using bench::median;
using bench::parseFlags;
using Clock = std::chrono::steady_clock;
constexpr double kDeg = M_PI / 180.0;
constexpr double kVoxel = 0.25;

struct Run {
  int iterations = -1;  // -1: not reported
  bool converged = false;
  int degenerate = -1;  // 1 or 0; -1: not reported
};

// A registration method: target, source, seed -> estimate (and iterations, converged).
using Method = std::function<Run(const PointCloud&, const PointCloud&, const Eigen::Isometry3d&,
                                 Eigen::Isometry3d*)>;

PointCloud downsampled(const PointCloud& cloud) {
  PointMapConfig config;
  config.voxel_size_m = kVoxel;
  return buildPointMapFromCloud(cloud, config).points;
}

std::vector<Eigen::Isometry3d> perturbedSeeds(const Eigen::Isometry3d& truth, int count) {
  std::mt19937_64 rng(42);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Eigen::Isometry3d> seeds;
  for (int i = 0; i < count; ++i) {
    Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
    delta.translation() = 0.5 * Eigen::Vector3d(g(rng), g(rng), 0.3 * g(rng)).normalized();
    delta.linear() =
        Eigen::AngleAxisd(3.0 * kDeg,
                          Eigen::Vector3d(0.3 * g(rng), 0.3 * g(rng), g(rng)).normalized())
            .matrix();
    seeds.push_back(truth * delta);
  }
  return seeds;
}

Method icpEm(const IcpEmConfig& config, const PlanarRegion* region = nullptr) {
  return [config, region](const PointCloud& target, const PointCloud& source,
                          const Eigen::Isometry3d& seed, Eigen::Isometry3d* estimate) {
    const IcpEmResult result = refineIcpEm(target, source, seed, config, region);
    *estimate = result.T_a_b;
    Run run;
    run.iterations = result.iterations;
    run.converged = result.converged;
    run.degenerate = result.degenerate;
    return run;
  };
}

pcl::PointCloud<pcl::PointXYZ>::Ptr toPcl(const PointCloud& cloud) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr out(new pcl::PointCloud<pcl::PointXYZ>);
  out->reserve(cloud.size());
  for (const Eigen::Vector3f& p : cloud) out->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return out;
}

// PCL's GICP (Segal et al. 2009) with its default 20-neighbour covariances; the conversion to PCL
// clouds is timed too, as the pipeline would have to do it.
Method pclGicp(double max_correspondence_m) {
  return [max_correspondence_m](const PointCloud& target, const PointCloud& source,
                                const Eigen::Isometry3d& seed, Eigen::Isometry3d* estimate) {
    pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
    gicp.setInputTarget(toPcl(target));
    gicp.setInputSource(toPcl(source));
    gicp.setMaxCorrespondenceDistance(max_correspondence_m);
    gicp.setMaximumIterations(64);
    pcl::PointCloud<pcl::PointXYZ> aligned;
    gicp.align(aligned, seed.matrix().cast<float>());
    estimate->matrix() = gicp.getFinalTransformation().cast<double>();
    Run run;
    run.converged = gicp.hasConverged();
    return run;
  };
}

// The same GICP on the clouds ICP-EM registers with the overlap region (overlapInputs, cropped
// at each seed inside the timed call, as ICP-EM does), so the two compare on the same input.
Method pclGicpOnOverlap(double max_correspondence_m, const PlanarRegion* region) {
  const Method gicp = pclGicp(max_correspondence_m);
  return [gicp, region](const PointCloud& target, const PointCloud& source,
                        const Eigen::Isometry3d& seed, Eigen::Isometry3d* estimate) {
    const OverlapInputs inputs = overlapInputs(target, source, seed, *region, IcpEmConfig{});
    return gicp(inputs.target_a, inputs.source_b, seed, estimate);
  };
}

// One row per case and method (--csv), the table's figures unrounded: docs/bench/icp_bench.csv,
// which scripts/bench_tables.py quotes.
std::ofstream* csv_out = nullptr;

// The seed itself, unrefined: the errors every method starts from.
Run seedOnly(const PointCloud&, const PointCloud&, const Eigen::Isometry3d& seed,
             Eigen::Isometry3d* estimate) {
  *estimate = seed;
  return Run{};
}

// Every method runs from every seed; the methods take turns seed by seed, so that load from other
// processes on a shared machine spreads evenly over them. The translation error is measured at
// the source cloud's centroid, ‖T̂ c - T c‖: a session frame's origin may lie far from the
// overlap, and where the geometry leaves a direction open what counts is where the overlap's
// points land, not the origin.
void benchCase(const std::string& name, const PointCloud& target, const PointCloud& source,
               const Eigen::Isometry3d& truth, int seeds,
               std::vector<std::pair<std::string, Method>> methods) {
  methods.insert(methods.begin(), {"seed (no refinement)", seedOnly});
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& p : source) centroid += p.cast<double>();
  centroid /= static_cast<double>(std::max<std::size_t>(source.size(), 1));
  struct Stats {
    std::vector<double> seconds, translation, rotation, iterations;
    int converged = 0, degenerate = 0;
  };
  std::vector<Stats> stats(methods.size());
  for (const Eigen::Isometry3d& seed : perturbedSeeds(truth, seeds)) {
    for (std::size_t m = 0; m < methods.size(); ++m) {
      Eigen::Isometry3d estimate;
      const auto start = Clock::now();
      const Run run = methods[m].second(target, source, seed, &estimate);
      Stats& s = stats[m];
      s.seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
      s.translation.push_back((estimate * centroid - truth * centroid).norm());
      s.rotation.push_back(rotationAngle(estimate.rotation() * truth.rotation().transpose()) /
                           kDeg);
      s.iterations.push_back(run.iterations);
      s.converged += run.converged;
      s.degenerate += run.degenerate;
    }
  }
  for (std::size_t m = 0; m < methods.size(); ++m) {
    const Stats& s = stats[m];
    const bool seed_row = m == 0;
    const std::string iterations =
        s.iterations.front() < 0 ? "-" : std::to_string(static_cast<int>(median(s.iterations)));
    const std::string converged =
        seed_row ? "-" : std::to_string(s.converged) + "/" + std::to_string(seeds);
    const std::string degenerate =
        s.degenerate < 0 ? "-" : std::to_string(s.degenerate) + "/" + std::to_string(seeds);
    char seconds[32] = "-";
    if (!seed_row) std::snprintf(seconds, sizeof seconds, "%.3f", median(s.seconds));
    if (csv_out)
      *csv_out << '"' << name << "\"," << target.size() << ',' << source.size() << ",\""
               << methods[m].first << "\"," << (seed_row ? -1.0 : median(s.seconds)) << ','
               << median(s.translation) << ','
               << *std::max_element(s.translation.begin(), s.translation.end()) << ','
               << median(s.rotation) << ','
               << *std::max_element(s.rotation.begin(), s.rotation.end()) << ','
               << (s.iterations.front() < 0 ? -1 : static_cast<int>(median(s.iterations))) << ','
               << (seed_row ? -1 : s.converged) << ',' << (s.degenerate < 0 ? -1 : s.degenerate)
               << ',' << seeds << '\n';
    std::printf("| %s | %zu / %zu | %s | %s | %.3f / %.3f | %.3f / %.3f | %s | %s | %s |\n",
                name.c_str(), target.size(), source.size(), methods[m].first.c_str(), seconds,
                median(s.translation),
                *std::max_element(s.translation.begin(), s.translation.end()), median(s.rotation),
                *std::max_element(s.rotation.begin(), s.rotation.end()), iterations.c_str(),
                converged.c_str(), degenerate.c_str());
  }
  std::fflush(stdout);
}

Eigen::Isometry3d readMatrix(const std::filesystem::path& file) {
  std::ifstream in(file);
  Eigen::Isometry3d T;
  for (int i = 0; i < 16; ++i) in >> T.matrix()(i / 4, i % 4);
  return T;
}

void benchLidarPair(int seeds) {
  const std::filesystem::path dir =
      std::filesystem::path(MM4MM_SHARED_DATA_DIR) / "koide-gicp-lidar-scan-pair";
  if (!std::filesystem::exists(dir / "fast_gicp" / "251370668.pcd")) {
    std::printf("| koide pair | absent: %s | | | | | | | |\n", dir.c_str());
    return;
  }
  const PointCloud target = downsampled(readPcd(dir / "fast_gicp" / "251370668.pcd"));
  const PointCloud source = downsampled(readPcd(dir / "fast_gicp" / "251371071.pcd"));
  const Eigen::Isometry3d truth = readMatrix(dir / "small_gicp" / "T_target_source.txt");
  IcpEmConfig single;
  single.voxel_sizes_m = {kVoxel};
  benchCase("koide LiDAR pair", target, source, truth, seeds,
            {{"ICP-EM (1, 0.5, 0.25 m)", icpEm(IcpEmConfig{})},
             {"ICP-EM (0.25 m only)", icpEm(single)},
             {"PCL GICP (1 m gate)", pclGicp(1.0)},
             {"PCL GICP (2 m gate)", pclGicp(2.0)}});
}

// Two simulated sessions, each with its keyframes put at their true poses seen from its own
// frame: b's frame is the world moved by a known transform, so the reference is exact and the
// maps are free of drift.
void benchSimulatedPair(const std::string& name, const sim::SimulationConfig& config, int seeds) {
  std::vector<Session> sessions = sim::simulateSessions(config, 2, 3);
  const Eigen::Isometry3d T_a_b = poseFromRpy({3.0, -2.0, 0.0}, 0.0, 0.0, 0.7);
  for (std::size_t s = 0; s < 2; ++s)
    for (std::size_t k = 0; k < sessions[s].keyframes.size(); ++k)
      sessions[s].keyframes[k].T_frame_body =
          (s == 0 ? Eigen::Isometry3d::Identity() : T_a_b.inverse()) *
          (*sessions[s].ground_truth)[k].T_frame_body;
  PointMapConfig map_config;
  map_config.voxel_size_m = kVoxel;
  const PointCloud target = buildVoxelisedPoints(sessions[0], map_config);
  const PointCloud source = buildVoxelisedPoints(sessions[1], map_config);
  const MagneticMap magnetic_a =
      buildMagneticMap(placeFingerprints(sessions[0]), sessions[0].rig, MagneticMapConfig{});
  const MagneticMap magnetic_b =
      buildMagneticMap(placeFingerprints(sessions[1]), sessions[1].rig, MagneticMapConfig{});
  // The region from the first seed, as the pipeline would have it from the magnetic match.
  const PlanarRegion region =
      overlapRegion(magnetic_a, magnetic_b, perturbedSeeds(T_a_b, 1).front(), 8.0);
  benchCase(name, target, source, T_a_b, seeds,
            {{"ICP-EM (1, 0.5, 0.25 m)", icpEm(IcpEmConfig{})},
             {"ICP-EM + overlap region (8 m margin)", icpEm(IcpEmConfig{}, &region)},
             {"PCL GICP (1 m gate)", pclGicp(1.0)},
             {"PCL GICP + overlap region (8 m margin)", pclGicpOnOverlap(1.0, &region)}});
}

// The paper's warehouse set-up (common start, 180° apart).
void benchWarehousePair(int seeds, double route_m) {
  sim::SimulationConfig config;
  config.world = "warehouse";
  config.layout.route_length_m = route_m;
  config.lidar.azimuth_step_deg = 1.0;
  benchSimulatedPair("warehouse maps, " + std::to_string(int(route_m)) + " m routes", config,
                     seeds);
}

// Corridor sessions 32 m apart along it (configs/corridor_small.yaml), with the pillars every
// 8 m and without any: there the overlap region leaves the corridor's axis to the seed.
void benchCorridorPairs(int seeds) {
  sim::SimulationConfig config;
  config.world = "corridor";
  config.lidar.azimuth_step_deg = 1.0;
  config.layout.mode = "windows";
  config.layout.window_spacing_m = 32.0;
  config.layout.window_length_m = 40.0;
  benchSimulatedPair("corridor maps, pillars", config, seeds);
  config.corridor.pillar_free_ranges_m = {{0.0, config.corridor.length_m}};
  benchSimulatedPair("corridor maps, no pillars", config, seeds);
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 5;
  double route_m = 150.0;
  std::string csv_path;
  for (const auto& [flag, value] : parseFlags(argc, argv, {"--seeds", "--route", "--csv"},
                                              "icp_bench [--seeds N] [--route M] [--csv FILE]")) {
    if (flag == "--seeds") seeds = std::max(1, std::stoi(value));
    if (flag == "--route") route_m = std::stod(value);
    if (flag == "--csv") csv_path = value;
  }
  std::ofstream csv;
  if (!csv_path.empty()) {
    csv.open(csv_path);
    csv << "case,target_points,source_points,method,seconds_median,translation_median_m,"
           "translation_max_m,rotation_median_deg,rotation_max_deg,iterations,converged,"
           "degenerate,seeds\n";
    csv_out = &csv;
  }
  std::printf(
      "| case | points (target / source) | method | seconds (median) | translation error at the "
      "source centroid m (median / max) | rotation error deg (median / max) | iterations | "
      "converged | "
      "degenerate |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  benchLidarPair(seeds);
  benchWarehousePair(seeds, route_m);
  benchCorridorPairs(seeds);
  return 0;
}
