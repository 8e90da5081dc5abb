#include "mm4mm/merge/octomap_tree.hpp"

#include <octomap/OcTree.h>
#include <sys/mman.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "mm4mm/atlas/atlas_poses.hpp"
#include "mm4mm/core/timing.hpp"

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
namespace {

using octomap::OcTreeKey;
using Clock = SteadyClock;

constexpr int kTreeDepth = 16;
constexpr int kBlockBits = 3;  // a block is 8^3 voxels: an octree node at depth 13
constexpr int kBlockEdge = 1 << kBlockBits;
constexpr int kBlockVoxels = kBlockEdge * kBlockEdge * kBlockEdge;
constexpr int kSuperBits = 3;  // a superblock is 8^3 blocks (64^3 voxels): depth 10
constexpr int kSuperVoxelBits = kBlockBits + kSuperBits;
constexpr int kSuperDepth = kTreeDepth - kSuperVoxelBits;
constexpr int kBlockDepth = kTreeDepth - kBlockBits;
constexpr int kSuperBlocks = 1 << (3 * kSuperBits);
// octomap::KeyRay holds at most 100000 keys and does not check; a DDA step moves one voxel along
// one axis, so a ray of length L takes at most sqrt(3) L / resolution steps.
constexpr double kMaxRaySteps = 99000.0;

// The class of an octree region in the pruned maximum-likelihood tree.
enum Class : std::uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2, kMixed = 3 };

// A region is a leaf when its 8 octants are known and alike; unknown when all are unknown.
Class combine(const std::array<Class, 8>& octants) {
  bool any_known = false, uniform = octants[0] == kFree || octants[0] == kOccupied;
  for (const Class c : octants) {
    any_known = any_known || c != kUnknown;
    uniform = uniform && c == octants[0];
  }
  if (uniform) return octants[0];
  return any_known ? kMixed : kUnknown;
}

// Index in a cube of 2^bits cells per edge, x fastest: for bits = 1 it is OctoMap's child index.
inline int cubeIndex(int x, int y, int z, int bits) { return (z << (2 * bits)) | (y << bits) | x; }

// Start (in voxels) of octant `child` of a region `size` voxels wide starting at `corner`.
std::array<int, 3> octantCorner(const std::array<int, 3>& corner, int size, int child) {
  const int half = size / 2;
  return {corner[0] + (child & 1) * half, corner[1] + ((child >> 1) & 1) * half,
          corner[2] + ((child >> 2) & 1) * half};
}

// Fills the coarser levels of a class pyramid over a cube of 2^kLevels cells per edge, stored
// coarse to fine: [0] the cube, then its 2^3 octants, 4^3, ..., the finest level last (each level
// in cubeIndex order). The finest level must be filled already.
template <int kLevels, std::size_t kSize>
void fillPyramid(std::array<Class, kSize>* classes) {
  std::size_t fine_offset = kSize - (std::size_t{1} << (3 * kLevels));
  for (int level = kLevels - 1; level >= 0; --level) {
    const int edge = 1 << level;
    const std::size_t offset = fine_offset - (std::size_t{1} << (3 * level));
    for (int z = 0; z < edge; ++z)
      for (int y = 0; y < edge; ++y)
        for (int x = 0; x < edge; ++x) {
          std::array<Class, 8> octants;
          for (int i = 0; i < 8; ++i)
            octants[i] = (*classes)[fine_offset + cubeIndex(2 * x + (i & 1), 2 * y + ((i >> 1) & 1),
                                                            2 * z + ((i >> 2) & 1), level + 1)];
          (*classes)[offset + cubeIndex(x, y, z, level)] = combine(octants);
        }
    fine_offset = offset;
  }
}

// Per voxel, a byte of bookkeeping and the log-odds, in two arrays of its block, both in Morton
// order. Ray casting is bound by memory: a ray reads the byte of every voxel it crosses, and a
// 64-byte line of bytes covers a 4x4x4 cube, shared by the neighbouring rays cast next; the float
// is touched only by the first ray of a scan that reaches the voxel, and not at all while it sits
// at the lower clamping bound, as free space seen a few times does. The byte: bits 0-6 a stamp
// (0: never observed; 1: observed before the current cycle of stamps; 2-127: the scan of this
// cycle that last updated it), bit 7 set while the log-odds equal the lower clamping bound.
constexpr std::uint8_t kStampMask = 0x7f;
constexpr std::uint8_t kClampedFree = 0x80;
constexpr std::uint8_t kSeenBefore = 1;
constexpr std::uint8_t kFirstStamp = 2;
constexpr std::uint8_t kLastStamp = 127;

