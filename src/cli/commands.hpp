#pragma once
// Subcommands of the mm4mm command line. Each registers its options and its callback on `app`.

#include <CLI/CLI.hpp>
#include <filesystem>
#include <map>
#include <optional>
#include <stdexcept>
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
  kOutputFailed = 5,
  kNotEnoughMemory = 6
};

/// Inputs whose estimated peak memory exceeds what the process may use (exit code 6).
class NotEnoughMemory : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Estimates the peak memory of holding the sessions in `session_dirs` (atlas/memory_bound.hpp,
/// from their files' headers), logs it, and throws NotEnoughMemory, naming the figure and the
/// limit, when it exceeds `limit_gib` where given, else the memory the system has available.
/// `doing` says what the sessions are for ("merging 2 sessions").
/// Registers `--memory-limit GIB` (positive) on `command`, read by checkMemory.
void addMemoryLimitOption(CLI::App* command, std::optional<double>* limit_gib);

void checkMemory(const std::vector<std::filesystem::path>& session_dirs, const std::string& doing,
                 std::optional<double> limit_gib);

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
void addChangesCommand(CLI::App& app);

/// "change 3: s0+s2: the field differs over 6.0 m² at (-21.1, 5.1) m in the atlas frame, by 7.1 µT
/// on average (14.3 at most)": a change region as merge, add and `changes` print it, numbered as
/// report.json and changes/magnetic_change.pcd number it.
std::string changeLine(std::size_t number, const std::string& a, const std::string& b,
                       const MagneticChangeRegion& region);

/// Prints one line per session of a merge or add: connected, or why not. `merging`: the atlas is
/// new, its frame that of the largest group of overlapping sessions (said when that group does
/// not hold the first session); `add` keeps its atlas's frame.
void printConnections(const std::vector<Session>& sessions, const MergeResult& result,
                      bool merging);

/// One line per placed session the fused magnetic map left out, its magnetometers at another
/// height than the others' (FusedMagneticMap::other_height_m).
void printLeftOutOfTheFusedMap(const std::vector<Session>& sessions, const AtlasOutputs& outputs);
/// A line per region where two placed sessions' fields differ (FusedMagneticMap::changes), then
/// how many pairs were compared; nothing where no pair shares cells.
void printChanges(const std::vector<Session>& sessions, const AtlasOutputs& outputs);

/// The pictures merge and add write into the atlas (render's atlasPictures of the fused map).
std::map<std::string, std::string> picturesOf(const AtlasOutputs& outputs);

/// Reads a session directory; a path without session.yaml is an InputError naming it.
Session readSessionDir(const std::string& path);

/// The pipeline's calibration step on sessions read from disk (calibrateSessions), with one log
/// line per magnetometer saying how it was calibrated.
std::vector<SessionCalibration> calibrateAndLog(const std::vector<Session*>& sessions,
                                                const CalibrationConfig& config);

}  // namespace mm4mm::cli
