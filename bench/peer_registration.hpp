#pragma once
// The registration pipelines a user would reach for instead of mm4mm, on PCL's implementations
// with settings tuned for building-scale point maps (voxels of 0.25 m, rooms of tens of metres).
// PCL stays inside peer_registration.cpp: its headers take about 20 s per translation unit.

#include <Eigen/Geometry>
#include <string>

#include "mm4mm/session/session.hpp"

namespace mm4mm::peers {

struct PeerResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  bool converged = false;
};

/// PCL's Generalized-ICP from `guess`: 2 m correspondences, 100 iterations.
PeerResult registerGicp(const PointCloud& target, const PointCloud& source,
                        const Eigen::Isometry3d& guess);

/// PCL's Normal Distributions Transform from `guess`: 2 m cells, 0.5 m steps, 35 iterations.
PeerResult registerNdt(const PointCloud& target, const PointCloud& source,
                       const Eigen::Isometry3d& guess);

/// The usual global pipeline without an initial guess: both clouds thinned to 1 m voxels, FPFH
/// features (normals over 2 m, features over 5 m), PCL's SAC-IA (Rusu et al. 2009; 3 samples at
/// least 2 m apart, 1000 iterations, `seed` drives its sampling through std::rand), then GICP on
/// the full clouds from its answer.
PeerResult registerFpfhSacIaGicp(const PointCloud& target, const PointCloud& source, unsigned seed);

}  // namespace mm4mm::peers
