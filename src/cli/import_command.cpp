// mm4mm import: a session directory from another tool's saved output and a magnetometer log.

#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "commands.hpp"
#include "mm4mm/geometry/floor_height.hpp"
#include "mm4mm/import/extrinsics.hpp"
#include "mm4mm/import/fast_lio.hpp"
#include "mm4mm/import/glim_dump.hpp"
#include "mm4mm/import/hdl_graph_slam_dump.hpp"
#include "mm4mm/import/kitti_odometry.hpp"
#include "mm4mm/import/lio_sam_map.hpp"
#include "mm4mm/import/magnetometer_table.hpp"
#include "mm4mm/import/recording.hpp"
#include "mm4mm/import/ros_bag.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/session_io.hpp"

namespace mm4mm::cli {
namespace {

namespace fs = std::filesystem;

struct ImportCliOptions {
  std::string from;
  std::string input;
  std::string out;
  std::string id;
  std::string poses;    // kitti: the pose file; tum_pcd: the TUM file
  std::string pos_log;  // fast_lio
  int interval = 0;     // fast_lio: pcd_save/interval
  double time_origin_s = 0.0;
  bool scans_in_world = false;
  bool odom_poses = false;  // fast_lio_keyframes: odom_poses.txt instead of optimized_poses.txt
  double map_crop_radius_m = 0.0;
  std::string odom_topic;
  std::string cloud_topic;
  std::string imu_topic;
  KeyframeSpacing spacing;
  std::string mag;
  std::vector<std::string> mag_topics;
  std::string body_frame;
  std::string mag_columns;
  std::string mag_unit = "uT";
  std::string mag_time_unit = "s";
  double clock_offset_s = 0.0;
  std::string extrinsics;
  std::vector<double> mag_extrinsic;    // x y z qx qy qz qw
  std::vector<double> lidar_extrinsic;  // x y z qx qy qz qw
  double earth_field_uT = 0.0;
  std::optional<double> earth_vertical_uT;
  std::optional<double> frame_height_m;
  bool overwrite = false;
};

// "x y z qx qy qz qw" as the flag gives it, the quaternion of norm 1 within 1e-3.
Eigen::Isometry3d flagPose(const std::vector<double>& v, const std::string& flag) {
  const Eigen::Vector4d q(v[3], v[4], v[5], v[6]);
  if (std::abs(q.norm() - 1.0) > 1e-3)
    throw std::invalid_argument(flag + ": the quaternion (qx qy qz qw) has norm " +
                                std::to_string(q.norm()) + ", not 1");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  return T;
}

void require(const std::string& value, const std::string& flag, const std::string& from) {
  if (value.empty()) throw std::invalid_argument("--from " + from + " needs " + flag);
}

LidarRecording readLidar(const ImportCliOptions& o, const Extrinsics& extrinsics) {
  const fs::path input(o.input);
  if (o.from == "glim") return readGlimDump(input);
  if (o.from == "hdl_graph_slam") return readHdlGraphSlamDump(input);
  if (o.from == "lio_sam") return readLioSamMap(input, o.map_crop_radius_m);
  if (o.from == "fast_lio") {
    require(o.pos_log, "--pos-log (FAST-LIO's Log/pos_log.txt)", o.from);
    if (o.interval < 1)
      throw std::invalid_argument("--from fast_lio needs --interval N (pcd_save/interval)");
    return readFastLioPcdSave(input, o.pos_log, o.interval, o.time_origin_s);
  }
  if (o.from == "fast_lio_keyframes") return readFastLioKeyframes(input, !o.odom_poses);
  if (o.from == "kitti") {
    require(o.poses, "--poses (the sequence's pose file)", o.from);
    return readKittiOdometry(input, o.poses, o.time_origin_s, o.spacing);
  }
  if (o.from == "tum_pcd") {
    require(o.poses, "--poses (the TUM file)", o.from);
    return readTumWithPcds(o.poses, input, o.scans_in_world);
  }
  // bag
  require(o.odom_topic, "--odom-topic (nav_msgs/Odometry)", o.from);
  BagLidarOptions bag;
  bag.odometry_topic = o.odom_topic;
  bag.cloud_topic = o.cloud_topic;
  bag.imu_topic = o.imu_topic;
  bag.spacing = o.spacing;
  bag.T_body_lidar = extrinsics.T_body_lidar;
  return readBagLidar(input, bag);
}

MagnetometerRecording readMagnetometer(const ImportCliOptions& o) {
  const fs::path file(o.mag);
  if (file.extension() == ".bag") {
    if (o.mag_topics.empty()) {
      std::string list;
      for (const auto& [topic, type] : bagTopics(file))
        if (type == "sensor_msgs/MagneticField") list += (list.empty() ? "" : ", ") + topic;
      throw std::invalid_argument(
          "--mag " + o.mag + " is a bag: give --mag-topic (its " +
          "sensor_msgs/MagneticField topics: " + (list.empty() ? "none" : list) + ")");
    }
    return readBagMagnetometer(
        file, o.mag_topics,
        o.body_frame.empty() ? std::nullopt : std::optional<std::string>(o.body_frame));
  }
  MagnetometerTableOptions table;
  if (!o.mag_columns.empty()) parseColumnMap(o.mag_columns, &table);
  table.unit = parseFieldUnit(o.mag_unit);
  const std::map<std::string, double> time_units = {
      {"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}, {"ns", 1e-9}};
  const auto unit = time_units.find(o.mag_time_unit);
  if (unit == time_units.end())
    throw std::invalid_argument("--mag-time-unit '" + o.mag_time_unit + "': use s, ms, us or ns");
  table.seconds_per_time_unit = unit->second;
  return readMagnetometerTable(file, table);
}

// What the scans say of the frame's height above the floor, which merge uses where none is stated
// and which checks one that is: a wrong height keeps sessions at one height from being compared.
void logFloorHeight(const Session& session) {
  if (!session.hasScans()) return;
  const std::optional<FloorHeight> floor = floorHeightFromScans(session);
  const std::optional<double>& stated = session.rig.frame_height_above_floor_m;
  // To the centimetre printed, and never "-0.00".
  const double shown = floor ? std::round(floor->frame_height_m * 100.0) / 100.0 + 0.0 : 0.0;
  if (floor && stated && std::abs(*stated - floor->frame_height_m) > 0.1)
    spdlog::warn(
        "import: --frame-height-above-floor says {:.2f} m, but the scans show the floor {:.2f} m "
        "below the frame's origin",
        *stated, shown);
  else if (floor && !stated)
    spdlog::info(
        "import: the scans show the floor {:.2f} m below the frame's origin; merge takes that "
        "height (--frame-height-above-floor states it)",
        shown);
  else if (!floor && !stated)
    spdlog::warn(
        "import: the scans show no floor and no --frame-height-above-floor was given: this "
        "session's field is compared with sessions at any height");
}

void runImport(const ImportCliOptions& o) {
  const fs::path out(o.out);
  if (fs::exists(out) && !o.overwrite)
    throw std::invalid_argument("--out " + o.out + " exists; give --overwrite to replace it");
  // --overwrite replaces a session, never some other directory named by mistake.
  if (fs::exists(out) &&
      !(fs::is_directory(out) && (fs::is_empty(out) || fs::exists(out / "session.yaml"))))
    throw std::invalid_argument("--out " + o.out +
                                " is not a session directory (no session.yaml): not replaced");
  Extrinsics extrinsics;
  if (!o.extrinsics.empty()) extrinsics = readExtrinsicsYaml(o.extrinsics);
  if (!o.mag_extrinsic.empty())
    extrinsics.T_body_magnetometer = flagPose(o.mag_extrinsic, "--mag-extrinsic");
  if (!o.lidar_extrinsic.empty())
    extrinsics.T_body_lidar = flagPose(o.lidar_extrinsic, "--lidar-extrinsic");
  const LidarRecording lidar = readLidar(o, extrinsics);
  const MagnetometerRecording magnetometer = readMagnetometer(o);
  ImportOptions options;
  // "sessions/run1/" names run1 as well.
  const fs::path named = out.filename().empty() ? out.parent_path() : out;
  options.id = o.id.empty() ? named.filename().string() : o.id;
  options.clock_offset_s = o.clock_offset_s;
  options.T_body_magnetometer = extrinsics.T_body_magnetometer;
  if (extrinsics.T_body_lidar) options.T_body_lidar = *extrinsics.T_body_lidar;
  if (o.earth_field_uT > 0.0) options.earth_field_horizontal_uT = o.earth_field_uT;
  options.earth_field_vertical_uT = o.earth_vertical_uT;
  options.frame_height_above_floor_m = o.frame_height_m;
  ImportReport report;
  const Session session = assembleSession(lidar, magnetometer, options, &report);
  writeSession(session, out);

  spdlog::info("import: {} ({} keyframes, {} scan points), body frame: {}", lidar.source,
               report.keyframes, report.scan_points, lidar.body_frame);
  spdlog::info(
      "import: magnetometer {}{}: {} samples kept, {} before and {} after the poses "
      "dropped, median |B| {:.1f} uT",
      magnetometer.source, magnetometer.frame.empty() ? "" : " (frame " + magnetometer.frame + ")",
      report.samples_kept, report.samples_before_poses, report.samples_after_poses,
      report.median_field_uT);
  if (!options.T_body_magnetometer && magnetometer.T_body_magnetometers.empty())
    spdlog::warn(
        "import: no T_body_magnetometer given: the magnetometer's axes are taken as the "
        "body's (--extrinsics, or --body-frame with a bag's /tf_static)");
  for (const std::string& note : lidar.notes) spdlog::info("import: note: {}", note);
  logFloorHeight(session);
  spdlog::info("import: wrote session '{}' to {}", session.id, out.string());
}

}  // namespace

void addImportCommand(CLI::App& app) {
  auto options = std::make_shared<ImportCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "import",
      "write a session directory from another tool's saved output and a magnetometer log");
  cmd->add_option("--from", options->from, "the source")
      ->required()
      ->check(CLI::IsMember({"glim", "hdl_graph_slam", "lio_sam", "fast_lio", "fast_lio_keyframes",
                             "kitti", "tum_pcd", "bag"}));
  cmd->add_option("--input", options->input,
                  "the source's directory (glim, hdl_graph_slam, lio_sam, fast_lio: PCD/, "
                  "fast_lio_keyframes, kitti: the sequence, tum_pcd: the PCDs) or bag")
      ->required();
  cmd->add_option("--out", options->out, "the session directory to write")->required();
  cmd->add_option("--id", options->id, "session id (default: the --out directory's name)");
  cmd->add_flag("--overwrite", options->overwrite, "replace --out when it exists");
  cmd->add_option("--poses", options->poses, "kitti: the pose file; tum_pcd: the TUM file");
  cmd->add_option("--pos-log", options->pos_log, "fast_lio: Log/pos_log.txt");
  cmd->add_option("--interval", options->interval, "fast_lio: pcd_save/interval (scans per PCD)");
  cmd->add_option("--time-origin", options->time_origin_s,
                  "fast_lio, kitti: the first scan's time (s) on the magnetometer's clock; their "
                  "pose times are relative");
  cmd->add_flag("--scans-in-world", options->scans_in_world,
                "tum_pcd: the PCDs are in the poses' frame, not the body frame");
  cmd->add_flag("--odom-poses", options->odom_poses,
                "fast_lio_keyframes: odom_poses.txt instead of optimized_poses.txt");
  cmd->add_option("--map-crop-radius", options->map_crop_radius_m,
                  "lio_sam: give each keyframe the saved map within this radius (m; default 0: "
                  "a magnetic-only session)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--odom-topic", options->odom_topic, "bag: nav_msgs/Odometry topic");
  cmd->add_option("--cloud-topic", options->cloud_topic,
                  "bag: sensor_msgs/PointCloud2 topic (none: a magnetic-only session)");
  cmd->add_option("--imu-topic", options->imu_topic,
                  "bag: sensor_msgs/Imu whose roll and pitch replace the odometry's (odometry "
                  "that knows only heading)");
  cmd->add_option("--keyframe-distance", options->spacing.distance_m,
                  "bag, kitti: a keyframe per this many metres...")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--keyframe-angle", options->spacing.angle_deg, "...or degrees of turn")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--mag", options->mag, "magnetometer: a .bag, or a CSV/text table")->required();
  cmd->add_option("--mag-topic", options->mag_topics,
                  "bag: sensor_msgs/MagneticField topic (repeat for a rig of several: sensor i "
                  "is the i-th topic)");
  cmd->add_option("--body-frame", options->body_frame,
                  "bag: look the magnetometer's pose in this frame up in /tf_static");
  cmd->add_option("--mag-columns", options->mag_columns,
                  "table: columns as t=NAME,x=NAME,y=NAME,z=NAME (names or 0-based indices; "
                  "default t,x,y,z)");
  cmd->add_option("--mag-unit", options->mag_unit, "table: field unit T, G, mG, uT or nT");
  cmd->add_option("--mag-time-unit", options->mag_time_unit, "table: time unit s, ms, us or ns");
  cmd->add_option("--clock-offset", options->clock_offset_s,
                  "seconds added to magnetometer times to put them on the poses' clock");
  cmd->add_option("--extrinsics", options->extrinsics,
                  "YAML with T_body_magnetometer and T_body_lidar (translation, quaternion xyzw)");
  cmd->add_option("--mag-extrinsic", options->mag_extrinsic,
                  "T_body_magnetometer as x y z qx qy qz qw (over --extrinsics)")
      ->expected(7);
  cmd->add_option("--lidar-extrinsic", options->lidar_extrinsic,
                  "T_body_lidar as x y z qx qy qz qw (over --extrinsics)")
      ->expected(7);
  cmd->add_option("--earth-field-horizontal", options->earth_field_uT,
                  "the site's horizontal Earth field (uT, from a geomagnetic model)")
      ->check(CLI::Range(0.0, 100.0));
  cmd->add_option("--earth-field-vertical", options->earth_vertical_uT,
                  "the site's vertical Earth field along z up (uT, negative in the northern "
                  "hemisphere: a geomagnetic model's Z with its sign turned); anchors the "
                  "atlas's fused magnetic map")
      ->check(CLI::Range(-100.0, 100.0));
  cmd->add_option("--frame-height-above-floor", options->frame_height_m,
                  "the odometry frame's origin above the floor (m): the LiDAR's or IMU's height "
                  "where the recording starts, for a LiDAR-inertial odometry; sessions whose "
                  "magnetometers are at other heights are then not searched by the field alone")
      ->check(CLI::Range(-1.0, 10.0));
  cmd->callback([options] { runImport(*options); });
}

}  // namespace mm4mm::cli
