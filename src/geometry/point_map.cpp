#include "mm4mm/geometry/point_map.hpp"

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>

#include "kd_tree.hpp"

namespace mm4mm {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

// PCL's VoxelGrid numbers the voxels of its input's bounding box with 32-bit integers and, when
// there are more than 2^31 of them, warns "Leaf size is too small" and returns the input
// unfiltered. A tile of 2^10 voxels along each axis has 2^30 voxels, so it never overflows.
constexpr int kTileBits = 10;

// Every scan point inside the range band, in the session frame.
Cloud sessionFramePoints(const Session& session, const PointMapConfig& config) {
  const Eigen::Vector3f lidar_body = session.rig.T_body_lidar.translation().cast<float>();
  const float min_range2 = static_cast<float>(config.min_range_m * config.min_range_m);
  const float max_range2 = static_cast<float>(config.max_range_m * config.max_range_m);
  std::size_t total = 0;
  for (const PointCloud& scan : session.scans) total += scan.size();
  Cloud cloud;
  cloud.reserve(total);
  for (std::size_t k = 0; k < session.scans.size(); ++k) {
    const Eigen::Isometry3f T_session_body = session.keyframes[k].T_frame_body.cast<float>();
    for (const Eigen::Vector3f& p_body : session.scans[k]) {
      if (!p_body.allFinite()) continue;
      const float range2 = (p_body - lidar_body).squaredNorm();
      if (range2 < min_range2 || range2 > max_range2) continue;
      const Eigen::Vector3f p = T_session_body * p_body;
      cloud.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    }
  }
  cloud.is_dense = true;
  return cloud;
}

// Floor division by 2^bits, also for negative voxel indices.
std::int64_t tileOf(float coordinate, float inverse_leaf) {
  // The same float expression as PCL's VoxelGrid, so that a point's tile and the voxel PCL puts
  // it in agree even for points on a voxel boundary.
  const auto voxel = static_cast<std::int64_t>(std::floor(coordinate * inverse_leaf));
  return voxel >= 0 ? voxel >> kTileBits : -((-voxel - 1) >> kTileBits) - 1;
}

// Packs a tile's three indices into one sortable key (21 bits each, ample for 1e6 m).
std::int64_t tileKey(const pcl::PointXYZ& p, float inverse_leaf) {
  constexpr std::int64_t kBias = std::int64_t{1} << 20;
  constexpr std::int64_t kMask = (std::int64_t{1} << 21) - 1;
  return (((tileOf(p.x, inverse_leaf) + kBias) & kMask) << 42) |
         (((tileOf(p.y, inverse_leaf) + kBias) & kMask) << 21) |
         ((tileOf(p.z, inverse_leaf) + kBias) & kMask);
}

// One centroid per occupied voxel. The grid is aligned with the frame's origin in every tile,
// so tiling gives exactly the points one overflow-free VoxelGrid pass would.
Cloud voxelise(const Cloud::ConstPtr& cloud, float leaf_m) {
  const float inverse_leaf = 1.0f / leaf_m;
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setLeafSize(leaf_m, leaf_m, leaf_m);
  grid.setInputCloud(cloud);
  Cloud kept;
  if (cloud->empty()) return kept;

  std::vector<std::int64_t> keys(cloud->size());
  for (std::size_t i = 0; i < cloud->size(); ++i) keys[i] = tileKey((*cloud)[i], inverse_leaf);
  if (std::all_of(keys.begin(), keys.end(), [&](std::int64_t k) { return k == keys.front(); })) {
    grid.filter(kept);
    return kept;
  }
  pcl::IndicesPtr order(new pcl::Indices(cloud->size()));
  std::iota(order->begin(), order->end(), 0);
  std::stable_sort(order->begin(), order->end(),
                   [&](pcl::index_t a, pcl::index_t b) { return keys[a] < keys[b]; });
  for (std::size_t begin = 0, end = 0; begin < order->size(); begin = end) {
    for (end = begin; end < order->size() && keys[(*order)[end]] == keys[(*order)[begin]];) ++end;
    pcl::IndicesPtr tile(new pcl::Indices(order->begin() + begin, order->begin() + end));
    grid.setIndices(tile);
    Cloud part;
    grid.filter(part);
    kept += part;
  }
  return kept;
}

// GICP's plane regularisation (Segal et al. 2009, Section III-B): the neighbourhood's scatter
// S = U diag(l0, l1, l2) U^T with l0 <= l1 <= l2 becomes U diag(eps, 1, 1) U^T, a Gaussian that
// is flat across the surface and equally loose along it. This keeps the Mahalanobis distance of
// Eq. 11 from being dominated by how densely a patch happened to be sampled.
void covarianceAt(const std::vector<Eigen::Vector3f>& points, const std::size_t* neighbours,
                  std::size_t count, double epsilon, Eigen::Matrix3f* covariance,
                  Eigen::Vector3f* normal) {
  if (count < 3) {
    covariance->setIdentity();
    normal->setZero();
    return;
  }
  // Centred in double: session-frame coordinates of hundreds of metres would cost float digits.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < count; ++k) mean += points[neighbours[k]].cast<double>();
  mean /= static_cast<double>(count);
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < count; ++k) {
    const Eigen::Vector3d d = points[neighbours[k]].cast<double>() - mean;
    scatter.noalias() += d * d.transpose();
  }
  // U diag(eps, 1, 1) U^T = I - (1 - eps) n n^T depends only on the normal n, so the closed-form
  // 3 x 3 solver suffices: its in-plane eigenvectors may be poor when l1 ~ l2, but are unused.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(scatter);  // eigenvalues ascending
  const Eigen::Vector3d n = solver.eigenvectors().col(0).normalized();
  *covariance = (Eigen::Matrix3d::Identity() - (1.0 - epsilon) * n * n.transpose()).cast<float>();
  *normal = n.cast<float>();
}