// Spreads the 3 bits of `i` to bits 0, 3 and 6.
constexpr int spreadBits(int i) { return (i & 1) | ((i & 2) << 2) | ((i & 4) << 4); }

inline int mortonIndex(int x, int y, int z) {
  return spreadBits(x) | (spreadBits(y) << 1) | (spreadBits(z) << 2);
}

struct alignas(64) Block {
  std::array<std::atomic<std::uint8_t>, kBlockVoxels> state;
  std::array<float, kBlockVoxels> log_odds;
  // Voxels at the lower clamping bound. When all are, a ray crossing the block changes nothing
  // in it and skips its memory altogether (aisle air, once seen a few times).
  std::atomic<int> clamped_free;

  Block() {
    for (auto& s : state) s.store(0, std::memory_order_relaxed);
    log_odds.fill(0.0f);
    clamped_free.store(0, std::memory_order_relaxed);
  }
};

// Region classes of a block, filled after ray casting: the block, its 2^3 octants, 4^3, then
// the 8^3 voxels (each level in cubeIndex order).
using BlockClasses = std::array<Class, 1 + 8 + 64 + kBlockVoxels>;

struct Superblock {
  std::array<std::atomic<Block*>, kSuperBlocks> blocks;
  std::array<std::unique_ptr<BlockClasses>, kSuperBlocks> block_classes;
  // Region classes: the superblock, its 2^3 octants (32^3 voxels), 4^3 (16^3), 8^3 (blocks).
  std::array<Class, 1 + 8 + 64 + kSuperBlocks> classes;

  Superblock() {
    for (auto& b : blocks) b.store(nullptr, std::memory_order_relaxed);
    classes.fill(kUnknown);
  }
  Superblock(const Superblock&) = delete;
  Superblock& operator=(const Superblock&) = delete;
};

// Allocates `*slot` on first use; safe when threads race for the same slot.
template <typename T>
T* getOrCreate(std::atomic<T*>* slot) {
  T* existing = slot->load(std::memory_order_acquire);
  if (existing != nullptr) return existing;
  auto fresh = std::make_unique<T>();
  if (slot->compare_exchange_strong(existing, fresh.get(), std::memory_order_acq_rel))
    return fresh.release();
  return existing;  // another thread won; `fresh` is freed
}

// Blocks come from 2 MB chunks marked for transparent huge pages: a ray enters a new block every
// few voxels, and with a 4 kB page per block the TLB misses (costly in virtual machines) would
// dominate ray casting. Blocks are freed with their arena.
class BlockArena {
 public:
  BlockArena() = default;
  BlockArena(const BlockArena&) = delete;
  BlockArena& operator=(const BlockArena&) = delete;
  ~BlockArena() {
    for (void* chunk : chunks_) std::free(chunk);
  }

  Block* allocate() {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (chunks_.empty() || used_ == kBlocksPerChunk) {
      void* chunk = std::aligned_alloc(kChunkBytes, kChunkBytes);
      if (chunk == nullptr) throw std::bad_alloc();
      ::madvise(chunk, kChunkBytes, MADV_HUGEPAGE);  // a hint; fine if refused
      chunks_.push_back(chunk);
      used_ = 0;
    }
    return new (static_cast<char*>(chunks_.back()) + sizeof(Block) * used_++) Block();
  }

 private:
  static constexpr std::size_t kChunkBytes = std::size_t{2} << 20;
  static constexpr std::size_t kBlocksPerChunk = kChunkBytes / sizeof(Block);
  static_assert(std::is_trivially_destructible_v<Block>, "blocks are freed with their chunk");

  std::mutex mutex_;
  std::vector<void*> chunks_;
  std::size_t used_ = 0;
};

