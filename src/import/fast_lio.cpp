#include "mm4mm/import/fast_lio.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "../io/text_io.hpp"
#include "import_text.hpp"
#include "mm4mm/import/floor_levelling.hpp"
#include "mm4mm/import/kitti_odometry.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/pcd_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

// dump_lio_state_to_log (laserMapping.cpp): 25 numbers per line, "%lf " each, "\r\n" at the end.
constexpr int kPosLogColumns = 25;

struct PosLog {
  std::vector<StampedPose> poses;
  Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -9.81);
  double scan_period_s = 0.0;  ///< the median time between lines: one scan's sweep
};

PosLog readPosLog(const fs::path& file, double time_origin_s) {
  const std::string content = io_detail::readWholeFile(file);
  const std::string name = file.string();
  PosLog log;
  io_detail::forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty()) return;
    const std::vector<std::string_view> tokens = io_detail::splitWhitespace(text);
    if (tokens.size() != kPosLogColumns)
      throw InputError(name, line,
                       "a pos_log line holds " + std::to_string(kPosLogColumns) +
                           " numbers (t, rotation vector, position, 0 0 0, velocity, 0 0 0, "
                           "gyro bias, accelerometer bias, gravity), found " +
                           std::to_string(tokens.size()));
    double v[kPosLogColumns];
    for (int k = 0; k < kPosLogColumns; ++k)
      v[k] = io_detail::parseFiniteNumber(tokens[k], "value", name, line);
    StampedPose pose;
    pose.time_s = v[0] + time_origin_s;
    const Eigen::Vector3d rotation_vector(v[1], v[2], v[3]);
    const double angle = rotation_vector.norm();
    pose.T_frame_body.linear() =
        angle > 0.0 ? Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix()
                    : Eigen::Matrix3d::Identity();
    pose.T_frame_body.translation() = Eigen::Vector3d(v[4], v[5], v[6]);
    if (!log.poses.empty() && pose.time_s <= log.poses.back().time_s)
      throw InputError(name, line, "times do not increase");
    log.poses.push_back(pose);
    log.gravity = Eigen::Vector3d(v[22], v[23], v[24]);
  });
  if (log.poses.empty())
    throw InputError(name, 0,
                     "holds no pose: FAST-LIO writes Log/pos_log.txt only when its ROS parameter "
                     "runtime_pos_log_enable is true (its launch files set 0); set it to 1 and "
                     "record again");
  if (log.poses.size() < 2) throw InputError(name, 0, "holds fewer than two poses");
  // A line's time is its scan's start (Measures.lidar_beg_time - first_lidar_time, in
  // dump_lio_state_to_log of FAST-LIO's laserMapping.cpp), but its state is the one the update
  // left at the scan's end, where FAST-LIO undistorts the scan to and publishes its odometry.
  // The log keeps no end time; a spinning LiDAR sweeps for one scan period, so each pose is
  // stamped at its start plus the median time between lines.
  std::vector<double> gaps;
  for (std::size_t k = 1; k < log.poses.size(); ++k)
    gaps.push_back(log.poses[k].time_s - log.poses[k - 1].time_s);
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2),
                   gaps.end());
  log.scan_period_s = gaps[gaps.size() / 2];
  for (StampedPose& pose : log.poses) {
    pose.time_s += log.scan_period_s;
    if (!std::isfinite(pose.time_s))
      throw InputError(name, 0, "its times are too large to be seconds since the first scan");
  }
  if (!(log.gravity.norm() > 1.0))
    throw InputError(name, 0, "its last gravity estimate is not a gravity vector");
  return log;
}

// The rotation that turns FAST-LIO's world (the IMU frame at start) so its gravity points down.
Eigen::Isometry3d levelling(const Eigen::Vector3d& gravity) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond::FromTwoVectors(gravity.normalized(), -Eigen::Vector3d::UnitZ())
                   .toRotationMatrix();
  return T;
}

}  // namespace

