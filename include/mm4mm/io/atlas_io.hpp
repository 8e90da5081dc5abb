#pragma once
// The atlas directory of docs/design.md: what `mm4mm merge` writes and `mm4mm eval` reads.
//
//   atlas.yaml             manifest: version, sessions (id, source directory, connected,
//                          T_atlas_session), every other file's checksum
//   config.yaml            the settings it was built with (PipelineConfig, io/config_io.hpp)
//   graph.g2o              the multi-session graph at the optimised poses
//   trajectories/<id>.txt  optimised keyframe poses (TUM), connected sessions
//   merged.pcd/.ply        merged point cloud (x y z, plus per-point sessions fused)
//   magnetic_map.pcd/.png  fused magnetic map
//   changes/magnetic_change.pcd/.png  where sessions' fields differ (ChangeMap), if compared
//   octomap.bt             OctoMap of the merged map
//   report.json            pairs, sessions, and the errors where ground truth exists: the same
//                          inputs give it byte for byte, with any thread count
//   timings.json           wall-clock seconds of each stage and each pair

#include <Eigen/Geometry>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "mm4mm/atlas/atlas.hpp"
#include "mm4mm/atlas/atlas_outputs.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// Seconds each output took to build (buildAtlasOutputs) and to write, for the log and the
/// benchmark.
struct AtlasWriteTimings {
  double cloud_s = 0.0;
  double magnetic_s = 0.0;
  double octomap_s = 0.0;
  double build_s = 0.0;  ///< every build, run concurrently
  double write_s = 0.0;  ///< writing, flushing and swapping the files
  double total_s = 0.0;  ///< build_s + write_s
  std::size_t merged_points = 0;
  std::size_t octomap_nodes = 0;
};

/// The absolute path `writeAtlas` would write the atlas of `sources` to, after checking it may:
/// `dir` is an atlas, an empty directory or absent, not a symbolic link, and holds none of the
/// sources. Throws
/// std::invalid_argument naming the problem (a mistyped --out must never replace a session).
std::filesystem::path checkAtlasTarget(const std::filesystem::path& dir,
                                       const std::vector<std::filesystem::path>& sources);

/// Writes the atlas of `result` (from mergeSessions or addSessionToAtlas over `sessions`, read
/// from `sources`), with `outputs` built from it by buildAtlasOutputs, into `dir`: serialises,
/// computes nothing. config.yaml holds `result.config` and `outputs.config`. Everything is written
/// into a scratch directory next to `dir`, the manifest last with the SHA-256 of every other file,
/// and the scratch directory then swapped with `dir` in one rename (renameat2 RENAME_EXCHANGE):
/// killed at any moment, `dir` holds the old atlas or the new one, never a mix; every file and
/// directory is flushed to disk (fsync) before the swap and the swap itself after it, so a power
/// cut leaves one of the two as well. Scratch directories of killed writes are removed. Throws
/// std::invalid_argument when sizes disagree, std::runtime_error or
/// std::filesystem::filesystem_error on I/O failure.
///
/// `pictures` (file name to content, render's atlasPictures) are written into the atlas with the
/// rest and listed in its manifest: io draws nothing. A name that is not a plain file name, or is
/// one of the files writeAtlas writes itself, is std::invalid_argument.
AtlasWriteTimings writeAtlas(const std::filesystem::path& dir, const std::vector<Session>& sessions,
                             const std::vector<std::filesystem::path>& sources,
                             const MergeResult& result, const AtlasOutputs& outputs,
                             const std::map<std::string, std::string>& pictures = {});

/// Puts `tree` into the atlas at `dir` as octomap.bt (replacing one there) and its checksum into
/// atlas.yaml; every other file stays as it is (hard links into the new directory, copies where
/// the file system has none). The atlas is checked whole first (readAtlasManifest), and the
/// new one swapped in as writeAtlas does, so a kill at any moment leaves the atlas with its old
/// OctoMap (or none) or the new one. The caller holds the AtlasWriteLock. Throws InputError for an
/// atlas that is not whole, OutputError or std::filesystem::filesystem_error when a write fails.
void writeAtlasOctoMap(const std::filesystem::path& dir, const OctoMapTree& tree);

