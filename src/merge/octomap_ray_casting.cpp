// Ray casting for buildOctoMap: the scans' returns and rays into the voxel grid, each voxel
// getting the clamped sequence of log-odds updates OctoMap's own insertion gives it.

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "octomap_grid.hpp"

namespace mm4mm::octomap_detail {
namespace {

octomap::point3d toPoint3d(const Eigen::Vector3d& p) {
  return octomap::point3d(static_cast<float>(p.x()), static_cast<float>(p.y()),
                          static_cast<float>(p.z()));
}

std::uint64_t packKey(const OcTreeKey& key) {
  return std::uint64_t{key[0]} | (std::uint64_t{key[1]} << 16) | (std::uint64_t{key[2]} << 32);
}

OcTreeKey unpackKey(std::uint64_t packed) {
  return OcTreeKey(static_cast<octomap::key_type>(packed & 0xffff),
                   static_cast<octomap::key_type>((packed >> 16) & 0xffff),
                   static_cast<octomap::key_type>((packed >> 32) & 0xffff));
}

// Calls `visit(key)` for every return of one keyframe scan that passes the range filter and
// falls inside OctoMap's key range; gives the sensor origin through `origin`. False when the
// origin itself lies outside the key range (the scan is then skipped).
template <typename Visit>
bool forEachReturn(const octomap::OcTree& tree, const Session& session, std::size_t keyframe,
                   const Eigen::Isometry3d& T_atlas_body, const OctoMapConfig& config,
                   octomap::point3d* origin, Visit&& visit) {
  *origin = toPoint3d(T_atlas_body * session.rig.T_body_lidar.translation());
  OcTreeKey key;
  if (!tree.coordToKeyChecked(*origin, key)) return false;
  const Eigen::Vector3f lidar_body = session.rig.T_body_lidar.translation().cast<float>();
  const float min_range2 = static_cast<float>(config.min_range_m * config.min_range_m);
  for (const Eigen::Vector3f& p_body : session.scans[keyframe]) {
    if (!p_body.allFinite() || (p_body - lidar_body).squaredNorm() < min_range2) continue;
    // In double, as the scan's returns would be transformed before octomap::insertPointCloud.
    if (tree.coordToKeyChecked(toPoint3d(T_atlas_body * p_body.cast<double>()), key)) visit(key);
  }
  return true;
}

}  // namespace

KeyBox keyBox(const octomap::OcTree& tree, const std::vector<Session>& sessions,
              const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
              const std::vector<ScanRef>& scans, const OctoMapConfig& config) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, scans.size(), 4), KeyBox{},
      [&](const tbb::blocked_range<std::size_t>& range, KeyBox box) {
        for (std::size_t s = range.begin(); s != range.end(); ++s) {
          const ScanRef& ref = scans[s];
          octomap::point3d origin;
          if (forEachReturn(tree, sessions[ref.session], ref.keyframe,
                            T_atlas_keyframe[ref.session][ref.keyframe], config, &origin,
                            [&box](const OcTreeKey& key) { box.extend(key); }))
            box.extend(tree.coordToKey(origin));
        }
        return box;
      },
      [](KeyBox a, const KeyBox& b) {
        a.extend(b);
        return a;
      });
}

