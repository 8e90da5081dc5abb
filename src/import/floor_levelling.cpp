#include "mm4mm/import/floor_levelling.hpp"

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <algorithm>
#include <cmath>

namespace mm4mm {

std::optional<FloorLevelling> levellingFromFloor(const PointCloud& points_frame,
                                                 const FloorLevellingConfig& config) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(points_frame.size());
  for (const Eigen::Vector3f& p : points_frame)
    if (p.allFinite()) cloud->push_back({p.x(), p.y(), p.z()});
  if (cloud->empty()) return std::nullopt;
  pcl::PointCloud<pcl::PointXYZ>::Ptr thinned(new pcl::PointCloud<pcl::PointXYZ>);
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(cloud);
  const float leaf = static_cast<float>(config.voxel_m);
  grid.setLeafSize(leaf, leaf, leaf);
  grid.filter(*thinned);

  // A plane whose normal is within max_tilt_deg of the frame's z; PCL refits the winner to all
  // its inliers by least squares (optimize coefficients), which is what sets the tilt's accuracy.
  pcl::SACSegmentation<pcl::PointXYZ> segmentation;
  segmentation.setOptimizeCoefficients(true);
  segmentation.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  segmentation.setMethodType(pcl::SAC_RANSAC);
  segmentation.setAxis(Eigen::Vector3f::UnitZ());
  segmentation.setEpsAngle(static_cast<float>(config.max_tilt_deg * M_PI / 180.0));
  segmentation.setDistanceThreshold(config.distance_m);
  segmentation.setMaxIterations(config.iterations);
  segmentation.setInputCloud(thinned);
  pcl::PointIndices inliers;
  pcl::ModelCoefficients plane;
  segmentation.segment(inliers, plane);  // not random(): PCL seeds its sampler with a constant
  const int count = static_cast<int>(inliers.indices.size());
  if (plane.values.size() < 4 || count < config.min_inliers ||
      count < config.min_inlier_share * static_cast<double>(thinned->size()))
    return std::nullopt;
  Eigen::Vector3d normal(plane.values[0], plane.values[1], plane.values[2]);
  normal.normalize();
  if (normal.z() < 0) normal = -normal;  // floor or ceiling: up is the side of the frame's z
  const double tilt = std::acos(std::clamp(normal.z(), -1.0, 1.0));
  if (!(tilt <= config.max_tilt_deg * M_PI / 180.0)) return std::nullopt;
  FloorLevelling result;
  result.R_level_frame = Eigen::Quaterniond::FromTwoVectors(normal, Eigen::Vector3d::UnitZ());
  result.tilt_deg = tilt * 180.0 / M_PI;
  result.inliers = count;
  result.points = static_cast<int>(thinned->size());
  return result;
}

}  // namespace mm4mm
