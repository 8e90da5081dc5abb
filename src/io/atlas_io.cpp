#include "mm4mm/io/atlas_io.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <map>
#include <stdexcept>
#include <utility>

#include "atlas_manifest.hpp"
#include "atlas_report.hpp"
#include "checksum.hpp"
#include "directory_swap.hpp"
#include "mm4mm/core/timing.hpp"
#include "mm4mm/graph/session_graph.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/g2o_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"
#include "mm4mm/io/octomap_io.hpp"
#include "mm4mm/io/ply_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/io/tum_io.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;
using io_detail::checksumsOf;
using io_detail::kConfigFile;
using io_detail::manifestWithFiles;
using io_detail::manifestYaml;
using io_detail::normalAtlasPath;
using io_detail::previousAtlasPath;
using io_detail::removeStaleStaging;
using io_detail::reportJson;
using io_detail::siblingPath;
using io_detail::swapIntoPlace;
using io_detail::syncTree;
using io_detail::timingsJson;
using io_detail::writeFileAtomically;
using Clock = SteadyClock;

// `write` fills a scratch directory beside `target` with a whole atlas, which then replaces
// `target` in one swap; on any failure the scratch directory goes and `target` stays as it was.
template <typename Write>
void stageAndSwap(const fs::path& target, Write write) {
  removeStaleStaging(target, ".partial");
  const fs::path staging = siblingPath(target, ".partial");
  fs::remove_all(staging);
  try {
    fs::create_directories(staging);
    write(staging);
    syncTree(staging);
    swapIntoPlace(staging, target, previousAtlasPath(target));
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(staging, ignored);
    throw;
  }
}

// Where the change map goes, with its picture beside it (docs/design.md "Atlas directory").
constexpr const char* kChangeMapFile = "changes/magnetic_change.pcd";

// A picture may not escape the atlas or replace one of its data files: its name is a plain file
// name, or one in the atlas's changes/ directory.
void checkPictureNames(const std::map<std::string, std::string>& pictures) {
  const std::string own[] = {"atlas.yaml",       kConfigFile,    "graph.g2o",    "merged.pcd",
                             "merged.ply",       "octomap.bt",   "report.json",  "timings.json",
                             "magnetic_map.pcd", "trajectories", kChangeMapFile, "changes"};
  const auto plain = [](const std::string& name) {
    return !name.empty() && name != "." && name != ".." &&
           name.find_first_of(std::string("/\0", 2)) == std::string::npos;
  };
  for (const auto& entry : pictures) {
    const std::string& name = entry.first;
    const std::string in_changes = name.rfind("changes/", 0) == 0 ? name.substr(8) : name;
    if (!plain(in_changes))
      throw std::invalid_argument("writeAtlas: picture name '" + name +
                                  "' is not a plain file name (or one in changes/)");
    if (std::find(std::begin(own), std::end(own), name) != std::end(own))
      throw std::invalid_argument("writeAtlas: picture name '" + name +
                                  "' is one of the atlas's own files");
  }
}

}  // namespace

fs::path checkAtlasTarget(const fs::path& dir, const std::vector<fs::path>& sources) {
  const fs::path target = normalAtlasPath(dir);
  // The atlas is replaced by renames in its parent: through a link, the link would be replaced
  // and the atlas it points to left as it was.
  if (fs::is_symlink(target))
    throw std::invalid_argument(target.string() + " is a symbolic link (to " +
                                fs::read_symlink(target).string() +
                                "): give the atlas directory itself");
  // Replacing is for atlases only: a mistyped --out must never delete a session or other data.
  if (fs::exists(target) && !fs::exists(target / "atlas.yaml") &&
      !(fs::is_directory(target) && fs::is_empty(target)))
    throw std::invalid_argument(target.string() +
                                " exists and is not an atlas (no atlas.yaml); refusing to "
                                "replace it");
  for (const fs::path& source : sources) {
    const fs::path normal = fs::absolute(source).lexically_normal();
    const auto [end, unused] =
        std::mismatch(target.begin(), target.end(), normal.begin(), normal.end());
    (void)unused;
    if (end == target.end())
      throw std::invalid_argument("the atlas " + target.string() + " would replace its own input " +
                                  normal.string());
  }
  return target;
}