LidarRecording readFastLioPcdSave(const fs::path& pcd_dir, const fs::path& pos_log, int interval,
                                  double time_origin_s) {
  if (interval < 1)
    throw std::invalid_argument("FAST-LIO's pcd_save/interval must be at least 1, got " +
                                std::to_string(interval));
  const PosLog log = readPosLog(pos_log, time_origin_s);
  const Eigen::Isometry3d level = levelling(log.gravity);
  const auto files = import_detail::numberedEntries(pcd_dir, [](const std::string& name) {
    return import_detail::numberBetween(name, "scans_", ".pcd");
  });
  if (files.empty() && fs::exists(pcd_dir / "scans.pcd"))
    throw InputError(
        pcd_dir.string(), 0,
        "holds scans.pcd alone: FAST-LIO saved every scan into one world-frame cloud "
        "(pcd_save/interval: -1, its default), so no scan can be placed by its own pose and "
        "there is no keyframe to import. Set pcd_save/interval to a number of scans (10 takes "
        "about one second per keyframe) with pcd_save_en: true, and record again");
  if (files.empty())
    throw InputError(pcd_dir.string(), 0,
                     "holds no scans_N.pcd (FAST-LIO's pcd_save output: set pcd_save/pcd_save_en "
                     "true and pcd_save/interval to a number of scans)");
  LidarRecording recording;
  recording.source = "FAST-LIO " + pcd_dir.string() + " with " + pos_log.string();
  recording.body_frame = "FAST-LIO's body (IMU) frame";
  for (const StampedPose& pose : log.poses)
    recording.odometry.push_back({pose.time_s, level * pose.T_frame_body});
  for (std::size_t k = 0; k < files.size(); ++k) {
    const long number = files[k].first;
    if (number != static_cast<long>(k) + 1)
      throw InputError(files[k].second.string(), 0,
                       "scans_" + std::to_string(k + 1) + ".pcd is missing before it");
    const std::size_t first = k * static_cast<std::size_t>(interval);
    const std::size_t middle = first + static_cast<std::size_t>(interval) / 2;
    if (first + static_cast<std::size_t>(interval) > log.poses.size())
      throw InputError(files[k].second.string(), 0,
                       "needs pos_log lines " + std::to_string(first + 1) + " to " +
                           std::to_string(first + interval) + ", but " + pos_log.string() +
                           " has " + std::to_string(log.poses.size()) + " (is pcd_save/interval " +
                           std::to_string(interval) + "?)");
    ImportedKeyframe keyframe;
    keyframe.pose = {log.poses[middle].time_s, level * log.poses[middle].T_frame_body};
    const PointCloud world = readPcd(files[k].second);
    if (world.empty()) throw InputError(files[k].second.string(), 0, "holds no point");
    keyframe.scan_body =
        import_detail::transformed(world, log.poses[middle].T_frame_body.inverse());
    recording.keyframes.push_back(std::move(keyframe));
  }
  // FAST-LIO writes a pos_log line per scan and a scans_N.pcd per `interval` scans, the rest in
  // scans.pcd at shutdown: fewer than `interval` lines are left after the last scans_N.pcd. More
  // means each file holds more scans than `interval`, and the keyframes would take poses from
  // scans far from their own.
  const std::size_t covered = files.size() * static_cast<std::size_t>(interval);
  if (log.poses.size() >= covered + static_cast<std::size_t>(interval))
    throw InputError(pos_log.string(), 0,
                     "has " + std::to_string(log.poses.size()) + " lines for " +
                         std::to_string(files.size()) + " scans_N.pcd of " +
                         std::to_string(interval) +
                         " scans each: " + std::to_string(log.poses.size() - covered) +
                         " left over, a whole interval or more (is pcd_save/interval about " +
                         std::to_string(log.poses.size() / files.size()) + "?)");
  recording.notes.push_back(
      "each scans_N.pcd holds " + std::to_string(interval) +
      " scans in the world frame; its keyframe is the middle scan's pose and its points are taken "
      "into that body frame (the other scans' points keep their world-frame placement)");
  recording.notes.push_back(
      "FAST-LIO's world frame rotated so that its gravity estimate points down");
  recording.notes.push_back(
      "each pose stamped at its scan's end: pos_log's start time plus the median scan period (" +
      std::to_string(log.scan_period_s) + " s)");
  if (fs::exists(pcd_dir / "scans.pcd"))
    recording.notes.push_back("scans.pcd (the scans after the last full interval) left out");
  return recording;
}

