#!/usr/bin/env python3
"""Open3D's global registration pipeline, as an external peer of mm4mm (issue 5).

FPFH features + RANSAC over feature correspondences, then point-to-plane ICP on the full clouds:
the pipeline of Open3D's global-registration tutorial with building-scale settings (features on
1 m voxels, the same scale as PCL's FPFH + SAC-IA peer in bench/peer_registration.cpp).

Usage: open3d_peer.py TARGET.pcd SOURCE.pcd SEED
Prints one JSON line: {"T_target_source": 4x4 row-major list, "fitness": f, "seconds": s,
"peak_rss_mb": m}.
"""
import json
import resource
import sys
import time

import numpy as np
import open3d as o3d

VOXEL_M = 1.0


def features(cloud):
    coarse = cloud.voxel_down_sample(VOXEL_M)
    coarse.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2.0 * VOXEL_M, max_nn=30))
    fpfh = o3d.pipelines.registration.compute_fpfh_feature(
        coarse, o3d.geometry.KDTreeSearchParamHybrid(radius=5.0 * VOXEL_M, max_nn=100))
    return coarse, fpfh


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: open3d_peer.py TARGET.pcd SOURCE.pcd SEED")
    target = o3d.io.read_point_cloud(sys.argv[1])
    source = o3d.io.read_point_cloud(sys.argv[2])
    if target.is_empty() or source.is_empty():
        sys.exit(f"open3d_peer: empty cloud in {sys.argv[1]} or {sys.argv[2]}")
    o3d.utility.random.seed(int(sys.argv[3]))
    start = time.perf_counter()
    target_coarse, target_fpfh = features(target)
    source_coarse, source_fpfh = features(source)
    reg = o3d.pipelines.registration
    coarse = reg.registration_ransac_based_on_feature_matching(
        source_coarse, target_coarse, source_fpfh, target_fpfh, True, 1.5 * VOXEL_M,
        reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9),
         reg.CorrespondenceCheckerBasedOnDistance(1.5 * VOXEL_M)],
        reg.RANSACConvergenceCriteria(100000, 0.999))
    target.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=1.0, max_nn=30))
    fine = reg.registration_icp(source, target, 0.5, coarse.transformation,
                                reg.TransformationEstimationPointToPlane(),
                                reg.ICPConvergenceCriteria(max_iteration=100))
    seconds = time.perf_counter() - start
    print(json.dumps({"T_target_source": np.asarray(fine.transformation).tolist(),
                      "fitness": fine.fitness, "seconds": seconds,
                      "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}))


if __name__ == "__main__":
    main()
