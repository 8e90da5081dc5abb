#pragma once
// Config files. A simulation preset (configs/warehouse.yaml, ...) mirrors SimulationConfig; a
// pipeline config (configs/mm4mm.yaml) mirrors PipelineConfig: every key is a member's C++ name,
// nesting is the structs' nesting, enumerations are written by name. A file only overrides the
// values it names; an unknown key is an error (it is almost always a typo), named by its dotted
// path with the file and line.

#include <filesystem>
#include <string>

#include "mm4mm/atlas/pipeline_config.hpp"
#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm {

/// Reads `path` over `base`. Throws InputError naming the file, line and key on bad input, and
/// when the result fails SimulationConfig::IsValid.
sim::SimulationConfig loadSimulationConfig(const std::filesystem::path& path,
                                           sim::SimulationConfig base = {});

/// A check of a whole config read (PipelineConfig::IsValid), or null for none. io links none of
/// the pipeline, whose IsValid this is, so the caller passes it in (loadPipelineConfig does).
using PipelineConfigCheck = bool (*)(const PipelineConfig& config, std::string* error);

/// Reads a pipeline config file over `base`. Throws InputError(file, line, ...) for a file that is
/// not YAML, an unknown key (its dotted path; a matcher file of the old format is said to be
/// one), a value of the wrong type or an enumeration's unknown name (with the names allowed),
/// and, when `check` says the result is invalid, its message, which starts with the key.
PipelineConfig readPipelineConfig(const std::filesystem::path& path, const PipelineConfig& base,
                                  PipelineConfigCheck check);

/// The same from the text of a file named `file` (an atlas's stored config.yaml).
PipelineConfig parsePipelineConfig(const std::string& text, const std::string& file,
                                   const PipelineConfig& base, PipelineConfigCheck check);

/// readPipelineConfig checked by PipelineConfig::IsValid: what the command line reads.
inline PipelineConfig loadPipelineConfig(const std::filesystem::path& path,
                                         const PipelineConfig& base = {}) {
  return readPipelineConfig(path, base, [](const PipelineConfig& config, std::string* error) {
    return config.IsValid(error);
  });
}

/// Every field of `config` as YAML, in the format loadPipelineConfig reads: loading it gives
/// `config` back exactly (numbers are written in their shortest exact form).
std::string pipelineConfigYaml(const PipelineConfig& config);

}  // namespace mm4mm
