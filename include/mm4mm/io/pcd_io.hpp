#pragma once
// Keyframe scans as PCD files (PCL's format), points in metres. PCL stays inside the .cpp.

#include <filesystem>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };

/// Reads the x y z fields of a PCD file in any encoding; other fields and the VIEWPOINT are
/// ignored. Points with a non-finite coordinate (PCL's "no return") are dropped; a file with no
/// points gives an empty cloud. Throws InputError when the file is missing, not a readable PCD,
/// lacks an x, y or z field, or holds a point beyond 1e6 m.
PointCloud readPcd(const std::filesystem::path& file);

/// The named scalar fields of every point of a PCD file in any encoding and numeric type (for
/// example LIO-SAM's key poses: x y z intensity roll pitch yaw time), as double, one row per point
/// in file order; non-finite values are kept. Throws InputError when the file is missing, not a
/// readable PCD, or lacks one of `fields` (the message lists the fields it has).
std::vector<std::vector<double>> readPcdFields(const std::filesystem::path& file,
                                               const std::vector<std::string>& fields);

/// Writes `cloud` as an unorganised PCD (fields x y z, float). Throws std::invalid_argument on a
/// non-finite point or one beyond 1e6 m, std::runtime_error when the file cannot be written. The
/// file is written under a temporary name and renamed into place.
void writePcd(const std::filesystem::path& file, const PointCloud& cloud,
              PcdEncoding encoding = PcdEncoding::kBinaryCompressed);

}  // namespace mm4mm
