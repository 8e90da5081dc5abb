#include "mm4mm/import/lio_sam_map.hpp"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "import_text.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/pcd_io.hpp"

namespace mm4mm {

namespace fs = std::filesystem;

LidarRecording readLioSamMap(const fs::path& dir, double map_crop_radius_m) {
  const fs::path file = dir / "transformations.pcd";
  const std::vector<std::vector<double>> rows =
      readPcdFields(file, {"x", "y", "z", "intensity", "roll", "pitch", "yaw", "time"});
  if (rows.empty()) throw InputError(file.string(), 0, "holds no key pose");
  LidarRecording recording;
  recording.source = "LIO-SAM map " + dir.string();
  recording.body_frame = "LIO-SAM's lidar_link (the LiDAR frame)";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::vector<double>& r = rows[i];
    for (double v : r)
      if (!std::isfinite(v))
        throw InputError(file.string(), 0, "key pose " + std::to_string(i) + " is not finite");
    ImportedKeyframe keyframe;
    keyframe.pose.time_s = r[7];
    // pcl::getTransformation(x, y, z, roll, pitch, yaw): R = Rz(yaw) Ry(pitch) Rx(roll).
    keyframe.pose.T_frame_body = poseFromRpy(Eigen::Vector3d(r[0], r[1], r[2]), r[4], r[5], r[6]);
    recording.keyframes.push_back(std::move(keyframe));
  }
  std::stable_sort(recording.keyframes.begin(), recording.keyframes.end(),
                   [](const auto& a, const auto& b) { return a.pose.time_s < b.pose.time_s; });
  // LIO-SAM before February 2022 and most of its forks save the key poses with
  // pcl::io::savePCDFileASCII, which prints 8 significant digits: a Unix time of 1.7e9 s keeps
  // 100 s steps, and key poses a second apart share times. Said as such, not as "times go
  // backwards" further on.
  const auto eightDigits = [](double t) {
    char printed[32];
    std::snprintf(printed, sizeof printed, "%.8g", t);
    return std::strtod(printed, nullptr) == t;
  };
  for (std::size_t k = 1; k < recording.keyframes.size(); ++k) {
    const double t = recording.keyframes[k].pose.time_s;
    if (t != recording.keyframes[k - 1].pose.time_s) continue;
    const bool rounded = std::all_of(
        rows.begin(), rows.end(), [&](const std::vector<double>& r) { return eightDigits(r[7]); });
    char at[32];
    std::snprintf(at, sizeof at, "%.10g", t);
    throw InputError(
        file.string(), 0,
        rounded ? std::string("its key poses' times keep 8 significant digits (") + at +
                      " s is shared by several): the file was saved as ASCII "
                      "(pcl::io::savePCDFileASCII, as LIO-SAM before February 2022 and most "
                      "forks save it), which loses the keyframes' times. Save the key poses "
                      "with pcl::io::savePCDFileBinary (LIO-SAM's saveMapService does since "
                      "2022) and import that file"
                : std::string("two key poses share the time ") + at +
                      " s: the keyframes have no order to place the field by");
  }
  if (map_crop_radius_m <= 0.0) {
    recording.scans_saved = false;
    recording.notes.push_back(
        "LIO-SAM saves no per-keyframe scan: the session is magnetic-only (key poses and the "
        "field; no ICP-EM refinement, nothing in the merged cloud)");
    return recording;
  }
  fs::path map_file = dir / "GlobalMap.pcd";
  if (!fs::exists(map_file) && fs::exists(dir / "cloudGlobal.pcd"))
    map_file = dir / "cloudGlobal.pcd";
  const PointCloud map = readPcd(map_file);
  if (map.empty()) throw InputError(map_file.string(), 0, "holds no point");
  // A k-d tree: a building-sized map has millions of points, and thousands of key poses.
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(map.size());
  for (const Eigen::Vector3f& p : map) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  std::vector<int> indices;
  std::vector<float> distances;
  for (ImportedKeyframe& keyframe : recording.keyframes) {
    const Eigen::Vector3f centre = keyframe.pose.T_frame_body.translation().cast<float>();
    tree.radiusSearch(pcl::PointXYZ(centre.x(), centre.y(), centre.z()), map_crop_radius_m, indices,
                      distances);
    std::sort(indices.begin(), indices.end());  // the map's order, whatever the tree's
    PointCloud near;
    near.reserve(indices.size());
    for (int i : indices) near.push_back(map[static_cast<std::size_t>(i)]);
    keyframe.scan_body = import_detail::transformed(near, keyframe.pose.T_frame_body.inverse());
    if (keyframe.scan_body.empty())
      throw InputError(map_file.string(), 0,
                       "has no point within " + std::to_string(map_crop_radius_m) +
                           " m of the key pose at " + std::to_string(keyframe.pose.time_s) + " s");
  }
  recording.notes.push_back(
      "LIO-SAM saves no per-keyframe scan: each keyframe holds the saved map's points within " +
      std::to_string(map_crop_radius_m) + " m (the map around it, not what the LiDAR saw)");
  return recording;
}

}  // namespace mm4mm
