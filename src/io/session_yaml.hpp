#pragma once
// Internal to src/io: a session directory's session.yaml, which holds the session id and the
// sensor rig (magnetometer positions in the body frame, optional LiDAR pose T_body_lidar):
//   id: s0
//   magnetometers: [[x, y, z], ...]        # metres, body frame, at least one
//   lidar: {translation: [x, y, z], quaternion: [x, y, z, w]}   # optional, default identity

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

}  // namespace mm4mm::io_detail
