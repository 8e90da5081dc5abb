#pragma once
// What a merge or add will hold, known before it reads anything whole: the size of each session
// directory from its files' headers, and the memory the system has left for the process. The
// command line refuses inputs whose estimated peak (atlas/memory_bound.hpp) exceeds it, rather
// than being killed by the kernel part way.

#include <cstdint>
#include <filesystem>
#include <optional>

#include "mm4mm/atlas/memory_bound.hpp"

namespace mm4mm {

/// Counts a session directory: the POINTS of every scans/*.pcd header, and magnetometer.csv's
/// lines after its header. A scan whose header has no POINTS line is an InputError naming the
/// file; a directory without scans/ counts no points (a magnetic-only session).
SessionSize countSession(const std::filesystem::path& dir);

/// The memory this process may still use (bytes): the kernel's MemAvailable, lowered to what the
/// process's cgroup (v2) leaves under its memory.max where one is set. std::nullopt where neither
/// can be read (not Linux).
std::optional<std::uint64_t> availableMemoryBytes();

}  // namespace mm4mm
