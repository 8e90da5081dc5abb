// Magnetic matching benchmark: success rate, overlap errors, the paper's e_t / e_r, false
// overlaps on disjoint pairs and time per match, over seeds of the simulator's presets, for each
// rig (one IMU magnetometer, the 7-sensor array, ...), sensor model (clean, realistic) and
// calibration (none, estimated from each session's own data, or the simulator's true one: the
// upper bound an estimator could reach). Prints markdown; writes a CSV.
//
// Usage: match_bench [--seeds N] [--first-seed S] [--methods a,b,...] [--presets a,b,...]
//                    [--rigs a,b,...] [--sensors clean,realistic] [--calibrations a,b,...]
//                    [--matcher FILE] [--csv FILE]
//                    [--peer-rules FILE] [--peer-voxel M] [--vertical-offset-uT X]
// Methods: default (the code's or --matcher's settings), compass (the compass prior on),
// exhaustive (the compass prior and coarse to fine off: every yaw and shift of the circle on the
// search's cells), pyramid (coarse to fine: the sweep on cells twice as coarse, its peaks
// searched again on the search's cells; correlation_search.hpp), refine_all (exhaustive, with
// every mode of the sweep refined: the default since refine_modes became max_modes, so the same
// as exhaustive unless --matcher sets fewer), probability (the confidence
// model decides, match_confidence.hpp), grid,
// none, concordance, paper; joint (the field alone, then, where it refused, its choice among the
// structure maps' modes, as merge does), joint_pyramid (joint with the structure maps' modes
// proposed by coarse to fine: JointMatchConfig::structure_pyramid_factor 2) and geometry (the
// structure maps alone), which simulate
// scans. Presets: warehouse, random, corridor; procedural (a building type drawn from the seed,
// the CSV's preset column names it) or one type: hallway, office, garage, racks, hall.
// Rigs: imu, husky3, array7, handheld. Calibrations: none, estimated, true (clean sensors are run
// uncalibrated only). --matcher: a config YAML (configs/mm4mm.yaml) whose merge.matcher every
// method starts from; its merge.joint, merge.structure_map and merge.geometry_matcher set the
// joint and geometry methods.
// The CSV also holds the verdict, z, r, second-mode ratio and yaw uncertainty, the fine score at
// the true transform, where each match spent its time (maps, global search, refinement, yaw
// interval; "joint" and "geometry" record the field match's stages only), how the compass was
// used and its error against the truth with its trust, the answer T_a_b (x, y, yaw: two
// methods' answers can be compared pair by pair) and the stage that gave it (field, joint or
// structure: a joint row is the field's own where the field accepted); stderr says where among the
// modes the true overlap was (MATCH_BENCH_MODES=1 lists every mode).
// Cloud peers (issue 31 slice 6) run on the same pairs: pcl-gicp and pcl-ndt from the identity and
// from the centroids at 8 headings, pcl-fpfh-sacia-gicp from 4 seeds, each on the sessions' point
// maps at --peer-voxel (default 0.5 m; FPFH works at 1 m inside). Finer costs more than the
// machine has for 9 starts a pair: at 0.25 m one procedural pair took GICP 163 s, at 0.5 m 8-20 s;
// mm4mm's own refinement reads 0.25 m maps. A peer's row holds, in place of the field's features: r
// its best answer's fitness, z that answer's inlier RMSE (m), second_mode_ratio the best distinct
// answer's fitness over the best's; stage "clouds". It claims by --peer-rules
// (scripts/choose_peer_rules.py --multi-start; without it, whatever converged).
// --vertical-offset-uT X (issue 32): after calibration, X µT is added along the body's z to every
// reading of s1 and s3 and of the disjoint session, so that every pair's two sessions differ by
// about X in B_v on a level body (the soft iron's few per cent scale it): what a level robot's
// unobservable vertical hard iron leaves. Run with and without, pair by pair, it shows whether such
// an offset changes a match decision.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "bench_util.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/magnetic/compass_prior.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/merge/joint_match.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/merge/structure_map.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "peer_registration.hpp"
#include "sim_presets.hpp"