void computeCovariances(const PointMapConfig& config, PointMap* map) {
  const std::size_t n = map->points.size();
  map->covariances.resize(n);
  map->normals.resize(n);
  if (n == 0) return;
  const KdTree3f tree(map->points);
  const std::size_t k = std::min<std::size_t>(config.covariance_neighbours, n);
  // Queries on a built index only read it, so the points can share one tree.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      std::vector<std::size_t> neighbours(k);
                      std::vector<float> distances2(k);
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const std::size_t found =
                            tree.nearest(map->points[i], k, neighbours.data(), distances2.data());
                        covarianceAt(map->points, neighbours.data(), found,
                                     config.covariance_epsilon, &map->covariances[i],
                                     &map->normals[i]);
                      }
                    });
}

// Voxelises `raw` (consumed, to free its memory early) into a map's points, without covariances.
PointMap pointsOfCloud(Cloud::Ptr raw, const PointMapConfig& config) {
  PointMap map;
  map.input_points = raw->size();
  Cloud::Ptr kept(new Cloud(voxelise(raw, static_cast<float>(config.voxel_size_m))));
  raw.reset();  // the raw scans can take gigabytes; the rest needs only the kept points
  map.points.reserve(kept->size());
  for (const pcl::PointXYZ& p : *kept) map.points.emplace_back(p.x, p.y, p.z);
  return map;
}

// The shared tail of both builders: the points, then their covariances and normals.
PointMap mapOfCloud(Cloud::Ptr raw, const PointMapConfig& config) {
  PointMap map = pointsOfCloud(std::move(raw), config);
  computeCovariances(config, &map);
  return map;
}

void checkBuildable(const Session& session, const PointMapConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("PointMapConfig: " + error);
  if (session.hasScans() && session.scans.size() != session.keyframes.size())
    throw std::invalid_argument("session '" + session.id + "' has " +
                                std::to_string(session.scans.size()) + " scans for " +
                                std::to_string(session.keyframes.size()) + " keyframes");
}

}  // namespace

bool PointMapConfig::IsValid(std::string* error) const {
  const auto fail = [error](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  // Below 1 mm, voxel indices of points up to 1e6 m from the origin would not fit in 32 bits.
  if (!std::isfinite(voxel_size_m) || voxel_size_m < 1e-3)
    return fail("voxel_size_m must be at least 0.001 (m) and finite");
  if (covariance_neighbours < 3) return fail("covariance_neighbours must be >= 3");
  if (!std::isfinite(covariance_epsilon) || covariance_epsilon <= 0.0 || covariance_epsilon > 1.0)
    return fail("covariance_epsilon must be in (0, 1]");
  if (!std::isfinite(min_range_m) || min_range_m < 0.0)
    return fail("min_range_m must be >= 0 (m) and finite");
  if (!(max_range_m > min_range_m)) return fail("max_range_m must exceed min_range_m");
  return true;
}

PointMap buildPointMap(const Session& session, const PointMapConfig& config) {
  checkBuildable(session, config);
  if (!session.hasScans()) return PointMap{};
  return mapOfCloud(Cloud::Ptr(new Cloud(sessionFramePoints(session, config))), config);
}

PointCloud buildVoxelisedPoints(const Session& session, const PointMapConfig& config) {
  checkBuildable(session, config);
  if (!session.hasScans()) return {};
  return pointsOfCloud(Cloud::Ptr(new Cloud(sessionFramePoints(session, config))), config).points;
}

PointMap buildPointMapFromCloud(const PointCloud& points, const PointMapConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("PointMapConfig: " + error);
  Cloud::Ptr cloud(new Cloud);
  cloud->reserve(points.size());
  for (const Eigen::Vector3f& p : points)
    if (p.allFinite()) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  cloud->is_dense = true;
  return mapOfCloud(std::move(cloud), config);
}

}  // namespace mm4mm