AtlasWriteTimings writeAtlas(const fs::path& dir, const std::vector<Session>& sessions,
                             const std::vector<fs::path>& sources, const MergeResult& result,
                             const AtlasOutputs& outputs,
                             const std::map<std::string, std::string>& pictures) {
  const auto start = Clock::now();
  const MultiSessionSolution& solution = result.solution;
  if (sources.size() != sessions.size() || solution.connected.size() != sessions.size() ||
      solution.T_atlas_keyframe.size() != sessions.size())
    throw std::invalid_argument(
        "writeAtlas: sessions, sources, the solution and the outputs disagree in size");

  checkPictureNames(pictures);
  const fs::path target = checkAtlasTarget(dir, sources);
  stageAndSwap(target, [&](const fs::path& staging) {
    fs::create_directories(staging / "trajectories");
    for (const int s : outputs.placed) {
      std::vector<StampedPose> trajectory;
      for (std::size_t k = 0; k < sessions[s].keyframes.size(); ++k)
        trajectory.push_back({sessions[s].keyframes[k].time_s, solution.T_atlas_keyframe[s][k]});
      writeTumPoses(staging / "trajectories" / (sessions[s].id + ".txt"), trajectory);
    }
    if (!outputs.placed.empty())
      writeMultiSessionGraphG2o(
          outputs.placed.size(),
          [&](std::size_t p) {
            const int s = outputs.placed[p];
            return buildSessionGraphAt(sessions[s], solution.T_atlas_keyframe[s]);
          },
          outputs.kept_edges, staging / "graph.g2o");
    if (outputs.cloud) {
      writeMergedCloudPcd(staging / "merged.pcd", *outputs.cloud);
      writePly(staging / "merged.ply", outputs.cloud->points);
    }
    if (outputs.fused) writeMagneticMapPcd(staging / "magnetic_map.pcd", outputs.fused->map);
    if (outputs.fused && outputs.fused->change_map.comparedCells() > 0) {
      fs::create_directories((staging / kChangeMapFile).parent_path());
      writeChangeMapPcd(staging / kChangeMapFile, outputs.fused->change_map);
    }
    for (const auto& [name, content] : pictures) {
      fs::create_directories((staging / name).parent_path());
      writeFileAtomically(staging / name, content);
    }
    if (outputs.octomap) writeOctoMap(staging / "octomap.bt", *outputs.octomap);
    writeFileAtomically(staging / "report.json",
                        reportJson(sessions, result, outputs).dump(2) + "\n");
    writeFileAtomically(staging / "timings.json",
                        timingsJson(sessions, result, outputs).dump(2) + "\n");
    // The manifest last: it lists every other file with its checksum, so a staging directory
    // without it is incomplete by construction.
    writeFileAtomically(staging / kConfigFile,
                        pipelineConfigYaml(PipelineConfig{result.config, outputs.config}));
    writeFileAtomically(staging / "atlas.yaml",
                        manifestYaml(sessions, sources, result, checksumsOf(staging)));
  });
  AtlasWriteTimings timings;
  timings.cloud_s = outputs.cloud_s;
  timings.magnetic_s = outputs.magnetic_s;
  timings.octomap_s = outputs.octomap_s;
  timings.build_s = outputs.total_s;
  timings.write_s = secondsSince(start);
  timings.total_s = timings.build_s + timings.write_s;
  timings.merged_points = outputs.cloud ? outputs.cloud->size() : 0;
  timings.octomap_nodes = outputs.octomap ? outputs.octomap->stats.nodes : 0;
  return timings;
}

void writeAtlasOctoMap(const fs::path& dir, const OctoMapTree& tree) {
  const fs::path target = normalAtlasPath(dir);
  // Checked whole: an OctoMap is never added to an atlas that would not load.
  const AtlasManifest manifest = readAtlasManifest(target);
  stageAndSwap(target, [&](const fs::path& staging) {
    std::vector<std::pair<std::string, std::string>> checksums;
    for (const auto& [file, sha256] : manifest.files) {
      if (file == "octomap.bt") continue;
      fs::create_directories((staging / file).parent_path());
      // Every write here makes a new file and renames it, so a link never sees a file change.
      std::error_code no_link;
      fs::create_hard_link(target / file, staging / file, no_link);
      if (no_link) fs::copy_file(target / file, staging / file);
      checksums.emplace_back(file, sha256);
    }
    writeOctoMap(staging / "octomap.bt", tree);
    checksums.emplace_back("octomap.bt", io_detail::sha256OfFile(staging / "octomap.bt"));
    std::sort(checksums.begin(), checksums.end());
    writeFileAtomically(
        staging / "atlas.yaml",
        manifestWithFiles(io_detail::readWholeFile(target / "atlas.yaml"), checksums));
  });
}