// A sparse grid of voxels over a box of OctoMap keys; the box starts on a superblock boundary.
class VoxelGrid {
 public:
  VoxelGrid(const std::array<int, 3>& key_min, const std::array<int, 3>& key_max) {
    for (int a = 0; a < 3; ++a) {
      origin_[a] = (key_min[a] >> kSuperVoxelBits) << kSuperVoxelBits;
      dims_[a] = ((key_max[a] - origin_[a]) >> kSuperVoxelBits) + 1;
      count_ *= static_cast<std::size_t>(dims_[a]);
    }
    supers_ = std::make_unique<std::atomic<Superblock*>[]>(count_);
    for (std::size_t i = 0; i < count_; ++i) supers_[i].store(nullptr, std::memory_order_relaxed);
  }
  VoxelGrid(const VoxelGrid&) = delete;
  VoxelGrid& operator=(const VoxelGrid&) = delete;
  ~VoxelGrid() {
    for (std::size_t i = 0; i < count_; ++i) delete supers_[i].load(std::memory_order_relaxed);
  }

  // Voxel coordinates of `key` relative to the grid's first voxel.
  std::array<int, 3> local(const OcTreeKey& key) const {
    return {key[0] - origin_[0], key[1] - origin_[1], key[2] - origin_[2]};
  }

  bool contains(const std::array<int, 3>& v) const {
    for (int a = 0; a < 3; ++a)
      if (v[a] < 0 || (v[a] >> kSuperVoxelBits) >= dims_[a]) return false;
    return true;
  }

  // The block holding local voxel `v` (which must be inside the grid), created if needed.
  Block* block(const std::array<int, 3>& v) {
    Superblock* super = getOrCreate(&supers_[superIndex(
        v[0] >> kSuperVoxelBits, v[1] >> kSuperVoxelBits, v[2] >> kSuperVoxelBits)]);
    constexpr int kMask = (1 << kSuperBits) - 1;
    std::atomic<Block*>& slot =
        super->blocks[cubeIndex((v[0] >> kBlockBits) & kMask, (v[1] >> kBlockBits) & kMask,
                                (v[2] >> kBlockBits) & kMask, kSuperBits)];
    Block* existing = slot.load(std::memory_order_acquire);
    if (existing != nullptr) return existing;
    Block* fresh = arena_.allocate();
    if (slot.compare_exchange_strong(existing, fresh, std::memory_order_acq_rel)) return fresh;
    return existing;  // another thread won the race; `fresh` stays unused in the arena
  }

  static int voxelIndex(const std::array<int, 3>& v) {
    constexpr int kMask = kBlockEdge - 1;
    return mortonIndex(v[0] & kMask, v[1] & kMask, v[2] & kMask);
  }

  // The superblock at superblock coordinates (sx, sy, sz), or null outside the grid or unused.
  Superblock* superblock(int sx, int sy, int sz) const {
    if (sx < 0 || sy < 0 || sz < 0 || sx >= dims_[0] || sy >= dims_[1] || sz >= dims_[2])
      return nullptr;
    return supers_[superIndex(sx, sy, sz)].load(std::memory_order_acquire);
  }

  std::size_t superblockCount() const { return count_; }
  Superblock* superblockAt(std::size_t i) const {
    return supers_[i].load(std::memory_order_acquire);
  }
  const std::array<int, 3>& origin() const { return origin_; }
  const std::array<int, 3>& dims() const { return dims_; }

 private:
  std::size_t superIndex(int sx, int sy, int sz) const {
    return (static_cast<std::size_t>(sz) * dims_[1] + sy) * dims_[0] + sx;
  }

  std::array<int, 3> origin_{};  // key of the grid's first voxel, a multiple of 64
  std::array<int, 3> dims_{};    // superblocks along each axis
  std::size_t count_ = 1;
  std::unique_ptr<std::atomic<Superblock*>[]> supers_;
  BlockArena arena_;
};

// OctoMap's update of one voxel (OccupancyOcTreeBase::updateNodeLogOdds), in float like it.
struct SensorModel {
  float hit, miss, clamp_min, clamp_max, occupied_threshold;

  float update(float value, bool occupied) const {
    value += occupied ? hit : miss;
    if (value < clamp_min) return clamp_min;
    if (value > clamp_max) return clamp_max;
    return value;
  }
};

struct ScanRef {
  std::size_t session = 0, keyframe = 0;
};

