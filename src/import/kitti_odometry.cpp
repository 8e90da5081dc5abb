#include "mm4mm/import/kitti_odometry.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "../io/text_io.hpp"
#include "import_text.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/pcd_io.hpp"
#include "mm4mm/io/tum_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

Eigen::Isometry3d parse3x4(const std::vector<std::string_view>& tokens, std::size_t first,
                           const std::string& file, int line) {
  Eigen::MatrixXd M(3, 4);
  for (int k = 0; k < 12; ++k)
    M(k / 4, k % 4) = io_detail::parseFiniteNumber(tokens[first + k], "value", file, line);
  return import_detail::rigidFromMatrix(M, file, line);
}

// calib.txt: "P0: 12 numbers" ... "Tr: 12 numbers" (velodyne to camera 0).
Eigen::Isometry3d readVelodyneToCamera(const fs::path& file) {
  const std::string content = io_detail::readWholeFile(file);
  std::optional<Eigen::Isometry3d> Tr;
  io_detail::forEachLine(content, [&](int line, std::string_view text) {
    const std::vector<std::string_view> tokens = io_detail::splitWhitespace(text);
    if (tokens.empty() || tokens[0] != "Tr:") return;
    if (tokens.size() != 13) throw InputError(file.string(), line, "Tr: needs 12 numbers");
    Tr = parse3x4(tokens, 1, file.string(), line);
  });
  if (!Tr) throw InputError(file.string(), 0, "has no 'Tr:' line (velodyne to camera 0)");
  return *Tr;
}

std::vector<double> readTimes(const fs::path& file) {
  const std::string content = io_detail::readWholeFile(file);
  std::vector<double> times;
  io_detail::forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty()) return;
    const double t = io_detail::parseFiniteNumber(text, "time", file.string(), line);
    if (!times.empty() && t <= times.back())
      throw InputError(file.string(), line, "times do not increase");
    times.push_back(t);
  });
  return times;
}

// The KITTI devkit's velodyne format: float32 x y z reflectance, no header.
PointCloud readVelodyneBin(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file.string(), 0, "file not found");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.empty() || bytes.size() % 16 != 0)
    throw InputError(file.string(), 0,
                     std::to_string(bytes.size()) +
                         " bytes is no whole, non-zero number of float32 x y z r points");
  PointCloud cloud;
  cloud.reserve(bytes.size() / 16);
  for (std::size_t i = 0; i < bytes.size() / 16; ++i) {
    float v[4];
    std::memcpy(v, bytes.data() + 16 * i, sizeof v);
    const Eigen::Vector3f p(v[0], v[1], v[2]);
    if (p.allFinite() && p.cwiseAbs().maxCoeff() < 1e6f) cloud.push_back(p);
  }
  return cloud;
}

// A PCD name split into its pattern (the text with every number as '#') and its numbers, in
// order: "scan_12" is ("scan_#", {12}), "1634567.25" is ("#", {1634567.25}). A number is a run of
// digits, with a decimal part where a '.' is followed by a digit.
struct NameKey {
  std::string pattern;
  std::vector<double> numbers;
};

NameKey nameKey(const std::string& name) {
  NameKey key;
  for (std::size_t i = 0; i < name.size();) {
    if (!std::isdigit(static_cast<unsigned char>(name[i]))) {
      key.pattern += name[i++];
      continue;
    }
    std::size_t end = i;
    while (end < name.size() && std::isdigit(static_cast<unsigned char>(name[end]))) ++end;
    if (end + 1 < name.size() && name[end] == '.' &&
        std::isdigit(static_cast<unsigned char>(name[end + 1]))) {
      ++end;
      while (end < name.size() && std::isdigit(static_cast<unsigned char>(name[end]))) ++end;
    }
    key.numbers.push_back(std::strtod(name.substr(i, end - i).c_str(), nullptr));
    key.pattern += '#';
    i = end;
  }
  return key;
}

