#pragma once
// octomap.bt (docs/design.md "Atlas directory"): an octree built by merge/octomap_tree.hpp,
// written in OctoMap's binary format.

#include <filesystem>

#include "mm4mm/merge/octomap_tree.hpp"

namespace mm4mm {

/// Writes `tree` as a .bt file (OctoMap's header, then the tree's data) under a temporary name,
/// renamed into place, so `file_bt` never holds a partial tree. Throws std::runtime_error when
/// the file cannot be written.
void writeOctoMap(const std::filesystem::path& file_bt, const OctoMapTree& tree);

}  // namespace mm4mm
