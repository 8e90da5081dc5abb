#pragma once
// Point maps as PCD files (mm4mm map: point_map.pcd). PCL stays inside the .cpp.

#include <filesystem>

#include "mm4mm/geometry/point_map.hpp"

namespace mm4mm {

/// Writes `map` as a binary_compressed PCD with fields x y z normal_x normal_y normal_z (float32,
/// session frame, m), which PCL reads as pcl::PointNormal minus curvature. The covariances are not
/// stored: buildPointMap's are all C = I - (1 - eps) n n^T, so the normals and the eps recorded in
/// a header comment (`# mm4mm_point_map ... eps=0.001`) carry them exactly. Written under a
/// temporary name and renamed. Throws std::invalid_argument on a non-finite point or normal or
/// mismatched vectors, std::runtime_error when the file cannot be written.
void writePointMapPcd(const std::filesystem::path& file, const PointMap& map);

}  // namespace mm4mm