namespace {

// The fork saves its poses in camera_init, the IMU frame at start, without the gravity that
// FAST-LIO estimated in it: the frame is levelled by the floor the keyframes' scans see
// (floor_levelling.hpp), or the import refused where they show none.
void levelByFloor(const fs::path& dir, LidarRecording* recording) {
  // At most 60 keyframes spread over the session, placed by their poses: enough floor to fit.
  PointCloud points;
  const std::size_t n = recording->keyframes.size(), step = std::max<std::size_t>(1, n / 60);
  for (std::size_t i = 0; i < n; i += step) {
    const ImportedKeyframe& k = recording->keyframes[i];
    const Eigen::Isometry3f T = k.pose.T_frame_body.cast<float>();
    for (const Eigen::Vector3f& p : k.scan_body) points.push_back(T * p);
  }
  const std::optional<FloorLevelling> level = levellingFromFloor(points);
  if (!level)
    throw InputError(dir.string(), 0,
                     "its poses are in FAST-LIO's camera_init (the IMU frame at start, not "
                     "levelled) and its scans show no floor or ceiling to level them by (no plane "
                     "within 20 degrees of horizontal holds 5 % of the points); import FAST-LIO's "
                     "own PCD/ and Log/pos_log.txt (--from fast_lio), which carry its gravity");
  Eigen::Isometry3d T_level_frame = Eigen::Isometry3d::Identity();
  T_level_frame.linear() = level->R_level_frame.toRotationMatrix();
  for (ImportedKeyframe& k : recording->keyframes)
    k.pose.T_frame_body = T_level_frame * k.pose.T_frame_body;
  char note[200];
  std::snprintf(note, sizeof note,
                "camera_init levelled by the floor or ceiling its scans see: turned %.2f deg "
                "(a plane of %d of %d points thinned to 0.1 m)",
                level->tilt_deg, level->inliers, level->points);
  recording->notes.push_back(note);
}

}  // namespace

LidarRecording readFastLioKeyframes(const fs::path& dir, bool optimized) {
  const fs::path pose_file = dir / (optimized ? "optimized_poses.txt" : "odom_poses.txt");
  const std::vector<Eigen::Isometry3d> poses = readKittiPoses(pose_file);
  const fs::path times_file = dir / "times.txt";
  const std::string content = io_detail::readWholeFile(times_file);
  std::vector<double> times;
  io_detail::forEachLine(content, [&](int line, std::string_view text) {
    if (text.empty()) return;
    times.push_back(io_detail::parseFiniteNumber(text, "time", times_file.string(), line));
  });
  const auto scans = import_detail::numberedEntries(dir / "Scans", [](const std::string& name) {
    return name.size() == 10 ? import_detail::numberBetween(name, "", ".pcd") : std::nullopt;
  });
  const std::size_t count = std::min({poses.size(), times.size(), scans.size()});
  if (count == 0) throw InputError(dir.string(), 0, "holds no keyframe (Scans/, times.txt, poses)");
  LidarRecording recording;
  recording.source = "FAST-LIO keyframes " + dir.string();
  recording.body_frame = "FAST-LIO's body (IMU) frame";
  for (std::size_t i = 0; i < count; ++i) {
    if (scans[i].first != static_cast<long>(i))
      throw InputError((dir / "Scans").string(), 0,
                       "keyframe scan " + std::to_string(i) + " is missing");
    ImportedKeyframe keyframe;
    keyframe.pose = {times[i], poses[i]};
    keyframe.scan_body = readPcd(scans[i].second);
    if (keyframe.scan_body.empty()) throw InputError(scans[i].second.string(), 0, "holds no point");
    recording.keyframes.push_back(std::move(keyframe));
  }
  levelByFloor(dir, &recording);
  const std::size_t most = std::max({poses.size(), times.size(), scans.size()});
  if (most > count)
    recording.notes.push_back(std::to_string(most - count) +
                              " last keyframe(s) without a pose, time or scan in all three files "
                              "left out (the optimised poses are rewritten once a second)");
  return recording;
}

}  // namespace mm4mm
