// OctoMap's binary tree stream for buildOctoMap: the region classes of the voxel grid, and the
// pruned maximum-likelihood tree encoded from them without building octree nodes.

#include <tbb/parallel_for.h>

#include "octomap_grid.hpp"

namespace mm4mm::octomap_detail {
namespace {

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

}  // namespace

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

namespace {

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

}  // namespace

void encodeBinaryTree(const VoxelGrid& grid, double resolution, std::string* data,
                      OctoMapStats* stats) {
  BinaryEncoder{grid, resolution, data, stats}.encode();
}

}  // namespace mm4mm::octomap_detail
