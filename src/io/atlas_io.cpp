#include "mm4mm/io/atlas_io.hpp"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <sys/file.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cstring>
#include <exception>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>

#include "checksum.hpp"
#include "json_util.hpp"
#include "mm4mm/core/timing.hpp"
#include "mm4mm/io/g2o_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"
#include "mm4mm/io/match_json.hpp"
#include "mm4mm/io/octomap_io.hpp"
#include "mm4mm/io/ply_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/io/tum_io.hpp"
#include "mm4mm/render/magnetic_map_render.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;
using io_detail::matchJson;
using io_detail::matrixJson;
using io_detail::readWholeFile;
using io_detail::sha256OfFile;
using io_detail::siblingPath;
using io_detail::writeFileAtomically;
using Clock = SteadyClock;

// 2: the manifest lists every other file of the atlas with its SHA-256.
constexpr int kManifestVersion = 2;

// The atlas directory as an absolute path without a trailing separator ("atlas/" names "atlas"),
// so that the names built beside it (.lock, .partial<pid>, .previous) are siblings.
fs::path normalAtlasPath(const fs::path& dir) {
  fs::path normal = fs::absolute(dir).lexically_normal();
  if (!normal.has_filename()) normal = normal.parent_path();
  return normal;
}

fs::path previousAtlasPath(const fs::path& dir) {
  fs::path previous = normalAtlasPath(dir);
  previous += ".previous";
  return previous;
}