// One keyframe scan ready for ray casting (OctoMap's computeDiscreteUpdate): the sensor origin
// and the voxel centres of its returns, each voxel once, in the atlas frame.
struct PreparedScan {
  octomap::point3d origin;
  bool valid = false;  // origin inside OctoMap's key range
  std::vector<octomap::point3d> endpoints;
};

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

// Key range of everything the rays touch: the sensor origins and the kept returns (a ray
// clipped at max range ends on its segment, so inside this box too).
struct KeyBox {
  std::array<int, 3> min{65535, 65535, 65535}, max{0, 0, 0};
  bool empty() const { return min[0] > max[0]; }
  void extend(const OcTreeKey& key) {
    for (int a = 0; a < 3; ++a) {
      min[a] = std::min<int>(min[a], key[a]);
      max[a] = std::max<int>(max[a], key[a]);
    }
  }
  // One voxel more on every side: rounding can let a ray's DDA step one voxel past its end.
  void pad() {
    for (int a = 0; a < 3; ++a) {
      min[a] = std::max(0, min[a] - 1);
      max[a] = std::min(65535, max[a] + 1);
    }
  }
  void extend(const KeyBox& other) {
    if (other.empty()) return;
    for (int a = 0; a < 3; ++a)
      min[a] = std::min(min[a], other.min[a]), max[a] = std::max(max[a], other.max[a]);
  }
};

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

// One scan into the grid, as OccupancyOcTreeBase::computeUpdate and insertPointCloud do it: a
// return within `max_range` makes its voxel occupied and the voxels its ray crosses free; a
// farther one clears its ray up to `max_range`. Each voxel gets one update per scan, a return
// winning over a ray. `stamp` is the scan's stamp in the current cycle.
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

// Starts a new cycle of stamps: every voxel observed so far is marked as seen before.
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

// Fills every block's and superblock's class pyramid from the voxels' log-odds.
void classify(const SensorModel& model, VoxelGrid* grid) {
  constexpr std::size_t kFinest = 1 + 8 + 64;
  tbb::parallel_for(std::size_t{0}, grid->superblockCount(), [&](std::size_t s) {
    Superblock* super = grid->superblockAt(s);
    if (super == nullptr) return;
    for (int b = 0; b < kSuperBlocks; ++b) {
      const Block* block = super->blocks[b].load(std::memory_order_acquire);
      if (block == nullptr) continue;
      auto classes = std::make_unique<BlockClasses>();
      for (int z = 0; z < kBlockEdge; ++z)
        for (int y = 0; y < kBlockEdge; ++y)
          for (int x = 0; x < kBlockEdge; ++x) {
            const int i = mortonIndex(x, y, z);
            const std::uint8_t state = block->state[i].load(std::memory_order_relaxed);
            (*classes)[kFinest + cubeIndex(x, y, z, kBlockBits)] =
                (state & kStampMask) == 0                        ? kUnknown
                : (state & kClampedFree) != 0                    ? kFree
                : block->log_odds[i] >= model.occupied_threshold ? kOccupied
                                                                 : kFree;
          }
      fillPyramid<3>(classes.get());
      super->classes[kFinest + b] = (*classes)[0];
      super->block_classes[b] = std::move(classes);
    }
    fillPyramid<3>(&super->classes);
  });
}

