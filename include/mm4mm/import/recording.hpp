#pragma once
// What an importer reads from another tool's files, before it becomes a session directory: the
// LiDAR side (keyframe poses with their scans, and the odometry's full pose stream where the tool
// saved one) and the magnetometer side (samples on the magnetometer's own axes and clock). Each
// source (GLIM, hdl_graph_slam, LIO-SAM, FAST-LIO2, KITTI, TUM + PCDs, ROS bags, CSV loggers) has
// its own header beside this one that returns these types; assembleSession puts them together.

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// Units a magnetometer source may be in, and the factor to µT.
enum class FieldUnit { kTesla, kGauss, kMilliGauss, kMicroTesla, kNanoTesla };

/// µT per unit of `unit`.
double microTeslaPer(FieldUnit unit);

/// Parses "T", "G", "mG", "uT" (or "µT"), "nT"; std::invalid_argument naming the choices
/// otherwise.
FieldUnit parseFieldUnit(const std::string& text);

/// The unit's usual symbol.
std::string unitName(FieldUnit unit);

/// The message for a field whose median magnitude is `median_uT` after reading it as `assumed`:
/// which unit would put it at an Earth-like 20-100 µT. Empty when the median is plausible µT.
std::string implausibleFieldMessage(double median_uT, FieldUnit assumed);

/// One keyframe: its pose in the session frame, and its scan in the body frame of that pose.
struct ImportedKeyframe {
  StampedPose pose;
  PointCloud scan_body;
};

/// When the motion since the last keyframe makes a new one.
struct KeyframeSpacing {
  double distance_m = 1.0;
  double angle_deg = 15.0;
};

/// Whether `pose` has moved or turned far enough from `last` to make a new keyframe.
bool movedEnough(const Eigen::Isometry3d& last, const Eigen::Isometry3d& pose,
                 const KeyframeSpacing& spacing);

/// Indices of the poses to keep as keyframes: the first, then each pose that has moved
/// `spacing.distance_m` or turned `spacing.angle_deg` from the last kept one.
std::vector<std::size_t> selectKeyframes(const std::vector<StampedPose>& poses,
                                         const KeyframeSpacing& spacing);

/// The LiDAR odometry or SLAM side of a recording, in one body frame and one session frame.
struct LidarRecording {
  /// What was read, for the log ("GLIM dump /data/run1: 14 submaps").
  std::string source;
  /// The frame the poses place and the scans are in, as the source tool names it ("GLIM's imu
  /// frame", "KITTI velodyne"); written into the log so the user can set extrinsics against it.
  std::string body_frame;
  /// Keyframes strictly increasing in time; scans may be empty only where `scans_saved` is false.
  std::vector<ImportedKeyframe> keyframes;
  /// The odometry's full pose stream, where the source keeps one (optional; places the
  /// magnetometer samples more finely than the keyframes).
  std::vector<StampedPose> odometry;
  /// False when the source does not save per-keyframe scans (the session is then magnetic-only).
  bool scans_saved = true;
  /// What the source holds that the session drops or approximates, one sentence each.
  std::vector<std::string> notes;
};

/// The magnetometer side: samples in µT along the magnetometer's own axes, on its own clock.
struct MagnetometerRecording {
  std::string source;
  /// Sensor index 0 unless the source carries several magnetometers; sorted by time.
  std::vector<MagnetometerSample> samples;
  /// The frame the samples are in, as the source names it (a bag's frame_id), where known.
  std::string frame;
  /// Each sensor's pose in the body frame, where the source itself states it (a bag's static
  /// transforms): empty, or one per sensor. ImportOptions::T_body_magnetometer overrides it.
  std::vector<Eigen::Isometry3d> T_body_magnetometers;
  /// The unit the source's numbers were read as (and converted from), for the plausibility check.
  FieldUnit read_as = FieldUnit::kMicroTesla;
};

/// What the user states about the rig and the clocks.
struct ImportOptions {
  /// The session id (session.yaml `id`): usable as a file name.
  std::string id;
  /// Seconds added to every magnetometer time to put it on the poses' clock.
  double clock_offset_s = 0.0;
  /// The magnetometer's pose in the body frame (axes rotate the samples into body axes); for a
  /// recording of one magnetometer only.
  std::optional<Eigen::Isometry3d> T_body_magnetometer;
  /// The LiDAR's pose in the body frame, written to session.yaml for the record (scans are
  /// already in the body frame).
  Eigen::Isometry3d T_body_lidar = Eigen::Isometry3d::Identity();
  /// The local Earth field's horizontal magnitude (µT), where known (session.yaml earth_field).
  std::optional<double> earth_field_horizontal_uT;
  /// Its vertical component along z up (µT, session.yaml earth_field.vertical_uT), where known.
  std::optional<double> earth_field_vertical_uT;
  /// The odometry frame's origin above the floor (m, session.yaml frame_height_above_floor_m),
  /// where known: what tells sessions whose magnetometers are at other heights apart.
  std::optional<double> frame_height_above_floor_m;
};

/// What assembleSession kept and dropped, for the log.
struct ImportReport {
  std::size_t keyframes = 0;
  std::size_t scan_points = 0;
  std::size_t samples_kept = 0;
  std::size_t samples_before_poses = 0;  ///< dropped: earlier than the first pose
  std::size_t samples_after_poses = 0;   ///< dropped: later than the last pose
  double median_field_uT = 0.0;          ///< median |B| of the kept samples
};

/// The session of `lidar` and `magnetometer`: samples shifted by the clock offset, rotated into
/// body axes, and those outside the pose stream's span (odometry where given, else keyframes)
/// dropped and counted. Throws InputError (naming the sources) when the two have no common time
/// span, when no sample is left, or when the field's median magnitude cannot be µT (outside
/// [1, 1000] µT: the message says which unit the numbers fit, tesla, gauss or nT), and
/// std::invalid_argument when `options.T_body_magnetometer` is given for several magnetometers.
Session assembleSession(const LidarRecording& lidar, const MagnetometerRecording& magnetometer,
                        const ImportOptions& options, ImportReport* report = nullptr);

}  // namespace mm4mm
