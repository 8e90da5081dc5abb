#pragma once
// Internal to src/io: a directory written whole beside its target and swapped in with one rename,
// so that a kill at any moment leaves the old directory or the new one (the atlas's writers and
// writeSession).

#include <filesystem>
#include <string>

namespace mm4mm::io_detail {

/// fsync(2) of one file or directory: its data, and for a directory its entries, reach the disk.
void syncPath(const std::filesystem::path& path, bool directory);

/// Every file under `dir`, then its directories, flushed: a swap that follows must not reach the
/// disk before the data it makes visible (ext4 and xfs may reorder them otherwise).
void syncTree(const std::filesystem::path& dir);

/// Puts the complete directory `staging` at `target` in one step: the kernel swaps the two
/// directory entries (renameat2 RENAME_EXCHANGE) and the old one is removed. Where the file system
/// cannot swap, the old one is moved to `previous` first; a kill between the two renames leaves it
/// there.
void swapIntoPlace(const std::filesystem::path& staging, const std::filesystem::path& target,
                   const std::filesystem::path& previous);

/// Removes the scratch directories `<target><suffix><pid>` of writers that were killed (their
/// process is gone; a live one may still be writing).
void removeStaleStaging(const std::filesystem::path& target, const std::string& suffix);

}  // namespace mm4mm::io_detail
