#include "peer_registration.hpp"

#include <pcl/features/fpfh_omp.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/correspondence_estimation.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/ia_ransac.h>
#include <pcl/registration/ndt.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace mm4mm::peers {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

Cloud::Ptr toPcl(const PointCloud& cloud) {
  Cloud::Ptr out(new Cloud);
  out->reserve(cloud.size());
  for (const Eigen::Vector3f& p : cloud) out->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return out;
}

Eigen::Isometry3d toIsometry(const Eigen::Matrix4f& m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Re-orthonormalise: PCL accumulates the rotation in float.
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>().cast<double>();
  T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  T.translation() = m.topRightCorner<3, 1>().cast<double>();
  return T;
}

Cloud::Ptr voxelised(const Cloud::Ptr& cloud, float leaf_m) {
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(cloud);
  grid.setLeafSize(leaf_m, leaf_m, leaf_m);
  Cloud::Ptr out(new Cloud);
  grid.filter(*out);
  return out;
}

pcl::PointCloud<pcl::FPFHSignature33>::Ptr fpfh(const Cloud::Ptr& cloud) {
  auto tree = std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>();
  pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> normals_estimation;
  normals_estimation.setInputCloud(cloud);
  normals_estimation.setSearchMethod(tree);
  normals_estimation.setRadiusSearch(2.0);
  pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
  normals_estimation.compute(*normals);
  pcl::FPFHEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> features_estimation;
  features_estimation.setInputCloud(cloud);
  features_estimation.setInputNormals(normals);
  features_estimation.setSearchMethod(tree);
  features_estimation.setRadiusSearch(5.0);
  pcl::PointCloud<pcl::FPFHSignature33>::Ptr features(new pcl::PointCloud<pcl::FPFHSignature33>);
  features_estimation.compute(*features);
  return features;
}

Eigen::Vector3d centroidOf(const PointCloud& cloud) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3f& p : cloud) c += p.cast<double>();
  return cloud.empty() ? c : Eigen::Vector3d(c / static_cast<double>(cloud.size()));
}

}  // namespace

void measureFit(const PointCloud& target, const PointCloud& source, PeerResult* result) {
  const Cloud::Ptr aligned(new Cloud);
  const Eigen::Isometry3f T = result->T_target_source.cast<float>();
  aligned->reserve(source.size());
  for (const Eigen::Vector3f& p : source) {
    const Eigen::Vector3f q = T * p;
    aligned->push_back(pcl::PointXYZ(q.x(), q.y(), q.z()));
  }
  pcl::registration::CorrespondenceEstimation<pcl::PointXYZ, pcl::PointXYZ> estimation;
  estimation.setInputSource(aligned);
  estimation.setInputTarget(toPcl(target));
  pcl::Correspondences within;
  estimation.determineCorrespondences(within, kFitDistanceM);
  double squared = 0.0;
  for (const pcl::Correspondence& c : within) squared += c.distance;  // squared distance in PCL
  result->fitness = source.empty() ? 0.0 : static_cast<double>(within.size()) / source.size();
  result->inlier_rmse_m = within.empty() ? 0.0 : std::sqrt(squared / within.size());
}

MultiStartResult bestOfStarts(const PointCloud& target, const PointCloud& source,
                              std::vector<PeerResult> answers) {
  MultiStartResult out;
  out.starts = static_cast<int>(answers.size());
  if (answers.empty()) return out;
  for (PeerResult& answer : answers) measureFit(target, source, &answer);
  const auto better = [](const PeerResult& x, const PeerResult& y) {
    return x.converged != y.converged ? x.converged : x.fitness > y.fitness;
  };
  out.best = *std::min_element(answers.begin(), answers.end(), better);
  const Eigen::Vector3d centroid = centroidOf(source);
  for (const PeerResult& answer : answers) {
    if (!answer.converged) continue;
    ++out.converged;
    const double apart_m =
        (answer.T_target_source * centroid - out.best.T_target_source * centroid).norm();
    const double apart_deg = Eigen::AngleAxisd(answer.T_target_source.linear().transpose() *
                                               out.best.T_target_source.linear())
                                 .angle() *
                             180.0 / M_PI;
    if (apart_m > kDistinctM || apart_deg > kDistinctDeg)
      out.second_fitness = std::max(out.second_fitness, answer.fitness);
  }
  return out;
}

std::vector<Eigen::Isometry3d> guessStarts(const PointCloud& target, const PointCloud& source,
                                           int yaws) {
  const Eigen::Vector3d c_target = centroidOf(target), c_source = centroidOf(source);
  std::vector<Eigen::Isometry3d> starts{Eigen::Isometry3d::Identity()};
  for (int k = 0; k < yaws; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(2.0 * M_PI * k / yaws, Eigen::Vector3d::UnitZ()).matrix();
    T.translation() = c_target - T.linear() * c_source;
    starts.push_back(T);
  }
  return starts;
}

PeerResult registerGicp(const PointCloud& target, const PointCloud& source,
                        const Eigen::Isometry3d& guess) {
  pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
  gicp.setInputTarget(toPcl(target));
  gicp.setInputSource(toPcl(source));
  gicp.setMaxCorrespondenceDistance(2.0);
  gicp.setMaximumIterations(100);
  Cloud aligned;
  gicp.align(aligned, guess.matrix().cast<float>());
  return {toIsometry(gicp.getFinalTransformation()), gicp.hasConverged()};
}

PeerResult registerNdt(const PointCloud& target, const PointCloud& source,
                       const Eigen::Isometry3d& guess) {
  pcl::NormalDistributionsTransform<pcl::PointXYZ, pcl::PointXYZ> ndt;
  ndt.setResolution(2.0f);
  ndt.setStepSize(0.5);
  ndt.setTransformationEpsilon(1e-3);
  ndt.setMaximumIterations(35);  // PCL's own default for NDT
  ndt.setInputTarget(toPcl(target));
  ndt.setInputSource(toPcl(source));
  Cloud aligned;
  ndt.align(aligned, guess.matrix().cast<float>());
  return {toIsometry(ndt.getFinalTransformation()), ndt.hasConverged()};
}

PeerResult registerFpfhSacIaGicp(const PointCloud& target, const PointCloud& source,
                                 unsigned seed) {
  const Cloud::Ptr target_full = toPcl(target), source_full = toPcl(source);
  const Cloud::Ptr target_coarse = voxelised(target_full, 1.0f);
  const Cloud::Ptr source_coarse = voxelised(source_full, 1.0f);
  pcl::SampleConsensusInitialAlignment<pcl::PointXYZ, pcl::PointXYZ, pcl::FPFHSignature33> sac_ia;
  sac_ia.setInputTarget(target_coarse);
  sac_ia.setTargetFeatures(fpfh(target_coarse));
  sac_ia.setInputSource(source_coarse);
  sac_ia.setSourceFeatures(fpfh(source_coarse));
  sac_ia.setNumberOfSamples(3);
  sac_ia.setMinSampleDistance(2.0f);
  sac_ia.setCorrespondenceRandomness(5);
  sac_ia.setMaxCorrespondenceDistance(2.0);
  sac_ia.setMaximumIterations(1000);  // PCL's own default for SAC-IA
  std::srand(seed);                   // SAC-IA samples with std::rand
  Cloud aligned;
  sac_ia.align(aligned);
  const Eigen::Isometry3d initial = toIsometry(sac_ia.getFinalTransformation());
  PeerResult refined = registerGicp(target, source, initial);
  refined.converged = refined.converged && sac_ia.hasConverged();
  return refined;
}

}  // namespace mm4mm::peers
