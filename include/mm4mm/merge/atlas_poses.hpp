#pragma once
// The check every atlas output runs first: sessions and their atlas-frame keyframe poses agree.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// Throws std::invalid_argument unless `T_atlas_keyframe` holds one pose list per session, each
/// exactly as long as that session's keyframes, with finite poses, and every session's scans
/// are either absent or one per keyframe. `caller` starts the message (for example
/// "buildMergedCloud"), which names the session and both counts.
void checkAtlasPoses(const std::vector<Session>& sessions,
                     const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                     const std::string& caller);

}  // namespace mm4mm