PreparedScan prepareScan(const octomap::OcTree& tree, const Session& session, std::size_t keyframe,
                         const Eigen::Isometry3d& T_atlas_body, const OctoMapConfig& config) {
  PreparedScan scan;
  std::vector<std::uint64_t> keys;
  keys.reserve(session.scans[keyframe].size());
  scan.valid = forEachReturn(tree, session, keyframe, T_atlas_body, config, &scan.origin,
                             [&keys](const OcTreeKey& key) { keys.push_back(packKey(key)); });
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  // Rays in angular order (a Morton curve over azimuth and elevation in 0.5 degree steps): rays
  // cast one after another then cross neighbouring voxels, which are still in cache.
  std::vector<std::pair<std::uint32_t, octomap::point3d>> rays;
  rays.reserve(keys.size());
  constexpr double kStep = 0.5 * M_PI / 180.0;
  for (const std::uint64_t packed : keys) {
    const octomap::point3d p = tree.keyToCoord(unpackKey(packed));
    const octomap::point3d d = p - scan.origin;
    const auto azimuth = static_cast<std::uint32_t>((std::atan2(d.y(), d.x()) + M_PI) / kStep);
    const auto elevation =
        static_cast<std::uint32_t>((std::atan2(d.z(), std::hypot(d.x(), d.y())) + M_PI) / kStep);
    std::uint32_t code = 0;
    for (int b = 0; b < 11; ++b)
      code |= ((azimuth >> b) & 1u) << (2 * b) | ((elevation >> b) & 1u) << (2 * b + 1);
    rays.emplace_back(code, p);
  }
  std::stable_sort(rays.begin(), rays.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  scan.endpoints.reserve(rays.size());
  for (const auto& ray : rays) scan.endpoints.push_back(ray.second);
  return scan;
}

namespace {

// Marks a return's voxel occupied in this scan. Returns are distinct voxels, so no two threads
// update the same one.
void applyHit(const std::array<int, 3>& v, std::uint8_t stamp, const SensorModel& model,
              VoxelGrid* grid) {
  if (!grid->contains(v)) return;
  Block* block = grid->block(v);
  const int index = VoxelGrid::voxelIndex(v);
  // A hit lifts the log-odds off the lower bound.
  if ((block->state[index].load(std::memory_order_relaxed) & kClampedFree) != 0)
    block->clamped_free.fetch_sub(1, std::memory_order_relaxed);
  block->log_odds[index] = model.update(block->log_odds[index], true);
  block->state[index].store(stamp, std::memory_order_relaxed);
}

// Applies a ray's miss to voxel `index` of `block`, once per scan: the thread that stamps the
// voxel with this scan owns its update.
inline void applyMiss(Block* block, int index, std::uint8_t stamp, const SensorModel& model) {
  std::atomic<std::uint8_t>& state = block->state[index];
  std::uint8_t seen = state.load(std::memory_order_relaxed);
  // A miss leaves a voxel at the lower bound unchanged, so it needs no stamp either: the scan's
  // returns were applied before any ray. Most rays run through such voxels.
  if ((seen & kClampedFree) != 0 || (seen & kStampMask) == stamp) return;
  // A failed exchange means another ray got there first.
  if (!state.compare_exchange_strong(seen, stamp, std::memory_order_relaxed)) return;
  const float log_odds = model.update(block->log_odds[index], false);
  block->log_odds[index] = log_odds;
  if (log_odds == model.clamp_min) {
    state.store(kClampedFree | stamp, std::memory_order_relaxed);
    block->clamped_free.fetch_add(1, std::memory_order_relaxed);
  }
}

// Morton offsets of a coordinate within a block: bit i of x goes to bit 3i.
constexpr std::array<int, kBlockEdge> kSpread{0, 1, 8, 9, 64, 65, 72, 73};

// The free voxels of one ray, as OcTreeBaseImpl::computeRayKeys finds them: Amanatides and Woo's
// 3D DDA with OctoMap's initialisation, tie-breaking and stopping rule, in the same float and
// double arithmetic, so it visits exactly the same voxels, from the origin's up to, not
// including, the end's. Each gets a miss. This loop is where the export spends its time: it
// keeps the DDA's state in registers and looks a block up only when the ray enters a new one.
void castRay(const octomap::OcTree& tree, const octomap::point3d& origin,
             const octomap::point3d& end, std::uint8_t stamp, const SensorModel& model,
             VoxelGrid* grid) {
  OcTreeKey key, key_end;
  if (!tree.coordToKeyChecked(origin, key) || !tree.coordToKeyChecked(end, key_end)) return;
  if (key == key_end) return;
  octomap::point3d direction = end - origin;
  const float length = static_cast<float>(direction.norm());
  direction /= length;
  const double resolution = tree.getResolution();
  std::array<int, 3> step{};
  std::array<double, 3> t_max{}, t_delta{};
  for (int i = 0; i < 3; ++i) {
    step[i] = direction(i) > 0.0 ? 1 : direction(i) < 0.0 ? -1 : 0;
    if (step[i] == 0) {
      t_max[i] = t_delta[i] = std::numeric_limits<double>::max();
      continue;
    }
    double border = tree.keyToCoord(key[i]);  // the voxel's centre, then its exit face
    border += static_cast<float>(step[i] * resolution * 0.5);
    t_max[i] = (border - origin(i)) / direction(i);
    t_delta[i] = resolution / std::fabs(direction(i));
  }
  double tx = t_max[0], ty = t_max[1], tz = t_max[2];
  const double dx = t_delta[0], dy = t_delta[1], dz = t_delta[2];
  // Voxel coordinates relative to the grid.
  const std::array<int, 3>& g = grid->origin();
  int x = key[0] - g[0], y = key[1] - g[1], z = key[2] - g[2];
  const int ex = key_end[0] - g[0], ey = key_end[1] - g[1], ez = key_end[2] - g[2];

  Block* block = nullptr;  // the block holding (x, y, z); null outside the grid or when skipped
  const auto enter = [&] {
    const std::array<int, 3> v{x, y, z};
    block = grid->contains(v) ? grid->block(v) : nullptr;
    // With every voxel at the lower bound, misses change nothing in the block.
    if (block != nullptr && block->clamped_free.load(std::memory_order_relaxed) == kBlockVoxels)
      block = nullptr;
  };
  const auto visit = [&] {
    if (block != nullptr)
      applyMiss(block, kSpread[x & 7] | (kSpread[y & 7] << 1) | (kSpread[z & 7] << 2), stamp,
                model);
  };
  enter();
  visit();
  while (true) {
    // OctoMap's choice: x if t_x < t_y and t_x < t_z, else y if t_y < t_z, else z.
    const bool x_first = tx < ty;
    const bool along_x = x_first & (tx < tz);
    const bool along_y = !x_first & (ty < tz);
    const bool along_z = !(along_x | along_y);
    const int px = x, py = y, pz = z;
    x += along_x ? step[0] : 0;
    y += along_y ? step[1] : 0;
    z += along_z ? step[2] : 0;
    tx += along_x ? dx : 0.0;  // adding 0 leaves the other two exact
    ty += along_y ? dy : 0.0;
    tz += along_z ? dz : 0.0;
    if (x == ex && y == ey && z == ez) return;
    // Past the end point without entering its voxel: rounding; OctoMap stops here too.
    if (std::min(std::min(tx, ty), tz) > length) return;
    if (((x ^ px) | (y ^ py) | (z ^ pz)) >> kBlockBits) enter();
    visit();
  }
}

}  // namespace

void castScan(const octomap::OcTree& tree, const PreparedScan& scan, std::uint8_t stamp,
              double max_range, const SensorModel& model, VoxelGrid* grid) {
  const octomap::point3d& origin = scan.origin;
  const auto within = [&](const octomap::point3d& p) { return (p - origin).norm() <= max_range; };
  const std::size_t n = scan.endpoints.size();
  // Returns first, so that rays of the same scan see their stamps.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 2048),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i)
                        if (within(scan.endpoints[i]))
                          applyHit(grid->local(tree.coordToKey(scan.endpoints[i])), stamp, model,
                                   grid);
                    });
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, n, 64), [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const octomap::point3d& p = scan.endpoints[i];
          castRay(
              tree, origin,
              within(p) ? p : origin + (p - origin).normalized() * static_cast<float>(max_range),
              stamp, model, grid);
        }
      });
}

void restartStamps(VoxelGrid* grid) {
  tbb::parallel_for(std::size_t{0}, grid->superblockCount(), [&](std::size_t s) {
    Superblock* super = grid->superblockAt(s);
    if (super == nullptr) return;
    for (auto& slot : super->blocks) {
      Block* block = slot.load(std::memory_order_acquire);
      if (block == nullptr) continue;
      for (auto& state : block->state) {
        const std::uint8_t value = state.load(std::memory_order_relaxed);
        if ((value & kStampMask) != 0)
          state.store((value & kClampedFree) | kSeenBefore, std::memory_order_relaxed);
      }
    }
  });
}

}  // namespace mm4mm::octomap_detail