namespace {

using namespace mm4mm;
using bench::median;
using bench::parseFlags;
using bench::splitList;

sim::SimulationConfig presetConfig(const std::string& preset, const std::string& rig,
                                   const std::string& sensors, bool scans) {
  sim::SimulationConfig c;
  c.lidar.enabled = scans;  // the field alone needs no scans; joint and geometry matching do
  if (preset == "corridor") c.world = "corridor";
  if (preset == "random") c.layout.mode = "random";
  const auto& buildings = sim::proceduralBuildings();
  if (preset == "procedural" ||
      std::find(buildings.begin(), buildings.end(), preset) != buildings.end()) {
    bench::makeProcedural(preset == "procedural" ? "any" : preset, &c);
  }
  sim::applyRigPreset(rig, &c);
  c.magnetometer_errors.model = sensors;
  return c;
}

MagneticMatcherConfig methodConfig(const std::string& method, const std::string& matcher_file) {
  MagneticMatcherConfig c;
  if (!matcher_file.empty()) c = loadPipelineConfig(matcher_file).merge.matcher;
  if (method == "grid") c.refinement = RefinementMethod::kLocalGrid;
  if (method == "none") c.refinement = RefinementMethod::kNone;
  if (method == "compass") c.use_compass_prior = true;
  if (method == "exhaustive") c.use_compass_prior = false, c.search.pyramid_factor = 1;
  if (method == "pyramid") c.use_compass_prior = false, c.search.pyramid_factor = 2;
  if (method == "refine_all")
    c.use_compass_prior = false, c.search.pyramid_factor = 1, c.refine_modes = c.search.max_modes;
  if (method == "probability") c.confidence_model.decides = true;
  if (method == "concordance") c.score.statistic = CorrelationStatistic::kConcordance;
  if (method == "paper") {
    // The paper's Eq. 4–5 fitness, minimum overlap, one PSO over the full (x, y, yaw) box.
    c.global = GlobalSearchMethod::kPaperPso;
    c.score.kind = MatchScoreKind::kPaperFitness;
    c.score.stride = 6;
    c.paper_pso.particles = 100;
    c.paper_pso.iterations = 60;
  }
  return c;
}

// The sessions as each calibration variant sees them: "true" states the simulator's calibration
// in the rig, as a user's session.yaml would.
// `estimates`: how each "estimated" calibration was reached (empty for the other variants).
std::vector<Session> withCalibration(std::vector<Session> sessions, const std::string& variant,
                                     const CalibrationConfig& calibration,
                                     std::vector<SessionCalibration>* estimates) {
  estimates->clear();
  if (variant == "estimated") {
    std::vector<Session*> pointers;
    for (Session& s : sessions) pointers.push_back(&s);
    *estimates = calibrateSessions(pointers, calibration);  // once per session, as the pipeline
    return sessions;
  }
  if (variant != "true") return sessions;
  for (Session& s : sessions) {
    s.rig.calibrations.clear();
    for (const MagnetometerCalibration& c : *s.true_calibration) s.rig.calibrations.push_back(c);
  }
  return sessions;
}

// Every reading of `session` shifted by `offset_uT` along the body's z.
void addVerticalOffset(Session* session, double offset_uT) {
  for (MagnetometerSample& sample : session->magnetometer) sample.field_body_uT.z() += offset_uT;
}

struct Outcome {
  bool overlapping = false;         // by ground truth: at least 10 keyframe pairs within 2 m
  bool separate = false;            // by ground truth: no keyframe of one within 2 m of the other
  double swath_overlap_m2 = 0;      // common magnetic swath at the true transform
  double truth_z = 0, truth_r = 0;  // the fine score at the true transform
  bool accepted = false;
  bool aligned = false;
  double overlap_t = 0, overlap_r = 0, frame_t = 0, frame_r = 0, seconds = 0;
  double compass_error_deg = 0, compass_resultant = 0;  // the compass heading against the truth
  // From the sessions' calibrations (0 unless estimated): the field's spread along each track and
  // the larger of the two sessions' worst per-sensor residuals after calibration.
  double field_spread_a_uT = 0, field_spread_b_uT = 0, calibration_residual_uT = 0;
};

// Cloud peers (issue 31 slice 6): what a user without mm4mm would run on the same pairs, from
// several starts, refusing as mm4mm refuses (peer_registration.hpp's AmbiguityRule).
bool isPeer(const std::string& method) { return method.rfind("pcl-", 0) == 0; }

// Headings tried from the centroids by the methods that need a guess (45 degrees apart: GICP's
// and NDT's basin on building maps is about +-20 degrees), and the seeds of the global pipeline.
constexpr int kPeerYaws = 8;
constexpr unsigned kPeerSeeds = 4;

MagneticMatchResult peerMatch(const std::string& method, const PointCloud& a, const PointCloud& b,
                              const peers::AmbiguityRule& rule) {
  std::vector<peers::PeerResult> answers;
  if (method == "pcl-fpfh-sacia-gicp") {
    for (unsigned seed = 1; seed <= kPeerSeeds; ++seed)
      answers.push_back(peers::registerFpfhSacIaGicp(a, b, seed));
  } else if (method == "pcl-gicp" || method == "pcl-ndt") {
    for (const Eigen::Isometry3d& start : peers::guessStarts(a, b, kPeerYaws))
      answers.push_back(method == "pcl-gicp" ? peers::registerGicp(a, b, start)
                                             : peers::registerNdt(a, b, start));
  } else {
    throw std::invalid_argument("unknown method " + method);
  }
  const peers::MultiStartResult m = peers::bestOfStarts(a, b, std::move(answers));
  MagneticMatchResult r;
  r.T_a_b = PlanarTransform::fromIsometry(m.best.T_target_source);
  r.r = m.best.fitness;
  r.z = m.best.inlier_rmse_m;
  r.second_mode_ratio = m.secondRatio();
  const bool fits = m.best.converged && m.best.fitness >= rule.min_fitness;
  r.verdict = rule.claims(m) ? MatchVerdict::kMatch
                             : (fits ? MatchVerdict::kAmbiguous : MatchVerdict::kNoOverlap);
  return r;
}

using Key = std::tuple<std::string, std::string, std::string, std::string, std::string>;

}  // namespace

