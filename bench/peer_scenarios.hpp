#pragma once
// The peer benchmark's scenarios (simulated sessions with their 0.25 m point maps) and the
// comparisons of the paper's Table I run on them (bench/peer_bench.cpp).

#include <string>
#include <utility>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm::peers {

struct Scenario {
  std::string preset;
  int seed = 0;
  std::vector<Session> sessions;
  std::vector<PointCloud> maps;  // 0.25 m point maps, each session's frame
  double calibration_s = 0.0;    // the pipeline's calibration of every session's magnetometers
};

/// The sessions of `preset` (warehouse, corridor, random, disjoint) at `seed`, with their maps,
/// the magnetometers calibrated as `mm4mm merge` does before it merges (calibrateSessions with
/// the default config; the estimate is stated in each rig, so every mm4mm method applies it).
Scenario simulateScenario(const std::string& preset, int seed);

// A comparison: which sessions take part, and which pairs of them are judged.
struct Comparison {
  std::string name;
  std::vector<int> sessions;
  std::vector<std::pair<int, int>> judged;
  bool disjoint = false;  // success = the second session is not placed
};

/// The paper's comparisons for the scenario: 1+2, 3+4, (1+2)+(3+4), all (corridor: 1+2, 2+3,
/// all; disjoint: the first session and the disjoint one).
std::vector<Comparison> comparisonsFor(const Scenario& s);

}  // namespace mm4mm::peers
