#pragma once
// YAML presets for the simulator. A preset only overrides the defaults in code and mirrors the
// nesting of SimulationConfig; an unknown key is an error (it is almost always a typo).

#include <filesystem>

#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm {

/// Reads `path` over `base`. Throws InputError naming the file, line and key on bad input, and
/// when the result fails SimulationConfig::IsValid.
sim::SimulationConfig loadSimulationConfig(const std::filesystem::path& path,
                                           sim::SimulationConfig base = {});

/// Reads a matcher preset (configs/matcher.yaml) over `base`, with the same rules.
MagneticMatcherConfig loadMatcherConfig(const std::filesystem::path& path,
                                        MagneticMatcherConfig base = {});

}  // namespace mm4mm
