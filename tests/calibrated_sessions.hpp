#pragma once
// The pipeline's calibration step as the command line runs it before match, merge and add: each
// session's magnetometers calibrated from its own readings and the result stated in its rig.

#include <vector>

#include "mm4mm/magnetic/self_calibration.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

inline void calibrate(std::vector<Session>* sessions,
                      const CalibrationConfig& config = CalibrationConfig{}) {
  std::vector<Session*> pointers;
  for (Session& s : *sessions) pointers.push_back(&s);
  calibrateSessions(pointers, config);
}

inline std::vector<Session> calibrated(std::vector<Session> sessions) {
  calibrate(&sessions);
  return sessions;
}

}  // namespace mm4mm
