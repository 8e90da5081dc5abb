#pragma once
// The merged point cloud as files (docs/design.md: merged.ply, merged.pcd). PLY for any viewer
// (MeshLab, CloudCompare, Blender); PCD with the per-point fusion fields for PCL tools.

#include <filesystem>

#include "mm4mm/merge/merged_cloud.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// Writes `points` (m) as binary little-endian PLY: one `vertex` element with float x y z.
/// Written under a temporary name and renamed, so `file` is never half-written. Throws
/// std::invalid_argument on a non-finite point, std::runtime_error or
/// std::filesystem::filesystem_error when the file cannot be written.
void writePly(const std::filesystem::path& file, const PointCloud& points);

/// Reads the x y z properties of the `vertex` element of a PLY file: ascii, binary little- or
/// big-endian, any numeric property types; other properties and elements (faces, lists) are
/// skipped. Throws InputError naming the file, and the header line where one is at fault, when
/// the file is missing, not PLY, has no vertex x y z, or is truncated.
PointCloud readPly(const std::filesystem::path& file);

/// Writes `cloud` as a binary (uncompressed) PCD with float32 fields per point:
///   x y z     position in the atlas frame (m)
///   variance  mean variance of the position, trace(covariance) / 3 (m^2)
///   session   index of the session that contributed most returns
///   sessions  number of sessions fused into the point
///   returns   scan returns behind the point
/// Written under a temporary name and renamed. Throws std::invalid_argument when the cloud's
/// vectors differ in length or a point is not finite, std::runtime_error when the file cannot
/// be written. readPcd (io/pcd_io.hpp) reads the positions back.
void writeMergedCloudPcd(const std::filesystem::path& file, const MergedCloud& cloud);

}  // namespace mm4mm
