#include "peer_scenarios.hpp"

#include <chrono>
#include <filesystem>
#include <stdexcept>

#include "mm4mm/geometry/point_map.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/magnetic/self_calibration.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace mm4mm::peers {

namespace fs = std::filesystem;

Scenario simulateScenario(const std::string& preset, int seed) {
  Scenario s{preset, seed, {}, {}};
  sim::SimulationConfig config;
  int count = 4;
  if (preset == "corridor") {
    config = loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "corridor.yaml");
    count = 3;
  } else if (preset == "random") {
    config.layout.mode = "random";
  } else if (preset == "disjoint") {
    config.layout.disjoint_session = true;
    count = 5;
  } else if (preset != "warehouse") {
    throw std::invalid_argument("unknown preset " + preset);
  }
  s.sessions = sim::simulateSessions(config, count, seed);
  std::vector<Session*> pointers;
  for (Session& session : s.sessions) pointers.push_back(&session);
  const auto start = std::chrono::steady_clock::now();
  calibrateSessions(pointers, MagneticMatcherConfig{}.calibration);
  s.calibration_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  PointMapConfig map_config;
  map_config.voxel_size_m = 0.25;
  for (const Session& session : s.sessions)
    s.maps.push_back(buildVoxelisedPoints(session, map_config));
  return s;
}

std::vector<Comparison> comparisonsFor(const Scenario& s) {
  const auto all_pairs = [](const std::vector<int>& ids) {
    std::vector<std::pair<int, int>> out;
    for (std::size_t i = 0; i < ids.size(); ++i)
      for (std::size_t j = i + 1; j < ids.size(); ++j) out.push_back({ids[i], ids[j]});
    return out;
  };
  if (s.preset == "disjoint") return {{"1+disjoint", {0, 4}, {}, true}};
  if (s.sessions.size() == 3)
    return {{"1+2", {0, 1}, {{0, 1}}, false},
            {"2+3", {1, 2}, {{1, 2}}, false},
            {"all", {0, 1, 2}, all_pairs({0, 1, 2}), false}};
  return {{"1+2", {0, 1}, {{0, 1}}, false},
          {"3+4", {2, 3}, {{2, 3}}, false},
          {"(1+2)+(3+4)", {0, 1, 2, 3}, {{0, 2}, {0, 3}, {1, 2}, {1, 3}}, false},
          {"all", {0, 1, 2, 3}, all_pairs({0, 1, 2, 3}), false}};
}

}  // namespace mm4mm::peers