YAML::Node matrixYaml(const Eigen::Isometry3d& T) {
  YAML::Node rows(YAML::NodeType::Sequence);
  for (int r = 0; r < 4; ++r) {
    YAML::Node row(YAML::NodeType::Sequence);
    row.SetStyle(YAML::EmitterStyle::Flow);
    for (int c = 0; c < 4; ++c) row.push_back(T.matrix()(r, c));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json evaluationJson(const std::vector<Session>& sessions, const AtlasEvaluation& e) {
  nlohmann::json pairs = nlohmann::json::array();
  for (const auto& pair : e.pairs)
    pairs.push_back({{"a", sessions[pair.a].id},
                     {"b", sessions[pair.b].id},
                     {"keyframe_pairs", pair.overlap.pairs},
                     {"median_translation_m", pair.overlap.median_translation_m},
                     {"median_rotation_deg", pair.overlap.median_rotation_deg},
                     {"aligned", pair.overlap.aligned()}});
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& frame : e.frames)
    frames.push_back({{"session", sessions[frame.session].id},
                      {"e_t_m", frame.error.translation_m},
                      {"e_r_deg", frame.error.rotation_deg}});
  return {{"overlap_errors", pairs},
          {"frame_errors", frames},
          {"ate_m", e.ate_m},
          {"odometry_ate_m", e.odometry_ate_m}};
}

// How one magnetometer was calibrated: MagnetometerCalibration's model, where it came from, and
// how much the readings' disagreement at places read twice fell (µT).
nlohmann::json calibrationJson(const SensorCalibration& c) {
  const MagnetometerCalibration& m = c.calibration;
  nlohmann::json soft = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    soft.push_back({m.soft_iron(r, 0), m.soft_iron(r, 1), m.soft_iron(r, 2)});
  return {{"source", toString(c.source)},
          {"hard_iron_uT", {m.hard_iron_uT.x(), m.hard_iron_uT.y(), m.hard_iron_uT.z()}},
          {"soft_iron", soft},
          {"speed_uT_per_mps",
           {m.speed_uT_per_mps.x(), m.speed_uT_per_mps.y(), m.speed_uT_per_mps.z()}},
          {"hard_iron_sigma_uT", c.hard_iron_sigma_uT},
          {"places_read_twice", c.pairs},
          {"residual_before_uT", c.residual_before_uT},
          {"residual_after_uT", c.residual_after_uT},
          {"vertical_estimated", c.vertical_estimated},
          {"note", c.note}};
}

// Everything but wall-clock times, which go to timings.json: the same inputs and seed give the
// same report.json byte for byte, whatever the thread count or the machine's load.
nlohmann::json reportJson(const std::vector<Session>& sessions, const MergeResult& result,
                          const std::optional<AtlasEvaluation>& evaluation) {
  const MultiSessionSolution& solution = result.solution;
  nlohmann::json report;
  report["sessions"] = nlohmann::json::array();
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    nlohmann::json entry = {{"id", sessions[s].id},
                            {"connected", static_cast<bool>(solution.connected[s])},
                            {"T_atlas_session", matrixJson(solution.T_atlas_session[s])}};
    if (s < result.match_obstacles.size() && result.match_obstacles[s].any()) {
      entry["not_matchable"] = describe(result.match_obstacles[s]);
      entry["not_matchable_reason"] = toString(result.match_obstacles[s].reason);
    }
    if (s < result.calibrations.size()) {
      nlohmann::json sensors = nlohmann::json::array();
      for (const SensorCalibration& c : result.calibrations[s].sensors)
        sensors.push_back(calibrationJson(c));
      entry["magnetometer_calibration"] = sensors;
    }
    report["sessions"].push_back(entry);
  }
  report["pairs"] = nlohmann::json::array();
  for (const PairResult& pair : result.pairs) {
    // docs/design.md's pair fields; the magnetic match's own fields under "magnetic".
    nlohmann::json magnetic = matchJson(pair.magnetic);
    magnetic.erase("seconds");
    nlohmann::json entry = {{"a", sessions[pair.a].id},
                            {"b", sessions[pair.b].id},
                            {"overlap", pair.accepted},
                            {"role", toString(pair.role)},
                            {"T_a_b", matrixJson(pair.T_a_b)},
                            {"fitness", pair.magnetic.fitness},
                            {"confidence", matchConfidence(pair.magnetic)},
                            {"edges", pair.edges},
                            {"edges_kept", pair.edges_kept}};
    // A geometry-only pair's match ran on structure maps: named so, never passed off as magnetic.
    entry[pair.geometry_only ? "structure_match" : "magnetic"] = magnetic;
    // An add with another config can clear the obstacle of a pair matched by geometry before:
    // the pair still says what it is.
    if (pair.geometry_only)
      entry["geometry_only"] = "matched on the sessions' structure maps, not the field";
    if (pair.joint) entry["joint"] = "placed by the field's choice among the structure maps' modes";
    for (int s : {pair.a, pair.b})
      if (static_cast<std::size_t>(s) < result.match_obstacles.size() &&
          result.match_obstacles[s].any()) {
        const std::string why = sessions[s].id + " cannot be matched magnetically: " +
                                describe(result.match_obstacles[s]);
        if (pair.geometry_only)
          entry["geometry_only"] = why + "; matched on the sessions' structure maps";
        else
          entry["not_matched"] = why;
      }
    if (!pair.mode_inlier_ratios.empty())
      entry["geometric_verification"] = {{"mode_inlier_ratios", pair.mode_inlier_ratios},
                                         {"chosen_mode", pair.geometry_chosen_mode}};
    if (pair.refined)
      entry["icp_em"] = {{"converged", pair.icp.converged},
                         {"inlier_ratio", pair.icp.inlier_ratio},
                         {"iterations", pair.icp.iterations},
                         {"degenerate", pair.icp.degenerate}};
    report["pairs"].push_back(entry);
  }
  report["graph"] = {{"inter_session_edges", result.edges.size()},
                     {"magnetic_residuals", solution.magnetic_residuals},
                     {"iterations", solution.iterations},
                     {"initial_cost", solution.initial_cost},
                     {"final_cost", solution.final_cost},
                     {"converged", solution.converged}};
  if (evaluation) report["evaluation"] = evaluationJson(sessions, *evaluation);
  return report;
}

// The wall-clock seconds of every stage and of every pair (its magnetic match, its ICP-EM).
nlohmann::json timingsJson(const std::vector<Session>& sessions, const MergeResult& result,
                           const AtlasOutputs& timings) {
  nlohmann::json json;
  json["stages_s"] = {{"magnetic_maps", result.seconds_maps},
                      {"matching", result.seconds_matching},
                      {"refinement_and_edges", result.seconds_refinement},
                      {"solve", result.seconds_solve},
                      {"merged_cloud", timings.cloud_s},
                      {"magnetic_map", timings.magnetic_s},
                      {"octomap", timings.octomap_s}};
  json["pairs"] = nlohmann::json::array();
  for (const PairResult& pair : result.pairs) {
    nlohmann::json entry = {{"a", sessions[pair.a].id},
                            {"b", sessions[pair.b].id},
                            {"seconds", pair.seconds},
                            {"magnetic_s", pair.magnetic.seconds}};
    if (pair.refined) entry["icp_em_s"] = pair.icp.seconds;
    json["pairs"].push_back(entry);
  }
  return json;
}

