#pragma once
// The ground truth of a simulated change between sessions (sim/world_change.hpp), written by
// `mm4mm simulate` beside the sessions:
//
//   change.yaml        the change as configured (first_session, the removed and added boxes
//                      with the dipoles and solids each held), and the truth's summary: its
//                      height, cell, threshold, changed area (m²) and largest |(ΔB_h, ΔB_v)|
//   change_truth.pcd   the truth's grid as a magnetic map PCD (magnetic_map_io.hpp): bh = ΔB_h,
//                      bv = ΔB_v, bf = |(ΔB_h, ΔB_v)|, bx by = ΔB along world x and y

#include <filesystem>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/sim/simulation_config.hpp"
#include "mm4mm/sim/world.hpp"
#include "mm4mm/sim/world_change.hpp"

namespace mm4mm {

/// The truth's grid as a magnetic map (every cell covered), the form change_truth.pcd holds.
MagneticMap changeTruthMap(const sim::ChangeTruth& truth);

/// Writes change.yaml and change_truth.pcd into `dir` (which must exist), each under a temporary
/// name and renamed. `world` is the unchanged world, whose contents each box's counts describe.
/// Throws std::runtime_error when a file cannot be written.
void writeChangeTruth(const std::filesystem::path& dir, const sim::ChangeConfig& change,
                      const sim::World& world, const sim::ChangeTruth& truth);

}  // namespace mm4mm