int main(int argc, char** argv) {
  int seeds = 20, first_seed = 1;
  std::vector<std::string> methods{"default"}, presets{"warehouse", "random", "corridor"},
      rigs{"imu", "array7"}, sensor_models{"realistic"}, calibrations{"estimated"};
  std::string csv_path = "match_bench.csv", matcher_file, peer_rules_file;
  double peer_voxel_m = 0.5, vertical_offset_uT = 0.0;
  for (const auto& [flag, value] : parseFlags(
           argc, argv,
           {"--seeds", "--first-seed", "--methods", "--presets", "--rigs", "--sensors",
            "--calibrations", "--matcher", "--csv", "--peer-rules", "--peer-voxel",
            "--vertical-offset-uT"},
           "match_bench [--seeds N] [--first-seed S] [--methods a,b,...] [--presets a,b,...] "
           "[--rigs a,b,...] [--sensors clean,realistic] [--calibrations none,estimated,true] "
           "[--matcher FILE] [--csv FILE] [--peer-rules FILE] [--peer-voxel M] "
           "[--vertical-offset-uT X]")) {
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--methods") methods = splitList(value);
    if (flag == "--presets") presets = splitList(value);
    if (flag == "--rigs") rigs = splitList(value);
    if (flag == "--sensors") sensor_models = splitList(value);
    if (flag == "--calibrations") calibrations = splitList(value);
    if (flag == "--matcher") matcher_file = value;
    if (flag == "--csv") csv_path = value;
    if (flag == "--peer-rules") peer_rules_file = value;
    if (flag == "--peer-voxel") peer_voxel_m = std::stod(value);
    if (flag == "--vertical-offset-uT") vertical_offset_uT = std::stod(value);
  }
  const std::map<std::string, peers::AmbiguityRule> peer_rules =
      peers::readAmbiguityRules(peer_rules_file);
  std::ofstream csv(csv_path);
  csv << "preset,rig,sensors,calibration,seed,method,pair,overlapping,separate,accepted,aligned,"
         "overlap_error_m,overlap_error_deg,e_t_m,e_r_deg,seconds,swath_overlap_m2,verdict,z,r,"
         "second_mode_ratio,truth_z,truth_r,yaw_uncertainty_deg,maps_s,search_s,refine_s,"
         "yaw_interval_s,compass,compass_error_deg,compass_resultant,overlap_m2,overlap_length_m,"
         "overlap_width_m,field_std_uT,field_spread_a_uT,field_spread_b_uT,calibration_residual_uT,"
         "probability,x_m,y_m,yaw_deg,stage\n";
  std::map<Key, std::vector<Outcome>> results;

  for (const std::string& preset : presets)
    for (const std::string& rig : rigs)
      for (const std::string& sensors : sensor_models)
        for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
          const bool scans = std::any_of(methods.begin(), methods.end(), [](const std::string& m) {
            return m == "joint" || m == "joint_pyramid" || m == "geometry" || isPeer(m);
          });
          sim::SimulationConfig config = presetConfig(preset, rig, sensors, scans);
          // A procedural preset's rows name the building the seed drew.
          const std::string world_name =
              config.world == "procedural"
                  ? "procedural:" + sim::SimulatedWorld(config, seed).world.name
                  : preset;
          const int shared = config.world == "corridor" ? 3 : 4;
          const auto simulated = sim::simulateSessions(config, shared, seed);
          config.layout.disjoint_session = true;
          const auto simulated_disjoint = sim::simulateSessions(config, shared + 1, seed);
          for (const std::string& calibration : calibrations) {
            if (sensors == "clean" && calibration != calibrations.front()) continue;
            const std::string variant = sensors == "clean" ? "none" : calibration;
            const CalibrationConfig calibrator = methodConfig("default", matcher_file).calibration;
            std::vector<SessionCalibration> estimates, estimates_disjoint;
            auto sessions = withCalibration(simulated, variant, calibrator, &estimates);
            auto with_disjoint =
                withCalibration(simulated_disjoint, variant, calibrator, &estimates_disjoint);
            if (vertical_offset_uT != 0.0) {
              for (std::size_t k = 1; k < sessions.size(); k += 2)
                addVerticalOffset(&sessions[k], vertical_offset_uT);
              addVerticalOffset(&with_disjoint[shared], vertical_offset_uT);
            }
            std::map<const Session*, const SessionCalibration*> estimate_of;
            for (std::size_t k = 0; k < estimates.size(); ++k)
              estimate_of[&sessions[k]] = &estimates[k];
            for (std::size_t k = 0; k < estimates_disjoint.size(); ++k)
              estimate_of[&with_disjoint[k]] = &estimates_disjoint[k];
            // Consecutive sessions (the paper's pairs 1+2, 2+3, 3+4), and the disjoint one
            // against s0.
            std::vector<std::pair<const Session*, const Session*>> pairs;
            std::map<const Session*, MagneticMap> structure_maps;  // match grids, one per session
            const MergeConfig merge =
                matcher_file.empty() ? MergeConfig{} : loadPipelineConfig(matcher_file).merge;
            const auto structureOf = [&](const Session* s) -> const MagneticMap& {
              auto found = structure_maps.find(s);
              if (found == structure_maps.end())
                found = structure_maps
                            .emplace(s, buildStructureMap(*s, merge.structure_map).asMatchGrid())
                            .first;
              return found->second;
            };
            std::map<const Session*, PointCloud> peer_clouds;  // the peers' input, per session
            const auto cloudOf = [&](const Session* s) -> const PointCloud& {
              auto found = peer_clouds.find(s);
              if (found == peer_clouds.end()) {
                PointMapConfig c;
                c.voxel_size_m = peer_voxel_m;
                found = peer_clouds.emplace(s, buildVoxelisedPoints(*s, c)).first;
              }
              return found->second;
            };
            for (int k = 0; k + 1 < shared; ++k) pairs.push_back({&sessions[k], &sessions[k + 1]});
            pairs.push_back({&with_disjoint[0], &with_disjoint[shared]});
            for (const std::string& method : methods) {
              MagneticMatcherConfig matcher = methodConfig(method, matcher_file);
              matcher.calibration.enabled = false;  // done above, or not at all
              for (std::size_t p = 0; p < pairs.size(); ++p) {
                const Session& a = *pairs[p].first;
                const Session& b = *pairs[p].second;
                Outcome o;
                const int true_pairs = overlapError(a, b, trueRelativeTransform(a, b)).pairs;
                o.overlapping = true_pairs >= 10;
                o.separate = true_pairs == 0;
                MagneticMatchResult r;
                const char* stage = "field";
                const auto match_start = std::chrono::steady_clock::now();
                if (isPeer(method)) {
                  r = peerMatch(
                      method, cloudOf(&a), cloudOf(&b),
                      peer_rules.count(method) ? peer_rules.at(method) : peers::AmbiguityRule{});
                  stage = "clouds";
                } else if (method == "geometry") {
                  // Walls alone: the structure maps' match, as the geometry-only fallback runs it.
                  r = matchMagneticMaps(structureOf(&a), structureOf(&b), merge.geometry_matcher);
                  stage = "structure";
                } else {
                  r = matchSessions(a, b, matcher);
                  // Joint, as merge runs it: where the field alone did not accept a place, it
                  // chooses among the structure maps' modes.
                  if ((method == "joint" || method == "joint_pyramid") && !r.overlap()) {
                    JointMatchConfig joint = merge.joint;
                    if (method == "joint_pyramid") joint.structure_pyramid_factor = 2;
                    const MagneticMatchResult structure = matchStructureForJoint(
                        structureOf(&a), structureOf(&b), merge.geometry_matcher, joint);
                    const MagneticMatchResult chosen =
                        matchJointly(buildSessionMap(a, matcher), buildSessionMap(b, matcher),
                                     structure, merge.geometry_matcher, matcher, joint);
                    if (std::getenv("MATCH_BENCH_MODES")) {
                      for (const CorrelationMode& m : structure.modes)
                        std::fprintf(
                            stderr,
                            "  structure mode: x %.2f y %.2f yaw %.1f z %.2f r %.3f error %.2f m\n",
                            m.T_a_b.x_m, m.T_a_b.y_m, m.T_a_b.yaw_rad * 180 / M_PI, m.z, m.r,
                            overlapError(a, b, m.T_a_b.toIsometry()).median_translation_m);
                      for (const CorrelationMode& m : chosen.modes)
                        std::fprintf(stderr,
                                     "  joint candidate: x %.2f y %.2f yaw %.1f z %.2f r %.3f "
                                     "overlap %.1f error %.2f m\n",
                                     m.T_a_b.x_m, m.T_a_b.y_m, m.T_a_b.yaw_rad * 180 / M_PI, m.z,
                                     m.r, m.overlap_m2,
                                     overlapError(a, b, m.T_a_b.toIsometry()).median_translation_m);
                    }
                    if (chosen.overlap()) {
                      r = chosen;
                      stage = "joint";
                    }
                  }
                }
                r.seconds =
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - match_start)
                        .count();
                {
                  // What the matcher could use at best: the common swath at the truth.
                  const MagneticMap map_a = buildSessionMap(a, matcher);
                  const MagneticMap map_b = buildSessionMap(b, matcher);
                  const MatchScore at_truth =
                      MatchScorer(map_a, map_b, matcher.score)
                          .evaluate(PlanarTransform::fromIsometry(trueRelativeTransform(a, b)));
                  o.swath_overlap_m2 = at_truth.overlap_m2;
                  // The compass against the truth, whether the method used it or not.
                  const CompassHeading compass = compassHeading(map_a, map_b);
                  o.compass_error_deg =
                      wrapAngle(
                          compass.yaw_rad -
                          PlanarTransform::fromIsometry(trueRelativeTransform(a, b)).yaw_rad) *
                      180.0 / M_PI;
                  o.compass_resultant = compass.resultant;
                  o.truth_z = at_truth.z, o.truth_r = at_truth.r;
                }
                if (estimate_of.count(&a) && estimate_of.count(&b)) {
                  const SessionCalibration& ca = *estimate_of.at(&a);
                  const SessionCalibration& cb = *estimate_of.at(&b);
                  o.field_spread_a_uT = ca.field_spread_uT;
                  o.field_spread_b_uT = cb.field_spread_uT;
                  for (const SessionCalibration* c : {&ca, &cb})
                    for (const SensorCalibration& sensor : c->sensors)
                      o.calibration_residual_uT =
                          std::max(o.calibration_residual_uT, sensor.residual_after_uT);
                }
                o.accepted = r.overlap();
                o.seconds = r.seconds;
                const Eigen::Isometry3d T = r.T_a_b.toIsometry();
                if (o.overlapping) {
                  const OverlapError e = overlapError(a, b, T);
                  const FrameError f = frameError(a, b, T);
                  o.overlap_t = e.median_translation_m, o.overlap_r = e.median_rotation_deg;
                  o.frame_t = f.translation_m, o.frame_r = f.rotation_deg;
                  o.aligned = o.accepted && e.aligned();
                }
                results[{preset, rig, sensors, variant, method}].push_back(o);
                // Where the search put the true overlap: the rank of the first aligned mode.
                int truth_rank = -1;
                for (std::size_t m = 0; m < r.modes.size() && truth_rank < 0 && o.overlapping; ++m)
                  if (overlapError(a, b, r.modes[m].T_a_b.toIsometry()).aligned())
                    truth_rank = static_cast<int>(m);
                if (std::getenv("MATCH_BENCH_MODES"))
                  for (std::size_t m = 0; m < r.modes.size(); ++m)
                    std::fprintf(stderr,
                                 "  mode %zu: x %.2f y %.2f yaw %.1f z %.2f r %.3f overlap %.1f\n",
                                 m, r.modes[m].T_a_b.x_m, r.modes[m].T_a_b.y_m,
                                 r.modes[m].T_a_b.yaw_rad * 180 / M_PI, r.modes[m].z, r.modes[m].r,
                                 r.modes[m].overlap_m2);
                if (truth_rank >= 0)
                  std::fprintf(stderr, "  truth mode %d: z %.2f r %.3f overlap %.1f\n", truth_rank,
                               r.modes[truth_rank].z, r.modes[truth_rank].r,
                               r.modes[truth_rank].overlap_m2);
                char line[768];
                std::snprintf(
                    line, sizeof(line),
                    "%s,%s,%s,%s,%d,%s,%s-%s,%d,%d,%d,%d,%.4f,%.4f,%.4f,%.4f,%.3f,%.1f,%s,"
                    "%.2f,%.3f,%.3f,%.2f,%.3f,%.2f,%.3f,%.3f,%.3f,%.3f,%s,%.2f,%.3f,%.1f,%.2f,%.2f,"
                    "%.3f,"
                    "%.3f,%.3f,%.3f,%.4f,%.4f,%.4f,%.4f,%s\n",
                    world_name.c_str(), rig.c_str(), sensors.c_str(), variant.c_str(), seed,
                    method.c_str(), a.id.c_str(), b.id.c_str(), o.overlapping, o.separate,
                    o.accepted, o.aligned, o.overlap_t, o.overlap_r, o.frame_t, o.frame_r,
                    o.seconds, o.swath_overlap_m2, toString(r.verdict).c_str(), r.z, r.r,
                    r.second_mode_ratio, o.truth_z, o.truth_r, r.yaw_uncertainty_deg,
                    r.stage_seconds.maps, r.stage_seconds.search, r.stage_seconds.refine,
                    r.stage_seconds.yaw_interval, toString(r.compass).c_str(), o.compass_error_deg,
                    o.compass_resultant, r.overlap_m2, r.overlap_statistics.length_m,
                    r.overlap_statistics.width_m, r.overlap_statistics.field_std_uT,
                    o.field_spread_a_uT, o.field_spread_b_uT, o.calibration_residual_uT,
                    r.probability, r.T_a_b.x_m, r.T_a_b.y_m, r.T_a_b.yaw_rad * 180.0 / M_PI, stage);
                csv << line;
                csv.flush();
                std::fprintf(stderr, "%s", line);
              }
            }
          }
        }

  std::printf(
      "| preset | rig | sensors | calibration | method | overlapping pairs | success | success "
      "where the common swath is >= 15 m² | median overlap error (m / °) | median e_t (m) / e_r "
      "(°) | pairs without overlap | false overlaps | median s per match |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& [key, outcomes] : results) {
    int overlapping = 0, success = 0, disjoint = 0, false_overlaps = 0, wide = 0, wide_success = 0;
    std::vector<double> et, er, ft, fr, seconds;
    for (const Outcome& o : outcomes) {
      seconds.push_back(o.seconds);
      if (o.overlapping) {
        ++overlapping;
        success += o.aligned;
        if (o.swath_overlap_m2 >= 15.0) ++wide, wide_success += o.aligned;
        et.push_back(o.overlap_t), er.push_back(o.overlap_r);
        ft.push_back(o.frame_t), fr.push_back(o.frame_r);
      } else if (o.separate) {
        ++disjoint;
        false_overlaps += o.accepted;
      }
    }
    const auto& [preset, rig, sensors, calibration, method] = key;
    std::printf(
        "| %s | %s | %s | %s | %s | %d | %d/%d (%.0f %%) | %d/%d (%.0f %%) | %.3f / %.3f | "
        "%.3f / %.3f | %d | %d (%.0f %%) | %.2f |\n",
        preset.c_str(), rig.c_str(), sensors.c_str(), calibration.c_str(), method.c_str(),
        overlapping, success, overlapping, overlapping ? 100.0 * success / overlapping : 0.0,
        wide_success, wide, wide ? 100.0 * wide_success / wide : 0.0, median(et), median(er),
        median(ft), median(fr), disjoint, false_overlaps,
        disjoint ? 100.0 * false_overlaps / disjoint : 0.0, median(seconds));
  }
  return 0;
}
