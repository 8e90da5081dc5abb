#pragma once
// Internal to src/io: a session directory's session.yaml, which holds the session id and the
// sensor rig (magnetometer positions in the body frame, optional LiDAR pose T_body_lidar):
//   id: s0
//   magnetometers:                         # at least one; body frame, metres
//     - [x, y, z]                          # a position alone: calibrated from its own data
//     - position: [x, y, z]                # or a position with its calibration, µT
//       hard_iron_uT: [hx, hy, hz]         #   (magnetometer_calibration.hpp): any of the three
//       soft_iron: [[..], [..], [..]]      #   keys, the others default to zero / identity
//       speed_uT_per_mps: [kx, ky, kz]
//   earth_field: {horizontal_uT: H}        # optional: the site's horizontal Earth field
//   lidar: {translation: [x, y, z], quaternion: [x, y, z, w]}   # optional, default identity
// and ground_truth_magnetometers.yaml, the simulator's true calibration of each magnetometer:
//   magnetometers: [{hard_iron_uT: [..], soft_iron: [[..], ..], speed_uT_per_mps: [..]}, ...]

#include <filesystem>
#include <string>

#include "mm4mm/session/session.hpp"

namespace mm4mm::io_detail {

/// Whether `id` can name files in an atlas (trajectories/<id>.txt): not empty, not "." or "..",
/// no '/', '\\', line break or NUL.
bool isValidId(const std::string& id);

/// Reads session.yaml into `session->id` and `session->rig`, leaving the other fields alone.
/// Throws InputError (file, line, problem) on a missing file or key, a malformed value, an id
/// unusable as a file name, or a LiDAR quaternion whose norm is off from 1 by more than 1e-3.
void readSessionYaml(const std::filesystem::path& file, Session* session);

/// session.yaml's text for `session`'s id and rig, numbers in shortest round-trip form.
std::string formatSessionYaml(const Session& session);

/// Reads ground_truth_magnetometers.yaml: one calibration per magnetometer of a rig of
/// `magnetometers` sensors. Throws InputError as readSessionYaml does.
std::vector<MagnetometerCalibration> readTrueCalibration(const std::filesystem::path& file,
                                                         std::size_t magnetometers);
std::string formatTrueCalibration(const std::vector<MagnetometerCalibration>& calibrations);

}  // namespace mm4mm::io_detail
