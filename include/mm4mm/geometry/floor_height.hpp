#pragma once
// The session frame's height above the floor, from the floor its scans see. Near the floor the
// field changes with height (docs/bench/field_height.csv: local r 0.75 between 0.3 m and 0.8 m),
// so sessions whose magnetometers are at other heights must not be compared by their field; a
// magnetometer's height in its session frame says nothing about the floor until the frame's own
// height above the floor is known. Users state it where they know it (session.yaml
// frame_height_above_floor_m); otherwise the scans hold it: the floor is the lowest level surface
// around every keyframe.

#include <optional>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct FloorHeightConfig {
  /// Scan points within this horizontal distance of the body count: a LiDAR 0.8 m up with a 30°
  /// downward field of view first meets the floor 1.4 m away.
  double radius_m = 4.0;
  double min_range_m = 0.3;  ///< nearer returns to the LiDAR are dropped: the rig, or no return
  double bin_m = 0.02;       ///< histogram bin of the points' heights below the body
  /// The floor is the lowest bin holding at least this share of the fullest bin's points: a
  /// shelf deck or the ceiling may hold more points than the floor, nothing lies below it but
  /// noise and the odd stairwell.
  double min_share_of_peak = 0.3;
  int min_floor_points = 200;  ///< fewer points on the floor than this: no floor seen
  /// The floor's bins hold at least this many times the points of a bin 0.1-0.3 m above it.
  double min_floor_contrast = 3.0;
  int max_keyframes = 200;   ///< keyframes spread evenly over the session, for speed ...
  int max_points = 1000000;  ///< ... and points spread evenly over their scans
};

struct FloorHeight {
  /// The session frame's origin above the floor (m): the body's height above the floor less the
  /// median height of the keyframes in the frame (their z drift is the odometry's).
  double frame_height_m = 0.0;
  double body_height_m = 0.0;  ///< the body origin's height above the floor under it (m)
  int floor_points = 0;        ///< points in the floor's bins
  double contrast = 0.0;       ///< their points per bin over a bin's 0.1-0.3 m above them
  int keyframes = 0;           ///< keyframes whose scans were read
};

/// The floor from the keyframe scans, in a session frame whose z is up (as every session's is);
/// nullopt for a session without scans or whose scans see no floor. Deterministic.
std::optional<FloorHeight> floorHeightFromScans(const Session& session,
                                                const FloorHeightConfig& config = {});

struct FrameHeight {
  double height_m = 0.0;    ///< the session frame's origin above the floor
  bool from_scans = false;  ///< estimated from the scans (floorHeightFromScans), not stated
};

/// The frame's height above the floor as stated (SensorRig::frame_height_above_floor_m), else as
/// its scans show it, else nullopt.
std::optional<FrameHeight> frameHeightAboveFloor(const Session& session);

}  // namespace mm4mm
