#pragma once
// Internal to merge/: the sparse voxel grid buildOctoMap (octomap_tree.cpp) casts rays into and
// the passes over it, shared by the ray casting (octomap_ray_casting.cpp) and the encoding of
// OctoMap's binary tree stream (octomap_binary_stream.cpp). Not installed: it exposes OctoMap.

#include <octomap/OcTree.h>
#include <sys/mman.h>

#include <Eigen/Geometry>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <type_traits>
#include <vector>

#include "mm4mm/merge/octomap_tree.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm::octomap_detail {

using octomap::OcTreeKey;

constexpr int kTreeDepth = 16;
constexpr int kBlockBits = 3;  // a block is 8^3 voxels: an octree node at depth 13
constexpr int kBlockEdge = 1 << kBlockBits;
constexpr int kBlockVoxels = kBlockEdge * kBlockEdge * kBlockEdge;
constexpr int kSuperBits = 3;  // a superblock is 8^3 blocks (64^3 voxels): depth 10
constexpr int kSuperVoxelBits = kBlockBits + kSuperBits;
constexpr int kSuperDepth = kTreeDepth - kSuperVoxelBits;
constexpr int kBlockDepth = kTreeDepth - kBlockBits;
constexpr int kSuperBlocks = 1 << (3 * kSuperBits);

// The class of an octree region in the pruned maximum-likelihood tree.
enum Class : std::uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2, kMixed = 3 };

// Index in a cube of 2^bits cells per edge, x fastest: for bits = 1 it is OctoMap's child index.
inline int cubeIndex(int x, int y, int z, int bits) { return (z << (2 * bits)) | (y << bits) | x; }

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

// Ray casting (octomap_ray_casting.cpp).

// Keys of every scan's origin and kept returns, over all `scans` (in parallel).
KeyBox keyBox(const octomap::OcTree& tree, const std::vector<Session>& sessions,
              const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
              const std::vector<ScanRef>& scans, const OctoMapConfig& config);

// Scan `keyframe` of `session` placed by `T_atlas_body`: its returns' voxels, each once, in
// angular order; not valid when its origin lies outside OctoMap's key range.
PreparedScan prepareScan(const octomap::OcTree& tree, const Session& session, std::size_t keyframe,
                         const Eigen::Isometry3d& T_atlas_body, const OctoMapConfig& config);

// One scan into the grid, as OccupancyOcTreeBase::computeUpdate and insertPointCloud do it: a
// return within `max_range` makes its voxel occupied and the voxels its ray crosses free; a
// farther one clears its ray up to `max_range`. Each voxel gets one update per scan, a return
// winning over a ray. `stamp` is the scan's stamp in the current cycle.
void castScan(const octomap::OcTree& tree, const PreparedScan& scan, std::uint8_t stamp,
              double max_range, const SensorModel& model, VoxelGrid* grid);

// Starts a new cycle of stamps: every voxel observed so far is marked as seen before.
void restartStamps(VoxelGrid* grid);

// The binary tree stream (octomap_binary_stream.cpp).

// Fills every block's and superblock's class pyramid from the voxels' log-odds.
void classify(const SensorModel& model, VoxelGrid* grid);

// Appends to `data` the pruned maximum-likelihood tree of the classified grid as
// OcTree::writeBinaryData writes it, and counts its nodes, leaves and volumes into `stats`.
void encodeBinaryTree(const VoxelGrid& grid, double resolution, std::string* data,
                      OctoMapStats* stats);

}  // namespace mm4mm::octomap_detail
