#include "atlas_report.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <set>

#include "json_util.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/match_json.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace io_detail {
namespace {

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

// The offsets the fused map applied to each placed session's B_h and B_v, the shared cells they
// were solved from (each pair's median disagreement before them) and the anchor.
nlohmann::json fieldOffsetsJson(const std::vector<Session>& sessions, const AtlasOutputs& outputs) {
  const FieldOffsets& f = outputs.fused->offsets;
  const auto idOf = [&](int layer) { return sessions[outputs.placed[layer]].id; };
  nlohmann::json json = {{"anchor", f.anchor},
                         {"sessions", nlohmann::json::array()},
                         {"pairs", nlohmann::json::array()}};
  const FusedMagneticMap& fused = *outputs.fused;
  for (std::size_t l = 0; l < f.offsets.size() && l < outputs.placed.size(); ++l) {
    nlohmann::json entry = {{"id", idOf(static_cast<int>(l))},
                            {"solved", static_cast<bool>(f.linked[l])},
                            {"earth_anchored", static_cast<bool>(f.earth_anchored[l])},
                            {"observed_anchored", static_cast<bool>(f.observed_anchored[l])},
                            {"horizontal_uT", f.offsets[l].horizontal_uT},
                            {"vertical_uT", f.offsets[l].vertical_uT}};
    // Left out of the fused map: its magnetometers read the field at another height.
    if (l < fused.other_height_m.size() && fused.other_height_m[l])
      entry["other_height_m"] = *fused.other_height_m[l];
    json["sessions"].push_back(entry);
  }
  for (const LayerDisagreement& d : f.pairs)
    json["pairs"].push_back(
        {{"a", idOf(d.a)},
         {"b", idOf(d.b)},
         {"shared_cells", d.cells},
         {"median_difference_before_uT",
          {{"horizontal", d.horizontal_uT}, {"vertical", d.vertical_uT}, {"total", d.total_uT}}}});
  return json;
}

// Where two placed sessions' fields differ past what both maps' uncertainty explains
// (FusedMagneticMap::changes): the pairs compared and each region, largest first per pair, with
// the number changes/magnetic_change.pcd gives its cells.
nlohmann::json changesJson(const std::vector<Session>& sessions, const AtlasOutputs& outputs) {
  const auto idOf = [&](int layer) { return sessions[outputs.placed[layer]].id; };
  nlohmann::json of = nlohmann::json::array();
  for (std::size_t l = 0; l < outputs.fused->changes_of.size(); ++l)
    if (outputs.fused->changes_of[l]) of.push_back(idOf(static_cast<int>(l)));
  nlohmann::json unchecked = nlohmann::json::array();
  for (std::size_t l = 0; l < outputs.fused->change_unchecked.size(); ++l)
    if (outputs.fused->change_unchecked[l]) unchecked.push_back(idOf(static_cast<int>(l)));
  nlohmann::json json = {{"pairs_compared", outputs.fused->changes.size()},
                         {"pairs_of", of},
                         {"calibration_unchecked", unchecked},
                         {"regions", nlohmann::json::array()}};
  for (const LayerChange& change : outputs.fused->changes)
    for (const MagneticChangeRegion& region : change.regions)
      json["regions"].push_back({{"number", json["regions"].size() + 1},
                                 {"a", idOf(change.a)},
                                 {"b", idOf(change.b)},
                                 {"area_m2", region.area_m2},
                                 {"centroid_m", {region.centroid_m.x(), region.centroid_m.y()}},
                                 {"mean_delta_uT", region.mean_delta_uT},
                                 {"max_delta_uT", region.max_delta_uT}});
  return json;
}

std::string formatHeight(double difference_m) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2f", std::abs(difference_m));
  return text;
}

}  // namespace

nlohmann::json reportJson(const std::vector<Session>& sessions, const MergeResult& result,
                          const AtlasOutputs& outputs) {
  const std::optional<AtlasEvaluation>& evaluation = outputs.evaluation;
  const MultiSessionSolution& solution = result.solution;
  nlohmann::json report;
  report["frame"] = sessions.at(result.frame_session).id;
  report["sessions"] = nlohmann::json::array();
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    nlohmann::json entry = {{"id", sessions[s].id},
                            {"connected", static_cast<bool>(solution.connected[s])},
                            {"T_atlas_session", matrixJson(solution.T_atlas_session[s])}};
    if (s < result.match_obstacles.size() && result.match_obstacles[s].any()) {
      entry["not_matchable"] = describe(result.match_obstacles[s]);
      entry["not_matchable_reason"] = toString(result.match_obstacles[s].reason);
    }
    if (s < result.frame_heights.size() && result.frame_heights[s]) {
      entry["frame_height_above_floor_m"] = result.frame_heights[s]->height_m;
      entry["frame_height_from"] = result.frame_heights[s]->from_scans ? "scans" : "stated";
    }
    if (s < result.magnetometer_heights_m.size() && result.magnetometer_heights_m[s])
      entry["magnetometer_height_above_floor_m"] = *result.magnetometer_heights_m[s];
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
    if (pair.height_difference_m) {
      // a's magnetometers above b's by this: the field was not compared across that height.
      entry["height_difference_m"] = *pair.height_difference_m;
      entry["height_difference"] = "magnetometers " + formatHeight(*pair.height_difference_m) +
                                   " m apart in height: not searched by the field alone";
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
  if (outputs.fused) {
    report["field_offsets"] = fieldOffsetsJson(sessions, outputs);
    report["changes"] = changesJson(sessions, outputs);
  }
  return report;
}

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

}  // namespace io_detail

namespace {

namespace fs = std::filesystem;
using io_detail::readWholeFile;

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
      if (entry.contains("height_difference_m"))
        pair.height_difference_m = numberFromJson(entry.at("height_difference_m"));
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
      if (magnetic.contains("probability"))
        pair.magnetic.probability = numberFromJson(magnetic.at("probability"));
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

ReportedChanges readAtlasReportChanges(const fs::path& file) {
  ReportedChanges changes;
  if (!fs::exists(file)) throw InputError(file.string(), 0, "missing");
  try {
    const nlohmann::json report = nlohmann::json::parse(readWholeFile(file));
    if (!report.contains("changes")) return changes;
    const nlohmann::json& section = report.at("changes");
    changes.pairs_compared = static_cast<std::size_t>(
        intFromJson(section.at("pairs_compared"), file, "changes' pairs_compared"));
    // Absent from the reports of the first version of the section, which compared every pair.
    if (section.contains("pairs_of"))
      changes.pairs_of = section.at("pairs_of").get<std::vector<std::string>>();
    if (section.contains("calibration_unchecked"))
      changes.calibration_unchecked =
          section.at("calibration_unchecked").get<std::vector<std::string>>();
    for (const auto& entry : section.at("regions")) {
      ReportedChanges::Region region;
      region.a = entry.at("a").get<std::string>();
      region.b = entry.at("b").get<std::string>();
      region.region.area_m2 = numberFromJson(entry.at("area_m2"));
      const auto centroid = entry.at("centroid_m").get<std::vector<double>>();
      if (centroid.size() != 2)
        throw InputError(file.string(), 0, "a change region's centroid_m is not [x, y]");
      region.region.centroid_m = Eigen::Vector2d(centroid[0], centroid[1]);
      region.region.mean_delta_uT = numberFromJson(entry.at("mean_delta_uT"));
      region.region.max_delta_uT = numberFromJson(entry.at("max_delta_uT"));
      changes.regions.push_back(region);
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(file.string(), 0, std::string("not a report this version wrote: ") + e.what());
  }
  return changes;
}

}  // namespace mm4mm
