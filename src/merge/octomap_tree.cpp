#include "mm4mm/merge/octomap_tree.hpp"

#include <octomap/OcTree.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "mm4mm/core/timing.hpp"
#include "mm4mm/merge/atlas_poses.hpp"
#include "octomap_grid.hpp"

// Why not octomap::OcTree::insertPointCloud: a warehouse scan crosses about a million voxels
// (400 k distinct ones) at 0.1 m, and OctoMap updates each through a 16-level tree descent and a
// hash set: half a second per scan, ten minutes for four sessions. Here:
//
//  1. Scans are applied in order, each in two parallel passes, returns then rays, into a sparse
//     voxel grid (blocks of 8^3 voxels under superblocks of 8^3 blocks, allocated on first touch)
//     holding OctoMap's log-odds per voxel. A per-voxel stamp of the last scan that updated it
//     gives OctoMap's per-scan rule "one update per voxel and scan, a return wins over a ray"
//     without a hash set, so every voxel sees the clamped sequence of updates OctoMap gives it.
//  2. Rays are traced with OctoMap's own DDA arithmetic (same voxels), and skip the memory of
//     voxels, and whole blocks, that sit at the lower clamping bound, where a miss is a no-op.
//  3. The .bt format stores only the maximum-likelihood tree (OcTree::writeBinary converts and
//     prunes), so the file is encoded straight from the grid's region classes (unknown, free,
//     occupied, mixed), without building octree nodes.
//
// The result is the file OctoMap writes itself, byte for byte (tests/merge_outputs_test.cpp).

namespace mm4mm {

using octomap_detail::castScan;
using octomap_detail::classify;
using octomap_detail::encodeBinaryTree;
using octomap_detail::KeyBox;
using octomap_detail::keyBox;
using octomap_detail::kFirstStamp;
using octomap_detail::kLastStamp;
using octomap_detail::PreparedScan;
using octomap_detail::prepareScan;
using octomap_detail::restartStamps;
using octomap_detail::ScanRef;
using octomap_detail::SensorModel;
using octomap_detail::VoxelGrid;

namespace {

using Clock = SteadyClock;

// octomap::KeyRay holds at most 100000 keys and does not check; a DDA step moves one voxel along
// one axis, so a ray of length L takes at most sqrt(3) L / resolution steps.
constexpr double kMaxRaySteps = 99000.0;

}  // namespace

bool OctoMapConfig::IsValid(std::string* error) const {
  const auto fail = [error](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (!std::isfinite(resolution_m) || resolution_m < 1e-3 || resolution_m > 100.0)
    return fail("resolution_m must be in [0.001, 100] (m)");
  if (!std::isfinite(min_range_m) || min_range_m < 0.0)
    return fail("min_range_m must be >= 0 (m) and finite");
  if (std::isnan(max_range_m) || (max_range_m >= 0.0 && !(max_range_m > min_range_m)))
    return fail("max_range_m must exceed min_range_m, or be negative (no limit)");
  if (!(probability_hit > 0.5 && probability_hit < 1.0))
    return fail("probability_hit must be in (0.5, 1)");
  if (!(probability_miss > 0.0 && probability_miss < 0.5))
    return fail("probability_miss must be in (0, 0.5)");
  if (!(clamping_min > 0.0 && clamping_min < 0.5)) return fail("clamping_min must be in (0, 0.5)");
  if (!(clamping_max > 0.5 && clamping_max < 1.0)) return fail("clamping_max must be in (0.5, 1)");
  return true;
}

OctoMapTree buildOctoMap(const std::vector<Session>& sessions,
                         const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                         const OctoMapConfig& config) {
  const auto start = Clock::now();
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("OctoMapConfig: " + error);
  checkAtlasPoses(sessions, T_atlas_keyframe, "buildOctoMap");

  // The tree supplies OctoMap's key arithmetic and its log-odds constants; it stays empty.
  octomap::OcTree tree(config.resolution_m);
  tree.setProbHit(config.probability_hit);
  tree.setProbMiss(config.probability_miss);
  tree.setClampingThresMin(config.clamping_min);
  tree.setClampingThresMax(config.clamping_max);
  const SensorModel model{tree.getProbHitLog(), tree.getProbMissLog(),
                          tree.getClampingThresMinLog(), tree.getClampingThresMaxLog(),
                          tree.getOccupancyThresLog()};
  // Beyond this a ray would overflow octomap::KeyRay in OctoMap's own insertion (about 5.7 km at
  // 0.1 m); longer rays are clipped there.
  const double longest_ray = kMaxRaySteps * config.resolution_m / std::sqrt(3.0);
  const double max_range =
      config.max_range_m < 0.0 ? longest_ray : std::min(config.max_range_m, longest_ray);

  std::vector<ScanRef> scans;
  for (std::size_t i = 0; i < sessions.size(); ++i)
    for (std::size_t k = 0; k < sessions[i].scans.size(); ++k) scans.push_back({i, k});

  OctoMapTree result;
  result.resolution_m = config.resolution_m;
  OctoMapStats& stats = result.stats;
  std::string& data = result.data;
  KeyBox box = keyBox(tree, sessions, T_atlas_keyframe, scans, config);
  if (!box.empty()) {
    box.pad();
    VoxelGrid grid(box.min, box.max);
    // Scans are prepared in parallel a chunk at a time, to bound memory, then cast in order.
    constexpr std::size_t kChunk = 32;
    std::uint8_t stamp = kLastStamp;
    for (std::size_t begin = 0; begin < scans.size(); begin += kChunk) {
      const std::size_t end = std::min(scans.size(), begin + kChunk);
      std::vector<PreparedScan> prepared(end - begin);
      tbb::parallel_for(begin, end, [&](std::size_t s) {
        const ScanRef& ref = scans[s];
        prepared[s - begin] = prepareScan(tree, sessions[ref.session], ref.keyframe,
                                          T_atlas_keyframe[ref.session][ref.keyframe], config);
      });
      for (const PreparedScan& scan : prepared) {
        if (!scan.valid) continue;
        if (stamp == kLastStamp) {
          restartStamps(&grid);
          stamp = kFirstStamp;
        } else {
          ++stamp;
        }
        castScan(tree, scan, stamp, max_range, model, &grid);
        ++stats.scans;
        stats.endpoints += scan.endpoints.size();
      }
    }
    classify(model, &grid);
    encodeBinaryTree(grid, config.resolution_m, &data, &stats);
  }
  stats.seconds = secondsSince(start);
  return result;
}

}  // namespace mm4mm
