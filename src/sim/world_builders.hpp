#pragma once
// Internal to the simulator: the geometry builders of each world and what they share.

#include <vector>

#include "mm4mm/sim/world.hpp"

namespace mm4mm::sim {

enum class SteelKind { kPillar, kUpright, kBeam };

/// A straight steel member, magnetised as a chain of dipoles from `from_m` to `to_m`.
struct SteelMember {
  SteelKind kind = SteelKind::kPillar;
  Eigen::Vector3d from_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d to_m = Eigen::Vector3d::Zero();
};

/// Where the world's steel is; moments are assigned afterwards from the seed.
using SteelAnchors = std::vector<SteelMember>;

World buildWarehouse(const WarehouseConfig& config, SteelAnchors* anchors);
World buildCorridor(const CorridorConfig& config, SteelAnchors* anchors);

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