std::string manifestYaml(const std::vector<Session>& sessions, const std::vector<fs::path>& sources,
                         const MergeResult& result, const AtlasOutputConfig& config,
                         const std::vector<std::pair<std::string, std::string>>& checksums) {
  YAML::Node root;
  root["version"] = kManifestVersion;
  root["settings"]["octomap_resolution_m"] = config.octomap.resolution_m;
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    YAML::Node entry;
    entry["id"] = sessions[s].id;
    entry["source"] = fs::absolute(sources[s]).lexically_normal().string();
    entry["connected"] = static_cast<bool>(result.solution.connected[s]);
    entry["T_atlas_session"] = matrixYaml(result.solution.T_atlas_session[s]);
    root["sessions"].push_back(entry);
  }
  for (const auto& [file, sha256] : checksums) root["files"][file] = sha256;
  YAML::Emitter out;
  out << root;
  return std::string(out.c_str()) + "\n";
}

// Every file under `dir` but the manifest, by path relative to it, sorted.
std::vector<std::string> filesOf(const fs::path& dir) {
  std::vector<std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    const std::string relative = fs::relative(entry.path(), dir).generic_string();
    if (relative != "atlas.yaml") files.push_back(relative);
  }
  std::sort(files.begin(), files.end());
  return files;
}

// The same with each file's SHA-256.
std::vector<std::pair<std::string, std::string>> checksumsOf(const fs::path& dir) {
  std::vector<std::pair<std::string, std::string>> checksums;
  for (const std::string& file : filesOf(dir))
    checksums.emplace_back(file, sha256OfFile(dir / file));
  return checksums;
}

// fsync(2) of one file or directory: its data, and for a directory its entries, reach the disk.
void syncPath(const fs::path& path, bool directory) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | (directory ? O_DIRECTORY : 0));
  if (fd < 0 || ::fsync(fd) != 0) {
    const std::error_code error(errno, std::generic_category());
    if (fd >= 0) ::close(fd);
    throw fs::filesystem_error("cannot flush to disk", path, error);
  }
  ::close(fd);
}

// Every file of the staging directory, then its directories, flushed: the swap that follows must
// not reach the disk before the data it makes visible (ext4 and xfs may reorder them otherwise).
void syncTree(const fs::path& dir) {
  std::vector<fs::path> directories{dir};
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_directory())
      directories.push_back(entry.path());
    else if (entry.is_regular_file())
      syncPath(entry.path(), false);
  }
  for (const fs::path& directory : directories) syncPath(directory, true);
}

// Puts the complete atlas `staging` at `target` in one step: the kernel swaps the two directory
// entries (renameat2 RENAME_EXCHANGE), so a kill at any moment leaves `target` old or new. Where
// the file system cannot swap, the old atlas is moved aside first, and a kill between the two
// renames leaves it at `previous` (readAtlasManifest then says so).
void swapIntoPlace(const fs::path& staging, const fs::path& target) {
  if (!fs::exists(target)) {
    fs::rename(staging, target);
    syncPath(target.parent_path(), true);
    return;
  }
  if (::renameat2(AT_FDCWD, staging.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) == 0) {
    syncPath(target.parent_path(), true);
    std::error_code ignored;
    fs::remove_all(staging, ignored);  // now the old atlas
    return;
  }
  if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP)
    throw fs::filesystem_error("cannot swap the new atlas into place", staging, target,
                               std::error_code(errno, std::generic_category()));
  const fs::path previous = previousAtlasPath(target);
  // A previous atlas left by a write killed after its second rename: `target` is whole.
  if (fs::exists(previous) && fs::exists(target / "atlas.yaml")) fs::remove_all(previous);
  fs::rename(target, previous);
  try {
    fs::rename(staging, target);
  } catch (...) {
    std::error_code ignored;
    fs::rename(previous, target, ignored);  // the old atlas back in place
    throw;
  }
  syncPath(target.parent_path(), true);
  std::error_code ignored;
  fs::remove_all(previous, ignored);
}