// The PCDs of `dir` in the order of the numbers in their names (scan_2 before scan_10, as the
// scans were written), which must follow one pattern: names with no number, with different
// patterns or with the same numbers give no order to pair scans with poses by, and are refused
// rather than paired by text order.
std::vector<std::pair<std::string, fs::path>> sortedPcds(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw InputError(dir.string(), 0, "directory not found");
  std::vector<std::pair<NameKey, fs::path>> files;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().extension() == ".pcd")
      files.push_back({nameKey(entry.path().stem().string()), entry.path()});
  for (const auto& [key, path] : files) {
    if (key.numbers.empty())
      throw InputError(path.string(), 0,
                       "the PCD's name holds no number to order the scans by (name them by index "
                       "or stamp, e.g. scan_12.pcd, as they pair with the poses in that order)");
    if (key.pattern != files.front().first.pattern)
      throw InputError(path.string(), 0,
                       "PCD names follow more than one pattern (" +
                           files.front().second.filename().string() + " and " +
                           path.filename().string() +
                           "): no one order to pair the scans with the poses by");
  }
  std::sort(files.begin(), files.end(),
            [](const auto& a, const auto& b) { return a.first.numbers < b.first.numbers; });
  for (std::size_t k = 1; k < files.size(); ++k)
    if (files[k].first.numbers == files[k - 1].first.numbers)
      throw InputError(files[k].second.string(), 0,
                       "has the same number as " + files[k - 1].second.filename().string() +
                           ": the scans' order is ambiguous");
  std::vector<std::pair<std::string, fs::path>> sorted;
  for (auto& [key, path] : files) sorted.push_back({path.stem().string(), path});
  return sorted;
}

}  // namespace

std::vector<Eigen::Isometry3d> readKittiPoses(const fs::path& file) {
  const std::string content = io_detail::readWholeFile(file);
  std::vector<Eigen::Isometry3d> poses;
  io_detail::forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty()) return;
    const std::vector<std::string_view> tokens = io_detail::splitWhitespace(text);
    if (tokens.size() != 12)
      throw InputError(file.string(), line,
                       "a KITTI pose line holds 12 numbers (row-major 3x4), found " +
                           std::to_string(tokens.size()));
    poses.push_back(parse3x4(tokens, 0, file.string(), line));
  });
  if (poses.empty()) throw InputError(file.string(), 0, "holds no pose");
  return poses;
}

LidarRecording readKittiOdometry(const fs::path& sequence_dir, const fs::path& pose_file,
                                 double time_origin_s, const KeyframeSpacing& spacing) {
  const Eigen::Isometry3d Tr = readVelodyneToCamera(sequence_dir / "calib.txt");
  const std::vector<double> times = readTimes(sequence_dir / "times.txt");
  const std::vector<Eigen::Isometry3d> camera_poses = readKittiPoses(pose_file);
  if (times.size() != camera_poses.size())
    throw InputError(pose_file.string(), 0,
                     "holds " + std::to_string(camera_poses.size()) + " poses, but times.txt has " +
                         std::to_string(times.size()));
  LidarRecording recording;
  recording.source = "KITTI sequence " + sequence_dir.string();
  recording.body_frame = "KITTI's velodyne frame";
  for (std::size_t i = 0; i < times.size(); ++i)
    recording.odometry.push_back({times[i] + time_origin_s, Tr.inverse() * camera_poses[i] * Tr});
  for (std::size_t i : selectKeyframes(recording.odometry, spacing)) {
    char name[32];
    std::snprintf(name, sizeof name, "%06zu.bin", i);
    ImportedKeyframe keyframe;
    keyframe.pose = recording.odometry[i];
    keyframe.scan_body = readVelodyneBin(sequence_dir / "velodyne" / name);
    recording.keyframes.push_back(std::move(keyframe));
  }
  recording.notes.push_back("reflectance dropped; one keyframe per " +
                            std::to_string(spacing.distance_m) + " m or " +
                            std::to_string(spacing.angle_deg) + " deg of motion");
  return recording;
}

LidarRecording readTumWithPcds(const fs::path& pose_file, const fs::path& pcd_dir,
                               bool scans_in_world) {
  const std::vector<StampedPose> poses = readTumPoses(pose_file);
  const auto files = sortedPcds(pcd_dir);
  if (files.size() != poses.size())
    throw InputError(pcd_dir.string(), 0,
                     "holds " + std::to_string(files.size()) + " PCD files, but " +
                         pose_file.string() + " has " + std::to_string(poses.size()) +
                         " poses (one scan per pose)");
  LidarRecording recording;
  recording.source = "TUM poses " + pose_file.string() + " with PCDs " + pcd_dir.string();
  recording.body_frame = "the frame the TUM poses place";
  for (std::size_t i = 0; i < poses.size(); ++i) {
    ImportedKeyframe keyframe;
    keyframe.pose = poses[i];
    keyframe.scan_body = readPcd(files[i].second);
    if (keyframe.scan_body.empty()) throw InputError(files[i].second.string(), 0, "holds no point");
    if (scans_in_world)
      keyframe.scan_body =
          import_detail::transformed(keyframe.scan_body, poses[i].T_frame_body.inverse());
    recording.keyframes.push_back(std::move(keyframe));
  }
  return recording;
}

}  // namespace mm4mm
