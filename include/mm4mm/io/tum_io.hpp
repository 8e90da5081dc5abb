#pragma once
// Stamped poses in the TUM trajectory format: one `t x y z qx qy qz qw` line per pose (seconds,
// metres, unit quaternion of the body-to-frame rotation); blank lines and `#` comments skipped.

#include <filesystem>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// Reads a TUM file. Throws InputError (file, line, problem) on a missing or empty file, a line
/// without 8 numbers, a non-finite value, a coordinate beyond 1e6 m, a quaternion whose norm is
/// off from 1 by more than 1e-3 (smaller deviations are normalised away), or times that are not
/// strictly increasing. If `line_numbers` is given it receives each pose's 1-based line number.
std::vector<StampedPose> readTumPoses(const std::filesystem::path& file,
                                      std::vector<int>* line_numbers = nullptr);

/// Writes `poses` so that readTumPoses gives them back to double precision (times to 1 ns).
/// Throws std::invalid_argument on poses readTumPoses would reject, std::runtime_error when the
/// file cannot be written. The file is written under a temporary name and renamed into place.
void writeTumPoses(const std::filesystem::path& file, const std::vector<StampedPose>& poses);

}  // namespace mm4mm