// Scratch directories of writes that were killed: `<atlas>.partial<pid>` of a process that is
// gone (a live one may be writing, though AtlasWriteLock keeps a second writer of the same atlas
// out before it gets here).
void removeStaleStaging(const fs::path& target) {
  const std::string prefix = target.filename().string() + ".partial";
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(target.parent_path(), error)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) == 0 && name.size() > prefix.size() &&
        name.size() - prefix.size() <= 9 &&
        std::all_of(name.begin() + prefix.size(), name.end(),
                    [](unsigned char c) { return std::isdigit(c) != 0; })) {
      const pid_t pid = static_cast<pid_t>(std::stol(name.substr(prefix.size())));
      if (::kill(pid, 0) == 0 || errno != ESRCH) continue;
      std::error_code ignored;
      fs::remove_all(entry.path(), ignored);
    }
  }
}

// JSON has no infinity or NaN: nlohmann writes them as null (a match without overlap scores
// -infinity), which reads back as NaN here.
double numberFromJson(const nlohmann::json& value) {
  return value.is_null() ? std::numeric_limits<double>::quiet_NaN() : value.get<double>();
}

// A whole number within int's range, or an InputError naming `file` and `what`: nlohmann's
// get<int>() casts any number, 1e300 included, which is undefined behaviour.
int intFromJson(const nlohmann::json& value, const fs::path& file, const std::string& what) {
  const bool fits = value.is_number_unsigned()
                        ? value.get<std::uint64_t>() <= static_cast<std::uint64_t>(INT_MAX)
                        : value.is_number_integer() && value.get<std::int64_t>() >= INT_MIN &&
                              value.get<std::int64_t>() <= INT_MAX;
  if (!fits) throw InputError(file.string(), 0, what + " is not a whole number of int's range");
  return static_cast<int>(value.get<std::int64_t>());
}

// A rigid transform (a 4 x 4 matrix of rows), or an InputError naming `file` and `what`.
Eigen::Isometry3d isometryFromJson(const nlohmann::json& rows, const fs::path& file,
                                   const std::string& what) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = rows.at(r).at(c).get<double>();
  const Eigen::Matrix3d R = T.linear();
  if (!T.matrix().allFinite() || !T.matrix().row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)) ||
      !(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || R.determinant() < 0.0)
    throw InputError(file.string(), 0, what + " is not a rigid transform");
  return T;
}

}  // namespace

