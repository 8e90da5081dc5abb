#pragma once
// Subcommands of the mm4mm command line. Each registers its options and its callback on `app`.

#include <CLI/CLI.hpp>
#include <map>
#include <string>
#include <vector>

#include "mm4mm/atlas/atlas_outputs.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm::cli {

/// Exit codes, documented in README.md.
enum ExitCode : int {
  kSuccess = 0,
  kInternalError = 1,
  kBadInput = 2,
  kNoOverlap = 3,
  kAtlasBusy = 4,
  kOutputFailed = 5
};

void addSimulateCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addMapCommand(CLI::App& app);
void addMatchCommand(CLI::App& app);
void addMergeCommand(CLI::App& app);
void addAddCommand(CLI::App& app);
void addEvalCommand(CLI::App& app);
void addConfigCommand(CLI::App& app);
void addImportCommand(CLI::App& app);
void addExportCommand(CLI::App& app);

/// Prints one line per session of a merge or add: connected, or why not. `merging`: the atlas is
/// new, its frame that of the largest group of overlapping sessions (said when that group does
/// not hold the first session); `add` keeps its atlas's frame.
void printConnections(const std::vector<Session>& sessions, const MergeResult& result,
                      bool merging);

/// One line per placed session the fused magnetic map left out, its magnetometers at another
/// height than the others' (FusedMagneticMap::other_height_m).
void printLeftOutOfTheFusedMap(const std::vector<Session>& sessions, const AtlasOutputs& outputs);

/// The pictures merge and add write into the atlas (render's atlasPictures of the fused map).
std::map<std::string, std::string> picturesOf(const AtlasOutputs& outputs);

/// Reads a session directory; a path without session.yaml is an InputError naming it.
Session readSessionDir(const std::string& path);

/// The pipeline's calibration step on sessions read from disk (calibrateSessions), with one log
/// line per magnetometer saying how it was calibrated.
std::vector<SessionCalibration> calibrateAndLog(const std::vector<Session*>& sessions,
                                                const CalibrationConfig& config);

}  // namespace mm4mm::cli
