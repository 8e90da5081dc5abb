#pragma once
// A mapping session as docs/design.md defines it: keyframe odometry poses in the session frame,
// magnetometer samples in the body frame, optional keyframe scans and ground truth.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/core/trajectory.hpp"
#include "mm4mm/session/magnetometer_calibration.hpp"

namespace mm4mm {

/// Points of one scan, in metres, in the body frame of the keyframe they belong to.
using PointCloud = std::vector<Eigen::Vector3f>;

/// A pose with its time stamp. `T_frame_body` maps body-frame points into the pose's frame.

/// One magnetometer reading: field in µT along the body axes of sensor `sensor`.
struct MagnetometerSample {
  double time_s = 0.0;
  int sensor = 0;
  Eigen::Vector3d field_body_uT = Eigen::Vector3d::Zero();
};

/// The sensors carried by the robot, fixed for a session.
struct SensorRig {
  /// Magnetometer positions in the body frame (m); their axes are the body axes.
  std::vector<Eigen::Vector3d> magnetometers_body;
  /// LiDAR pose in the body frame. Scans are stored already in the body frame.
  Eigen::Isometry3d T_body_lidar = Eigen::Isometry3d::Identity();
  /// Calibrations stated with the rig (session.yaml), one entry per magnetometer or none at all;
  /// an empty entry leaves that sensor to be calibrated from its own data.
  std::vector<std::optional<MagnetometerCalibration>> calibrations;
  /// Magnitude of the local Earth field's horizontal component (µT, as a geomagnetic model such as
  /// the WMM gives it for the site), where known: it fixes the scale that a calibration from the
  /// robot's own data cannot (the data say the field's shape, not its unit).
  std::optional<double> earth_field_horizontal_uT;
  /// The local Earth field's vertical component along the session frame's z (up, µT: negative in
  /// the northern hemisphere; a geomagnetic model's Z, positive down, with its sign turned), where
  /// known: the fused magnetic map's anchor (field_offsets.hpp). A level robot's own data cannot
  /// fix its vertical hard iron, so without it the atlas's B_v is right only up to a constant.
  std::optional<double> earth_field_vertical_uT;
  /// Height of the session frame's origin above the floor the body moves on (m), where known:
  /// the odometry's origin where the body started (the LiDAR's or IMU's height for a
  /// LiDAR-inertial odometry), 0 for a frame on the floor. With it the height of the session's
  /// magnetometers above the floor is known, and two sessions whose magnetometers are at
  /// different heights are not compared by their field, which changes with height
  /// (MergeConfig::max_height_difference_m).
  std::optional<double> frame_height_above_floor_m;
};

struct Session {
  std::string id;
  SensorRig rig;
  /// Keyframe odometry poses in the session frame, strictly increasing in time.
  std::vector<StampedPose> keyframes;
  /// The odometry's full pose stream in the session frame (optional, odometry.txt), strictly
  /// increasing in time: where given, magnetometer samples are placed and levelled by it instead
  /// of by the keyframes, which are too sparse for a body that sways or tilts between them.
  std::vector<StampedPose> odometry;
  /// Magnetometer samples sorted by time (ties ordered by sensor index).
  std::vector<MagnetometerSample> magnetometer;
  /// One scan per keyframe, or empty for a magnetic-only session.
  std::vector<PointCloud> scans;
  /// The same keyframes' true poses in the world frame, where known (simulated sessions).
  std::optional<std::vector<StampedPose>> ground_truth;
  /// Each magnetometer's true calibration, where known (simulated sessions).
  std::optional<std::vector<MagnetometerCalibration>> true_calibration;

  bool hasScans() const { return !scans.empty(); }
};

}  // namespace mm4mm