AtlasWriteLock::AtlasWriteLock(const fs::path& atlas_dir) {
  fs::path lock = normalAtlasPath(atlas_dir);
  lock += ".lock";
  fs::create_directories(lock.parent_path());
  // Read-only is enough for flock, and lets another user who may write the atlas's directory
  // but not this file take the lock too.
  fd_ = ::open(lock.c_str(), O_RDONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw OutputError("cannot create the atlas's lock file " + lock.string() + ": " +
                      std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    ::close(fd_);
    if (error == EWOULDBLOCK)
      throw AtlasBusy(atlas_dir.string() +
                      ": another mm4mm process is writing this atlas (it holds " + lock.string() +
                      "); run again when it has finished");
    throw InputError(lock.string(), 0, std::string("cannot lock: ") + std::strerror(error));
  }
  // The writers stage the new atlas beside the old one. A directory this user may not write (or
  // a read-only mount) is said now, not after minutes of matching: a lock file left by another
  // user opens read-only and would not tell. The probe is a staging name, so a kill before its
  // removal leaves scratch the next writer removes.
  fs::path probe = normalAtlasPath(atlas_dir);
  probe += ".partial" + std::to_string(::getpid());
  if (::mkdir(probe.c_str(), 0755) != 0 && errno != EEXIST) {
    const int error = errno;
    ::close(fd_);
    throw OutputError("cannot write in " + lock.parent_path().string() +
                      ", where the new atlas is staged beside the old one (making " +
                      probe.filename().string() + "): " + std::strerror(error));
  }
  ::rmdir(probe.c_str());
}

AtlasWriteLock::~AtlasWriteLock() { ::close(fd_); }  // closing releases the flock

Atlas loadAtlas(const fs::path& dir, SessionParts parts) {
  return loadAtlas(dir, readAtlasManifest(dir), parts);
}

Atlas loadAtlas(const fs::path& dir, AtlasManifest manifest, SessionParts parts) {
  Atlas atlas;
  atlas.manifest = std::move(manifest);
  atlas.frame_session = atlas.manifest.frame_session;
  for (const AtlasSessionEntry& entry : atlas.manifest.sessions) {
    if (!fs::exists(entry.source / "session.yaml"))
      throw InputError((dir / "atlas.yaml").string(), 0,
                       "session '" + entry.id + "': its source " + entry.source.string() +
                           " is not a session directory (moved or deleted?)");
    atlas.sessions.push_back(readSession(entry.source, parts));
    const Session& session = atlas.sessions.back();
    if (session.id != entry.id)
      throw InputError((dir / "atlas.yaml").string(), 0,
                       "session '" + entry.id + "': its source " + entry.source.string() +
                           " now holds session '" + session.id + "'");
    atlas.connected.push_back(entry.connected);
    atlas.T_atlas_keyframe.emplace_back();
    auto& poses = atlas.T_atlas_keyframe.back();
    if (!entry.connected) {
      for (const StampedPose& k : session.keyframes) poses.push_back(k.T_frame_body);
      continue;
    }
    const fs::path file = dir / "trajectories" / (entry.id + ".txt");
    const std::vector<StampedPose> trajectory = readTumPoses(file);
    if (trajectory.size() != session.keyframes.size())
      throw InputError(file.string(), 0,
                       std::to_string(trajectory.size()) + " poses for session '" + entry.id +
                           "' of " + std::to_string(session.keyframes.size()) + " keyframes");
    for (const StampedPose& p : trajectory) poses.push_back(p.T_frame_body);
  }
  std::map<std::string, int> index_of;
  for (std::size_t s = 0; s < atlas.sessions.size(); ++s)
    index_of[atlas.sessions[s].id] = static_cast<int>(s);
  const auto indexOf = [&](const std::string& id, const fs::path& file) {
    const auto found = index_of.find(id);
    if (found == index_of.end())
      throw InputError(file.string(), 0,
                       "names session '" + id + "', which atlas.yaml does not list");
    return found->second;
  };
  if (parts == SessionParts::kAll && fs::exists(dir / "graph.g2o")) {
    const StoredInterSessionEdges stored = readInterSessionEdgesG2o(dir / "graph.g2o");
    std::vector<int> session_of;
    for (const std::string& id : stored.session_ids)
      session_of.push_back(indexOf(id, dir / "graph.g2o"));
    for (InterSessionEdge edge : stored.edges) {
      edge.session_a = session_of[edge.session_a];
      edge.session_b = session_of[edge.session_b];
      atlas.edges.push_back(edge);
    }
  }
  std::vector<std::string> session_ids;
  for (const Session& session : atlas.sessions) session_ids.push_back(session.id);
  atlas.pairs = readAtlasReportPairs(dir / "report.json", session_ids);
  if (parts == SessionParts::kAll && fs::exists(dir / "magnetic_map.pcd"))
    atlas.fused_magnetic_map = readMagneticMapPcd(dir / "magnetic_map.pcd");
  return atlas;
}

}  // namespace mm4mm
