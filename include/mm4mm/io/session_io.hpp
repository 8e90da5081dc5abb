#pragma once
// A session directory as docs/design.md ("Session directory (input)") defines it:
//   session.yaml, poses.txt, magnetometer.csv, optional scans/NNNNNN.pcd, optional odometry.txt
//   (the odometry's full pose stream, TUM, which places the magnetometer samples), optional
//   ground_truth.txt and ground_truth_magnetometers.yaml (simulated sessions).

#include <filesystem>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// What readSession reads of a session directory.
enum class SessionParts {
  kAll,
  /// session.yaml, poses.txt, odometry.txt and the ground truth, without the magnetometer
  /// readings and the scans (most of a session's bytes): for what needs only where the session
  /// went, such as `mm4mm eval`. The session then has no readings and no scans, so it must not be
  /// matched, merged or written.
  kPoses,
};

/// Reads and checks a whole session directory. Throws InputError naming the file, the line
/// (0 when the problem concerns a whole file) and the problem: missing files or required keys,
/// malformed lines, non-finite or absurd values, times out of order, unknown sensor indices,
/// duplicate magnetometer samples, scans/ not holding exactly one scan per keyframe, ground truth
/// not matching poses.txt's keyframes. Magnetometer samples come back sorted by time, ties by
/// sensor index. Without scans/ the session is magnetic-only (`scans` empty).
Session readSession(const std::filesystem::path& dir, SessionParts parts = SessionParts::kAll);

/// Writes `session` as a session directory at `dir`, replacing whatever is there. The files are
/// written into a sibling scratch directory (`<dir>.partial<pid>`), flushed to disk, and swapped
/// with `dir` in one rename (renameat2 RENAME_EXCHANGE), so killed at any moment `dir` holds the
/// old session or the whole new one; scratch directories of killed writes are removed by the next
/// write. Magnetometer times are written to 1 µs and fields to 0.1 nT.
/// Throws std::invalid_argument on a session readSession would reject (for example scans not
/// one per keyframe), std::runtime_error or std::filesystem::filesystem_error on I/O failure.
void writeSession(const Session& session, const std::filesystem::path& dir);

}  // namespace mm4mm