// Class of the octree region at `depth` whose first voxel is `corner` (grid-local voxels).
Class regionClass(const VoxelGrid& grid, int depth, const std::array<int, 3>& corner) {
  if (depth < kSuperDepth) {
    const int size = 1 << (kTreeDepth - depth);
    for (int a = 0; a < 3; ++a)
      if (corner[a] + size <= 0 || corner[a] >= (grid.dims()[a] << kSuperVoxelBits))
        return kUnknown;
    std::array<Class, 8> octants;
    for (int i = 0; i < 8; ++i)
      octants[i] = regionClass(grid, depth + 1, octantCorner(corner, size, i));
    return combine(octants);
  }
  // From here on the region lies inside one superblock; corners are multiples of its size, so
  // the shifts below are exact (and select no superblock for negative corners).
  const Superblock* super = grid.superblock(
      corner[0] >> kSuperVoxelBits, corner[1] >> kSuperVoxelBits, corner[2] >> kSuperVoxelBits);
  if (super == nullptr) return kUnknown;
  constexpr int kMask = (1 << kSuperVoxelBits) - 1;
  const int x = corner[0] & kMask, y = corner[1] & kMask, z = corner[2] & kMask;
  const int level = depth - kSuperDepth;  // 0: the superblock, 3: a block
  if (level == 0) return super->classes[0];
  if (level <= 3) {
    const int shift = kSuperVoxelBits - level;
    const int offset = level == 1 ? 1 : level == 2 ? 9 : 73;
    return super->classes[offset + cubeIndex(x >> shift, y >> shift, z >> shift, level)];
  }
  const BlockClasses* block =
      super->block_classes[cubeIndex(x >> kBlockBits, y >> kBlockBits, z >> kBlockBits, kSuperBits)]
          .get();
  if (block == nullptr) return kUnknown;
  const int block_level = depth - kBlockDepth;  // 1: 4^3 voxels, 3: one voxel
  const int shift = kBlockBits - block_level;
  const int offset = block_level == 1 ? 1 : block_level == 2 ? 9 : 73;
  constexpr int kVoxelMask = kBlockEdge - 1;
  return (*block)[offset + cubeIndex((x & kVoxelMask) >> shift, (y & kVoxelMask) >> shift,
                                     (z & kVoxelMask) >> shift, block_level)];
}

// Writes the pruned maximum-likelihood tree in OctoMap's binary stream format (what
// OccupancyOcTreeBase::writeBinaryNode emits): depth first, for every inner node two bytes
// giving each child's state in two bits (child i in bits 2i and 2i+1 of the first byte for
// i < 4, of the second for i >= 4): 00 unknown, 01 free, 10 occupied, 11 inner node; then the
// inner children in order. Written from the region classes, without building octree nodes.
struct BinaryEncoder {
  const VoxelGrid& grid;
  double resolution;
  std::string* data;
  OctoMapStats* stats;

  void children(int depth, const std::array<int, 3>& corner) {
    const int size = 1 << (kTreeDepth - depth);
    std::array<Class, 8> classes;
    std::array<std::uint8_t, 2> bytes{0, 0};
    const double edge = resolution * size / 2;
    for (int i = 0; i < 8; ++i) {
      classes[i] = regionClass(grid, depth + 1, octantCorner(corner, size, i));
      // As std::bitset: bit 2j is OctoMap's "free" flag of child j, bit 2j + 1 its "occupied".
      const int shift = 2 * (i % 4);
      if (classes[i] == kFree) {
        bytes[i / 4] |= static_cast<std::uint8_t>(1 << shift);
        ++stats->free_leaves;
        stats->free_volume_m3 += edge * edge * edge;
      } else if (classes[i] == kOccupied) {
        bytes[i / 4] |= static_cast<std::uint8_t>(2 << shift);
        ++stats->occupied_leaves;
        stats->occupied_volume_m3 += edge * edge * edge;
      } else if (classes[i] == kMixed) {
        bytes[i / 4] |= static_cast<std::uint8_t>(3 << shift);
      }
      if (classes[i] != kUnknown) ++stats->nodes;
    }
    data->push_back(static_cast<char>(bytes[0]));
    data->push_back(static_cast<char>(bytes[1]));
    for (int i = 0; i < 8; ++i)
      if (classes[i] == kMixed) children(depth + 1, octantCorner(corner, size, i));
  }

  // The root's region: unknown gives an empty tree (no data at all), as OctoMap writes one.
  void encode() {
    const std::array<int, 3> corner{-grid.origin()[0], -grid.origin()[1], -grid.origin()[2]};
    const Class root = regionClass(grid, 0, corner);
    if (root == kUnknown) return;
    stats->nodes = 1;
    if (root == kMixed) {
      children(0, corner);
    } else {  // a root leaf; unreachable with real scans (it spans 6.5 km at 0.1 m)
      data->append(2, '\0');
    }
  }
};

// OctoMap's binary file: its header (AbstractOccupancyOcTree::writeBinaryConst, numbers in the
// stream's default format, as OctoMap prints them) and the node stream.

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
    BinaryEncoder{grid, config.resolution_m, &data, &stats}.encode();
  }
  stats.seconds = secondsSince(start);
  return result;
}

}  // namespace mm4mm
