#pragma once
// Internal to the simulator: the geometry builders of each world and what they share.

#include <vector>

#include "mm4mm/sim/world.hpp"

namespace mm4mm::sim {

enum class SteelKind { kPillar, kUpright, kBeam, kObject };

/// A straight steel member, magnetised as a chain of dipoles from `from_m` to `to_m`. Pillars,
/// uprights and beams take their moments per dipole from SteelConfig; an object (a stud, a pipe,
/// a car, a machine) carries its own.
struct SteelMember {
  SteelKind kind = SteelKind::kPillar;
  Eigen::Vector3d from_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d to_m = Eigen::Vector3d::Zero();
  double induced_moment_Am2 = 0.0;   ///< kObject: per dipole, along the Earth's field
  double remanent_moment_Am2 = 0.0;  ///< kObject: std-dev per axis, one draw per member
};

/// Where the world's steel is; moments are assigned afterwards from the seed.
using SteelAnchors = std::vector<SteelMember>;

World buildWarehouse(const WarehouseConfig& config, SteelAnchors* anchors);
World buildCorridor(const CorridorConfig& config, SteelAnchors* anchors);
/// A building of `config.procedural.building` drawn from `seed` (geometry and contents; the
/// moments are drawn later from the steel seed). `clearance_m`: half the width a lane keeps free
/// for the rig. May draw floor steel into `config`'s floor_mesh and floor_steel.
World buildProcedural(SimulationConfig* config, double clearance_m, std::uint64_t seed,
                      SteelAnchors* anchors);

void addEnclosingWalls(World* world, double thickness_m);
/// Lanes along every x = xs[i] and y = ys[j], crossing at each (xs[i], ys[j]).
LaneGraph gridLanes(const std::vector<double>& xs, const std::vector<double>& ys);
std::vector<MagneticDipole> placeSteelDipoles(const SteelAnchors& anchors,
                                              const SimulationConfig& config, std::uint64_t seed);
/// The bar ends of the floor's reinforcement mesh under `floor` (FloorMeshConfig).
std::vector<MagneticCharge> floorMeshCharges(const Eigen::AlignedBox2d& floor,
                                             const SimulationConfig& config, std::uint64_t seed);
/// Sparse irregular steel under `floor` (FloorSteelConfig).
std::vector<MagneticDipole> floorSteelDipoles(const Eigen::AlignedBox2d& floor,
                                              const FloorSteelConfig& config, std::uint64_t seed);

}  // namespace mm4mm::sim
