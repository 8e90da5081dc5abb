#pragma once
// Multi-session simulation: a world, its magnetic field, and sessions whose routes overlap each
// other partially, each with drifting odometry, magnetometer samples, LiDAR scans and ground truth.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"
#include "mm4mm/sim/magnetic_field.hpp"
#include "mm4mm/sim/raycaster.hpp"
#include "mm4mm/sim/route.hpp"
#include "mm4mm/sim/simulation_config.hpp"
#include "mm4mm/sim/world.hpp"

namespace mm4mm::sim {

/// Called with a short message as each session is done; may be empty.
using ProgressCallback = std::function<void(const std::string&)>;

/// Everything about a world that sessions are simulated in.
struct SimulatedWorld {
  World world;
  MagneticFieldModel field;
  Raycaster raycaster;

  SimulatedWorld(const SimulationConfig& config, std::uint64_t seed);
  /// `world` (buildWorld's, or a changed copy of it: world_change.hpp) with the field's
  /// background drawn from `seed` as the constructor above draws it.
  SimulatedWorld(World world, const SimulationConfig& config, std::uint64_t seed);
  SimulatedWorld(const SimulatedWorld&) = delete;
  SimulatedWorld& operator=(const SimulatedWorld&) = delete;
};

/// The building as each session sees it when it changes between sessions (ChangeConfig): as it
/// stood before the change for the sessions before change.first_session, after it from then on.
/// Without a change every session sees the whole world. Routes are planned in the whole world,
/// whose lanes a change leaves as they are.
class ChangingWorld {
 public:
  /// Throws std::invalid_argument when a box of the change holds nothing (changedWorld).
  ChangingWorld(const SimulationConfig& config, std::uint64_t seed);
  bool changes() const { return after_ != nullptr; }
  const SimulatedWorld& whole() const { return *whole_; }
  /// Before and after the change; both the whole world without one.
  const SimulatedWorld& before() const { return before_ ? *before_ : *whole_; }
  const SimulatedWorld& after() const { return after_ ? *after_ : *whole_; }
  const SimulatedWorld& forSession(int index) const {
    return index >= first_session_ ? after() : before();
  }

 private:
  int first_session_ = 0;
  std::unique_ptr<SimulatedWorld> whole_, before_, after_;
};

/// The rig of `config`: magnetometers in a lateral row centred on the body x axis.
SensorRig simulatedRig(const RigConfig& config);

/// Routes for `count` sessions in the layout of `config` (paper set-ups, random starts, and
/// optionally a last session that overlaps no other).
std::vector<Route> planSessionRoutes(const World& world, const SimulationConfig& config, int count,
                                     std::uint64_t seed);

/// One session driven along `route`. Its id is `id`; its frame is its own odometry frame.
Session simulateSession(const SimulatedWorld& world, const Route& route,
                        const SimulationConfig& config, const std::string& id, std::uint64_t seed);

/// `count` sessions with ids s0 … s<count-1>. Same config and seed give the same sessions.
std::vector<Session> simulateSessions(const SimulationConfig& config, int count, std::uint64_t seed,
                                      const ProgressCallback& progress = {});

/// A well-mixed 64-bit seed for sub-stream `stream` of `seed` (SplitMix64).
std::uint64_t deriveSeed(std::uint64_t seed, std::uint64_t stream);

}  // namespace mm4mm::sim
