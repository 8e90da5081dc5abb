#include "mm4mm/merge/atlas_poses.hpp"

#include <stdexcept>

namespace mm4mm {

void checkAtlasPoses(const std::vector<Session>& sessions,
                     const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                     const std::string& caller) {
  if (T_atlas_keyframe.size() != sessions.size())
    throw std::invalid_argument(caller + ": " + std::to_string(sessions.size()) + " sessions but " +
                                std::to_string(T_atlas_keyframe.size()) +
                                " lists of optimised keyframe poses");
  for (std::size_t i = 0; i < sessions.size(); ++i) {
    const Session& s = sessions[i];
    if (T_atlas_keyframe[i].size() != s.keyframes.size())
      throw std::invalid_argument(caller + ": session '" + s.id + "' has " +
                                  std::to_string(s.keyframes.size()) + " keyframes but " +
                                  std::to_string(T_atlas_keyframe[i].size()) + " optimised poses");
    if (s.hasScans() && s.scans.size() != s.keyframes.size())
      throw std::invalid_argument(caller + ": session '" + s.id + "' has " +
                                  std::to_string(s.scans.size()) + " scans for " +
                                  std::to_string(s.keyframes.size()) + " keyframes");
    for (std::size_t k = 0; k < T_atlas_keyframe[i].size(); ++k)
      if (!T_atlas_keyframe[i][k].matrix().allFinite())
        throw std::invalid_argument(caller + ": session '" + s.id + "' optimised pose " +
                                    std::to_string(k) + " is not finite");
  }
}

}  // namespace mm4mm