std::vector<PairResult> readAtlasReportPairs(const fs::path& file,
                                             const std::vector<std::string>& session_ids) {
  std::map<std::string, int> index_of;
  for (std::size_t s = 0; s < session_ids.size(); ++s)
    index_of[session_ids[s]] = static_cast<int>(s);
  const auto indexOf = [&](const std::string& id) {
    const auto found = index_of.find(id);
    if (found == index_of.end())
      throw InputError(file.string(), 0,
                       "names session '" + id + "', which atlas.yaml does not list");
    return found->second;
  };
  std::vector<PairResult> pairs;
  if (!fs::exists(file))
    throw InputError(file.string(), 0, "missing: an atlas keeps its pairs here");
  try {
    const nlohmann::json report = nlohmann::json::parse(readWholeFile(file));
    std::set<std::pair<int, int>> listed;
    for (const auto& entry : report.at("pairs")) {
      PairResult pair;
      pair.a = indexOf(entry.at("a").get<std::string>());
      pair.b = indexOf(entry.at("b").get<std::string>());
      const std::string name = "pair " + session_ids[pair.a] + "+" + session_ids[pair.b];
      if (pair.a == pair.b ||
          !listed.insert({std::min(pair.a, pair.b), std::max(pair.a, pair.b)}).second)
        throw InputError(file.string(), 0,
                         name + ": a session paired with itself, or listed twice");
      pair.accepted = entry.at("overlap").get<bool>();
      pair.T_a_b = isometryFromJson(entry.at("T_a_b"), file, name + "'s T_a_b");
      pair.edges =
          entry.contains("edges") ? intFromJson(entry.at("edges"), file, name + "'s edges") : 0;
      pair.edges_kept = entry.contains("edges_kept")
                            ? intFromJson(entry.at("edges_kept"), file, name + "'s edges_kept")
                            : 0;
      const std::string role = entry.value("role", "refused");
      for (PairRole r :
           {PairRole::kRefused, PairRole::kTree, PairRole::kConsistent, PairRole::kInconsistent})
        if (toString(r) == role) pair.role = r;
      pair.geometry_only = entry.contains("geometry_only");
      pair.joint = entry.contains("joint");
      const nlohmann::json& magnetic =
          entry.at(pair.geometry_only ? "structure_match" : "magnetic");
      const std::string verdict = magnetic.at("verdict").get<std::string>();
      for (MatchVerdict v : {MatchVerdict::kMatch, MatchVerdict::kNoOverlap,
                             MatchVerdict::kAmbiguous, MatchVerdict::kYawUncertain})
        if (toString(v) == verdict) pair.magnetic.verdict = v;
      pair.magnetic.T_a_b = PlanarTransform::fromIsometry(
          isometryFromJson(magnetic.at("T_a_b"), file, name + "'s match T_a_b"));
      pair.magnetic.fitness = numberFromJson(magnetic.at("fitness"));
      pair.magnetic.z = numberFromJson(magnetic.at("z"));
      pair.magnetic.r = numberFromJson(magnetic.at("r"));
      pair.magnetic.overlap_m2 = numberFromJson(magnetic.at("overlap_m2"));
      pair.magnetic.second_mode_ratio = numberFromJson(magnetic.at("second_mode_ratio"));
      // Reports written before the yaw uncertainty was measured do not carry it.
      if (magnetic.contains("yaw_uncertainty_deg"))
        pair.magnetic.yaw_uncertainty_deg = numberFromJson(magnetic.at("yaw_uncertainty_deg"));
      if (entry.contains("icp_em")) {
        const nlohmann::json& icp = entry.at("icp_em");
        pair.refined = true;
        pair.icp.T_a_b = pair.T_a_b;
        pair.icp.converged = icp.at("converged").get<bool>();
        pair.icp.inlier_ratio = numberFromJson(icp.at("inlier_ratio"));
        pair.icp.iterations =
            intFromJson(icp.at("iterations"), file, name + "'s ICP-EM iterations");
        pair.icp.degenerate = icp.at("degenerate").get<bool>();
      }
      if (entry.contains("geometric_verification")) {
        const nlohmann::json& verification = entry.at("geometric_verification");
        pair.mode_inlier_ratios = verification.at("mode_inlier_ratios").get<std::vector<double>>();
        pair.geometry_chosen_mode =
            intFromJson(verification.at("chosen_mode"), file, name + "'s chosen_mode");
      }
      pairs.push_back(pair);
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(file.string(), 0, std::string("not a report this version wrote: ") + e.what());
  }
  return pairs;
}

fs::path checkAtlasTarget(const fs::path& dir, const std::vector<fs::path>& sources) {
  const fs::path target = normalAtlasPath(dir);
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
                             const AtlasOutputs& outputs) {
  const auto start = Clock::now();
  const MultiSessionSolution& solution = result.solution;
  if (sources.size() != sessions.size() || solution.connected.size() != sessions.size() ||
      solution.T_atlas_keyframe.size() != sessions.size() ||
      outputs.graphs.size() != outputs.placed.size())
    throw std::invalid_argument(
        "writeAtlas: sessions, sources, the solution and the outputs disagree in size");

  const fs::path target = checkAtlasTarget(dir, sources);
  removeStaleStaging(target);
  const fs::path staging = siblingPath(target, ".partial");
  fs::remove_all(staging);
  fs::create_directories(staging / "trajectories");
  try {
    for (const int s : outputs.placed) {
      std::vector<StampedPose> trajectory;
      for (std::size_t k = 0; k < sessions[s].keyframes.size(); ++k)
        trajectory.push_back({sessions[s].keyframes[k].time_s, solution.T_atlas_keyframe[s][k]});
      writeTumPoses(staging / "trajectories" / (sessions[s].id + ".txt"), trajectory);
    }
    if (!outputs.graphs.empty())
      writeMultiSessionGraphG2o(outputs.graphs, outputs.kept_edges, staging / "graph.g2o");
    if (outputs.cloud) {
      writeMergedCloudPcd(staging / "merged.pcd", *outputs.cloud);
      writePly(staging / "merged.ply", outputs.cloud->points);
    }
    if (outputs.fused) {
      writeMagneticMapPcd(staging / "magnetic_map.pcd", outputs.fused->map);
      if (outputs.fused->map.coveredCells() > 0) {
        MagneticMapRenderOptions render;
        render.title = "fused magnetic map, " + std::to_string(outputs.placed.size()) + " sessions";
        renderMagneticMapPng(outputs.fused->map, render, staging / "magnetic_map.png");
      }
    }
    if (outputs.octomap) writeOctoMap(staging / "octomap.bt", *outputs.octomap);
    writeFileAtomically(staging / "report.json",
                        reportJson(sessions, result, outputs.evaluation).dump(2) + "\n");
    writeFileAtomically(staging / "timings.json",
                        timingsJson(sessions, result, outputs).dump(2) + "\n");
    // The manifest last: it lists every other file with its checksum, so a staging directory
    // without it is incomplete by construction.
    writeFileAtomically(staging / "atlas.yaml", manifestYaml(sessions, sources, result,
                                                             outputs.config, checksumsOf(staging)));
    syncTree(staging);
    swapIntoPlace(staging, target);
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(staging, ignored);
    throw;
  }
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

AtlasWriteLock::AtlasWriteLock(const fs::path& atlas_dir) {
  fs::path lock = normalAtlasPath(atlas_dir);
  lock += ".lock";
  fs::create_directories(lock.parent_path());
  // Read-only is enough for flock, and lets another user who may write the atlas's directory
  // but not this file take the lock too.
  fd_ = ::open(lock.c_str(), O_RDONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw InputError(lock.string(), 0,
                     std::string("cannot create the atlas's lock file: ") + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    ::close(fd_);
    if (error == EWOULDBLOCK)
      throw AtlasBusy(atlas_dir.string() +
                      ": another mm4mm process is writing this atlas (it holds " + lock.string() +
                      "); run again when it has finished");
    throw InputError(lock.string(), 0, std::string("cannot lock: ") + std::strerror(error));
  }
}

AtlasWriteLock::~AtlasWriteLock() { ::close(fd_); }  // closing releases the flock

AtlasManifest readAtlasManifest(const fs::path& dir) {
  const fs::path file = dir / "atlas.yaml";
  const std::string name = file.string();
  if (!fs::exists(file)) {
    const fs::path previous = previousAtlasPath(dir);
    if (fs::exists(previous / "atlas.yaml"))
      throw InputError(dir.string(), 0,
                       "no atlas here, but an interrupted write left the previous atlas at " +
                           previous.string() + ": rename it back to " + dir.string());
    throw InputError(dir.string(), 0, "not an atlas directory (no atlas.yaml)");
  }
  const std::string content = readWholeFile(file);
  YAML::Node root;
  try {
    root = YAML::Load(content);
  } catch (const YAML::Exception& e) {
    throw InputError(name, e.mark.line + 1, std::string("not valid YAML: ") + e.msg);
  }
  // Every field read names itself in the error, with the line of its parent.
  const auto field = [&](const YAML::Node& parent, const char* key, const std::string& where) {
    // yaml-cpp throws on a subscript of a scalar or a list: a corrupt manifest, said as such.
    if (!parent.IsMap())
      throw InputError(name, parent.Mark().line + 1,
                       where + "expected a map holding '" + key + "'");
    const YAML::Node value = parent[key];
    if (!value)
      throw InputError(name, parent.Mark().line + 1, where + "missing field '" + key + "'");
    return value;
  };
  const auto as = [&](const YAML::Node& value, const std::string& what, auto example) {
    try {
      return value.as<decltype(example)>();
    } catch (const YAML::Exception&) {
      throw InputError(name, value.Mark().line + 1, what + " is malformed");
    }
  };
  AtlasManifest manifest;
  manifest.version = as(field(root, "version", ""), "'version'", 0);
  if (manifest.version != kManifestVersion)
    throw InputError(name, 0,
                     "version " + std::to_string(manifest.version) + " is not supported (" +
                         std::to_string(kManifestVersion) +
                         " is; an atlas of version 1 has no checksums: merge it again)");
  manifest.octomap_resolution_m =
      as(field(field(root, "settings", ""), "octomap_resolution_m", "settings: "),
         "'settings.octomap_resolution_m'", 0.0);
  const YAML::Node sessions = field(root, "sessions", "");
  if (!sessions.IsSequence() || sessions.size() == 0)
    throw InputError(name, sessions.Mark().line + 1, "'sessions' must be a non-empty list");
  for (const YAML::Node& node : sessions) {
    AtlasSessionEntry entry;
    entry.id = as(field(node, "id", "a session: "), "'id'", std::string());
    const std::string where = "session '" + entry.id + "': ";
    if (entry.id.empty() || entry.id.find('/') != std::string::npos || entry.id == "." ||
        entry.id == "..")
      throw InputError(name, node.Mark().line + 1, where + "the id must be a plain name");
    entry.source = as(field(node, "source", where), where + "'source'", std::string());
    entry.connected = as(field(node, "connected", where), where + "'connected'", false);
    const YAML::Node T = field(node, "T_atlas_session", where);
    if (!T.IsSequence() || T.size() != 4)
      throw InputError(name, T.Mark().line + 1, where + "T_atlas_session must be 4 rows");
    for (int r = 0; r < 4; ++r) {
      if (!T[r].IsSequence() || T[r].size() != 4)
        throw InputError(
            name, T[r].Mark().line + 1,
            where + "T_atlas_session row " + std::to_string(r + 1) + " must hold 4 numbers");
      for (int c = 0; c < 4; ++c)
        entry.T_atlas_session.matrix()(r, c) =
            as(T[r][c], where + "T_atlas_session row " + std::to_string(r + 1), 0.0);
    }
    manifest.sessions.push_back(entry);
  }
  const YAML::Node files = field(root, "files", "");
  if (!files.IsMap()) throw InputError(name, files.Mark().line + 1, "'files' must be a map");
  for (const auto& item : files) {
    const std::string file = as(item.first, "a file name in 'files'", std::string());
    const std::string sha256 = as(item.second, "the checksum of " + file, std::string());
    const int line = item.first.Mark().line + 1;
    // Names stay inside the atlas: a manifest must not point the reader elsewhere.
    const fs::path relative(file);
    if (file.empty() || relative.is_absolute() ||
        std::any_of(relative.begin(), relative.end(),
                    [](const fs::path& part) { return part == ".."; }))
      throw InputError(name, line, "'" + file + "' is not a file of the atlas");
    if (!fs::is_regular_file(dir / file))
      throw InputError(name, line,
                       "lists " + file + ", which is missing (a corrupt or half-written atlas)");
    if (sha256OfFile(dir / file) != sha256)
      throw InputError(name, line,
                       file + " does not match its checksum (a corrupt or half-written atlas)");
    manifest.files.emplace_back(file, sha256);
  }
  // A manifest cut short lists fewer files than the atlas holds.
  for (const std::string& file : filesOf(dir))
    if (std::none_of(manifest.files.begin(), manifest.files.end(),
                     [&](const auto& listed) { return listed.first == file; }))
      throw InputError(name, 0,
                       file + " is not listed in 'files' (a corrupt or half-written manifest)");
  return manifest;
}

Atlas loadAtlas(const fs::path& dir) {
  Atlas atlas;
  atlas.manifest = readAtlasManifest(dir);
  for (const AtlasSessionEntry& entry : atlas.manifest.sessions) {
    if (!fs::exists(entry.source / "session.yaml"))
      throw InputError((dir / "atlas.yaml").string(), 0,
                       "session '" + entry.id + "': its source " + entry.source.string() +
                           " is not a session directory (moved or deleted?)");
    atlas.sessions.push_back(readSession(entry.source));
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
  if (fs::exists(dir / "graph.g2o")) {
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
  if (fs::exists(dir / "magnetic_map.pcd"))
    atlas.fused_magnetic_map = readMagneticMapPcd(dir / "magnetic_map.pcd");
  return atlas;
}

}  // namespace mm4mm
