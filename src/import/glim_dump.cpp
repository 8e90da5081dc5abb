#include "mm4mm/import/glim_dump.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include "import_text.hpp"
#include "mm4mm/io/input_error.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;
using import_detail::TokenStream;

struct Submap {
  Eigen::Isometry3d T_world_origin = Eigen::Isometry3d::Identity();
  int frame_id = -1;  // GLIM's FrameID: 1 lidar, 2 imu
  std::vector<double> stamps;
};

Eigen::Isometry3d readMatrix4(TokenStream& in, const std::string& key) {
  in.expect(key);
  const int line = in.line();
  return import_detail::rigidFromMatrix(in.matrix(4, 4, key), in.file(), line);
}

// SubMap::save's order (sub_map.cpp); the T_lidar_imu block is absent for a submap without frames.
Submap readSubmapData(const fs::path& file) {
  TokenStream in(file);
  Submap submap;
  in.expect("id:");
  in.number("submap id");
  submap.T_world_origin = readMatrix4(in, "T_world_origin:");
  readMatrix4(in, "T_origin_endpoint_L:");
  readMatrix4(in, "T_origin_endpoint_R:");
  if (in.peek() == "T_lidar_imu:") {
    readMatrix4(in, "T_lidar_imu:");
    in.expect("imu_bias:");
    in.matrix(1, 6, "imu_bias");
    in.expect("frame_id:");
    submap.frame_id = static_cast<int>(in.number("frame_id"));
  }
  in.expect("num_frames:");
  const int at = in.line();
  const double frames = in.number("num_frames");
  if (frames < 0 || frames > 1e7 || frames != std::floor(frames))
    throw InputError(in.file(), at, "num_frames is not a count");
  for (int i = 0; i < static_cast<int>(frames); ++i) {
    in.expect("frame_" + std::to_string(i));
    in.expect("id:");
    in.number("frame id");
    in.expect("stamp:");
    submap.stamps.push_back(in.number("stamp"));
    readMatrix4(in, "T_odom_lidar:");
    readMatrix4(in, "T_world_lidar:");
    in.expect("v_world_imu:");
    in.matrix(1, 3, "v_world_imu");
  }
  if (!in.done())
    throw InputError(in.file(), in.line(), "unexpected '" + in.peek() + "' after the last frame");
  return submap;
}

PointCloud readCompactPoints(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file.string(), 0, "file not found");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() % 12 != 0)
    throw InputError(file.string(), 0,
                     std::to_string(bytes.size()) +
                         " bytes is no whole number of float32 x y z points (12 bytes each)");
  PointCloud cloud(bytes.size() / 12);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    float xyz[3];
    std::memcpy(xyz, bytes.data() + 12 * i, sizeof xyz);
    cloud[i] = Eigen::Vector3f(xyz[0], xyz[1], xyz[2]);
    if (!cloud[i].allFinite() || cloud[i].cwiseAbs().maxCoeff() > 1e6f)
      throw InputError(file.string(), 0,
                       "point " + std::to_string(i) + " is not finite or lies beyond 1e6 m");
  }
  if (cloud.empty()) throw InputError(file.string(), 0, "holds no point");
  return cloud;
}

bool inTrajectory(const std::vector<StampedPose>& poses, double t) {
  const auto it = std::lower_bound(poses.begin(), poses.end(), t - 1e-6,
                                   [](const StampedPose& p, double v) { return p.time_s < v; });
  return it != poses.end() && std::abs(it->time_s - t) <= 1e-6;
}

}  // namespace

LidarRecording readGlimDump(const fs::path& dir) {
  const auto submap_dirs = import_detail::sixDigitDirectories(dir);
  if (submap_dirs.empty())
    throw InputError(dir.string(), 0, "holds no submap directory (000000/ ...): not a GLIM dump");

  std::vector<Submap> submaps;
  for (const auto& [index, path] : submap_dirs)
    submaps.push_back(readSubmapData(path / "data.txt"));
  const bool imu = submaps.front().frame_id == 2;
  const fs::path trajectory_file = dir / (imu ? "traj_imu.txt" : "traj_lidar.txt");

  LidarRecording recording;
  recording.source = "GLIM dump " + dir.string();
  recording.body_frame = imu ? "GLIM's imu frame" : "GLIM's lidar frame";
  std::size_t repeated = 0;
  // GlobalMapping::save's write_tum_frame: "%.9f %.6f %.6f %.6f %.6f %.6f %.6f %.6f".
  recording.odometry = import_detail::readTumLenient(trajectory_file, &repeated);
  std::size_t pruned = 0;
  for (std::size_t i = 0; i < submaps.size(); ++i) {
    const Submap& submap = submaps[i];
    const fs::path data = submap_dirs[i].second / "data.txt";
    if (submap.stamps.empty()) throw InputError(data.string(), 0, "has no frame");
    if ((submap.frame_id == 2) != imu)
      throw InputError(data.string(), 0, "frame_id differs from the first submap's");
    // The origin is the pose of the middle frame (GlobalMapping::create_submap: X(center),
    // center = odom_frames.size() / 2).
    const double stamp = submap.stamps[submap.stamps.size() / 2];
    if (!inTrajectory(recording.odometry, stamp)) {
      ++pruned;
      continue;
    }
    ImportedKeyframe keyframe;
    keyframe.pose.time_s = stamp;
    keyframe.pose.T_frame_body = submap.T_world_origin;
    keyframe.scan_body = readCompactPoints(submap_dirs[i].second / "points_compact.bin");
    recording.keyframes.push_back(std::move(keyframe));
  }
  recording.notes.push_back(
      "GLIM saves no per-frame scan: each keyframe is a submap origin and its scan the submap's "
      "merged cloud (subsampled and voxelised by GLIM)");
  if (pruned > 0)
    recording.notes.push_back(std::to_string(pruned) +
                              " submap(s) not in the trajectory (pruned by GLIM) left out");
  if (repeated > 0)
    recording.notes.push_back(std::to_string(repeated) +
                              " trajectory line(s) repeating a time left out");
  return recording;
}

}  // namespace mm4mm