/// Thrown when another process holds an atlas's lock (the command line's exit code 4).
class AtlasBusy : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Holds `<atlas>.lock` (next to the atlas directory) with flock(2) for as long as it lives: the
/// one writer of the atlas. `add` reads the atlas, solves and rewrites it under the lock, so two
/// concurrent adds cannot both start from the same atlas and lose one session. The kernel drops
/// the lock when the process ends, killed or not; the empty lock file is left in place. Then checks
/// that a directory can be made beside the atlas, where its writers stage the new one. Throws
/// AtlasBusy when another process holds it, OutputError when the lock file cannot be created or
/// the directory is not writable (permissions, a read-only file system), InputError when it
/// cannot be locked.
class AtlasWriteLock {
 public:
  explicit AtlasWriteLock(const std::filesystem::path& atlas_dir);
  ~AtlasWriteLock();
  AtlasWriteLock(const AtlasWriteLock&) = delete;
  AtlasWriteLock& operator=(const AtlasWriteLock&) = delete;

 private:
  int fd_ = -1;
};

/// Reads `dir/atlas.yaml`, checks every file it lists against its checksum and reads the stored
/// config (for an atlas of version 2, which has none: the defaults with the OctoMap resolution
/// its manifest kept, and `config_stored` false). Throws InputError naming the file and what is
/// wrong (a corrupt or half-written atlas is refused, not used).
AtlasManifest readAtlasManifest(const std::filesystem::path& dir);

/// The session pairs of an atlas's report.json (Atlas::pairs), each session by its index
/// in `session_ids`. Throws InputError naming the file for a report this version did not write,
/// a session the ids do not list, a pair of a session with itself or listed twice, or a
/// transform that is not rigid.
std::vector<PairResult> readAtlasReportPairs(const std::filesystem::path& report_json,
                                             const std::vector<std::string>& session_ids);

/// The "changes" section of an atlas's report.json: the pairs of placed sessions compared for
/// change and each region where their field differs (FusedMagneticMap::changes), sessions by id.
/// Empty for a report written before the section existed. Throws InputError naming the file
/// when it is missing or the section is malformed.
struct ReportedChanges {
  std::size_t pairs_compared = 0;
  /// The sessions whose pairs were compared: every placed one after a merge, the new one after an
  /// add.
  std::vector<std::string> pairs_of;
  /// The sessions compared with none: their calibration had nothing to check itself against
  /// (FusedMagneticMap::change_unchecked).
  std::vector<std::string> calibration_unchecked;
  struct Region {
    std::string a, b;
    MagneticChangeRegion region;
  };
  std::vector<Region> regions;
};
ReportedChanges readAtlasReportChanges(const std::filesystem::path& report_json);

/// Reads the manifest (checking every file's checksum), the sessions, the trajectories, the
/// graph's inter-session edges, the report's pairs and the fused magnetic map. Throws InputError
/// naming the file when a session directory is missing, a trajectory does not have one pose per
/// keyframe, or the graph or report names a session the manifest does not list.
/// With SessionParts::kPoses, only what says where each session went: the sessions without their
/// magnetometer readings and scans (readSession), and no graph edges or fused magnetic map (for
/// `mm4mm eval`; most of an atlas's bytes are its sessions' scans).
Atlas loadAtlas(const std::filesystem::path& dir, SessionParts parts = SessionParts::kAll);

/// The same for an atlas whose manifest, `readAtlasManifest(dir)`, the caller has read already
/// (to look at its sessions first): the files are not checked a second time.
Atlas loadAtlas(const std::filesystem::path& dir, AtlasManifest manifest,
                SessionParts parts = SessionParts::kAll);

}  // namespace mm4mm
