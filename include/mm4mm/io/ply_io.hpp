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

/// Reads the x y z properties of the `vertex` element of a PLY file with PCL's reader
/// (pcl::PLYReader): ascii, binary little- or big-endian, x y z of any numeric type; other
/// properties and elements are skipped, as are vertices that are not finite (PCL reads an ascii
/// value it cannot parse as NaN). Throws InputError naming the file, and the header line where
/// one is at fault, when the file is missing, not PLY, declares more items than it can hold, has
/// no vertex x y z, is truncated, or holds a vertex beyond 1e6 m. PCL prints what it refuses to
/// the console as well.
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
