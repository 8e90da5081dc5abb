#pragma once
// The simulator presets the merge-level benchmarks run (configs/*.yaml with their session
// counts). Needs MM4MM_SOURCE_DIR, the source tree the configs are read from.

#include <filesystem>
#include <stdexcept>
#include <string>

#include "mm4mm/io/config_io.hpp"
#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm::bench {

struct Preset {
  sim::SimulationConfig config;
  int sessions = 0;
};

/// The procedural buildings (issue 31; docs/heldout_set.md): `building` is a type
/// (sim::proceduralBuildings()) or "any", the type then drawn from the seed; sessions from random
/// starts along 150 m routes, shorter than the paper's set-ups, so that pairs share anything
/// from a whole floor to one pass. match_bench, merge_bench and add_bench run them alike.
inline void makeProcedural(const std::string& building, sim::SimulationConfig* c) {
  c->world = "procedural";
  c->procedural.building = building;
  c->layout.route_length_m = 150.0;
}

/// warehouse (configs/warehouse.yaml, 4 sessions), corridor (3), featureless
/// (corridor_featureless.yaml, 3), procedural (makeProcedural("any"), 4); throws
/// std::invalid_argument for another name.
inline Preset presetFor(const std::string& name) {
  const std::filesystem::path configs = std::filesystem::path(MM4MM_SOURCE_DIR) / "configs";
  if (name == "procedural") {
    Preset preset{sim::SimulationConfig{}, 4};
    makeProcedural("any", &preset.config);
    return preset;
  }
  if (name == "warehouse") return {loadSimulationConfig(configs / "warehouse.yaml"), 4};
  if (name == "corridor") return {loadSimulationConfig(configs / "corridor.yaml"), 3};
  if (name == "featureless")
    return {loadSimulationConfig(configs / "corridor_featureless.yaml"), 3};
  throw std::invalid_argument("unknown preset " + name);
}

}  // namespace mm4mm::bench
