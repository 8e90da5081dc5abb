// Seams in the fused magnetic map (issue 32): over seeds of the simulator's presets, simulate the
// sessions with realistic sensors, calibrate each on its own (as `merge` does), merge them, and
// place every session's own magnetic layer with the solved poses (buildMagneticLayer, the layers
// the fused map is made of, with the field offsets applied as the atlas applies them). Where two
// sessions cover the same 5 cm cell of the atlas they should read the same field; the median
// difference of B_F, B_v and B_h over their shared cells is the seam a user sees. The fused map is
// also compared with the simulator's true field at each covered cell (the sensor height of the map,
// the world position through the nearest placed keyframe), and each session's estimated hard iron
// with the true one (body z: vertical on a level robot, which a session alone cannot observe).
//
// Usage: field_seams_bench [--seeds N] [--first-seed S] [--presets a,b,...] [--rigs a,b,...]
//                          [--label L] [--csv FILE] [--earth-vertical stated|none]
//                          [--anchors combined,earth,observed] [--placement-csv FILE]
// Presets: warehouse (configs/warehouse.yaml, 4 sessions), corridor (configs/corridor.yaml, 3),
// procedural (4). Rigs: imu, husky3, array7, handheld (default: imu,array7), or a mix "A+B": the
// first session carried by rig A, the others by B, each simulated as the whole set would be on its
// rig (one world; the sessions of B's set but the first, A's first). The simulated sessions state
// the Earth's vertical field (as a user gives it from a geomagnetic model), which anchors the fused
// map's B_v with the sessions that observed their own vertical; --earth-vertical none drops it
// (the offsets sum to zero where no session observed its vertical). --anchors lists the anchors
// to measure on each merge: combined (the default) is the atlas's rule, its rows labelled L;
// earth or observed leaves the other reference out (its sigma infinite), rows labelled
// L:earth, L:observed. CSV rows (appended, with a header when the file is new; the first column is
// --label, the code the run measured), one kind per row:
//   pair:    shared cells and the median signed and absolute differences a - b (µT);
//   fused:   covered cells and the median absolute error against the true field (µT);
//   site:    the true field at those cells against the Earth's main field alone (true − Earth);
//   session: its first sensor's true and estimated hard iron along body z (µT).
// --hard-iron-csv FILE (appended, header when new): per session, its first sensor's vertical bias,
// what a level body cannot observe: the reading's error along z in the Earth's vertical field
// (hard iron z plus the vertical gain's error times that field: distort((0, 0, B_v)) - B_v), the
// true one and the calibration's, the B_v offset the fused map applied, and what is left in the
// atlas's B_v (true - calibrated + offset: 0 when the offset undid what the calibration could
// not see); whether the session observed its vertical (a tilting body), how its B_v was anchored;
// then the same at the session's typical forward speed (the median of its readings'), where the
// drive current's field adds to the error along z: the speed, the true and calibrated errors there,
// and what is left (a calibration that could not tell the current from the hard iron at a
// constant speed holds both in its hard iron, and the map's B_v is read at that speed).
// --placement-csv FILE (appended, header when new): per merge, which sessions the atlas placed:
// how many, the session whose frame it took, how many the first session's group of the spanning
// tree held (what the atlas placed before it took the largest group's frame), the placed pairs
// that overlap by the ground truth and how many of them are aligned (overlap error below 0.5 m,
// 2 deg), and the largest frame error (the paper's e_t, e_r) against the frame session.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "bench_util.hpp"
#include "mm4mm/atlas/atlas_outputs.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/self_calibration.hpp"
#include "mm4mm/merge/field_offsets.hpp"
#include "mm4mm/merge/fused_magnetic_map.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/merge/pair_refinement.hpp"
#include "mm4mm/sim/magnetic_field.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "sim_presets.hpp"

namespace {

using namespace mm4mm;
using bench::median;
using bench::parseFlags;
using bench::Preset;
using bench::presetFor;
using bench::splitList;
namespace fs = std::filesystem;

// The three heading-free channels of a map cell.
struct Channels {
  double total = 0, vertical = 0, horizontal = 0;
};

Channels channelsAt(const MagneticMap& map, std::size_t i) {
  return {map.total_uT[i], map.vertical_uT[i], map.horizontal_uT[i]};
}

struct Medians {
  std::size_t cells = 0;
  Channels signed_, absolute;
};

Medians mediansOf(const std::vector<Channels>& differences) {
  Medians m;
  m.cells = differences.size();
  std::vector<double> t, v, h;
  for (const Channels& d : differences) {
    t.push_back(d.total);
    v.push_back(d.vertical);
    h.push_back(d.horizontal);
  }
  m.signed_ = {median(t), median(v), median(h)};
  for (auto* values : {&t, &v, &h})
    for (double& x : *values) x = std::abs(x);
  m.absolute = {median(t), median(v), median(h)};
  return m;
}

// The median forward speed of a session's first magnetometer's readings: the speed at which a
// typical map cell was read.
double typicalSpeed(const Session& session) {
  std::vector<double> speeds;
  for (const PlacedReading& r : placeReadings(session))
    if (r.sensor == 0) speeds.push_back(r.speed_mps);
  return speeds.empty() ? 0.0 : median(speeds);
}

// Differences a - b at the cells both layers cover, as the field offsets see them.
Medians sharedCellMedians(const MagneticLayer& a, const MagneticLayer& b) {
  std::vector<Channels> differences;
  for (const CellDifference& d : sharedCellDifferences(a, b))
    differences.push_back({d.total_uT, d.vertical_uT, d.horizontal_uT});
  return mediansOf(differences);
}

// The fused map against the true field: each covered cell taken to the world through the nearest
// placed keyframe of any placed session (its solved pose and its true one), at the map's height.
// `site` gets the true field there against the Earth's main field alone (true − Earth): how far
// the building's steel takes the field's median from what a geomagnetic model gives for the site,
// the limit of an anchor that fixes the fused map's level by the Earth's field.
Medians fusedError(const MagneticMap& fused, const std::vector<Session>& sessions,
                   const MultiSessionSolution& solution, const sim::MagneticFieldModel& field,
                   Medians* site) {
  struct Anchor {
    Eigen::Isometry3d T_world_atlas;
    Eigen::Vector2d position;
  };
  std::vector<Anchor> anchors;
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    if (!solution.connected[s]) continue;
    for (std::size_t k = 0; k < sessions[s].keyframes.size(); ++k) {
      const Eigen::Isometry3d& T_atlas_body = solution.T_atlas_keyframe[s][k];
      anchors.push_back({(*sessions[s].ground_truth)[k].T_frame_body * T_atlas_body.inverse(),
                         T_atlas_body.translation().head<2>()});
    }
  }
  const Eigen::Vector3d earth = field.earthField();
  std::vector<Channels> errors, steel;
  for (int iy = 0; iy < fused.height; iy += 2)  // every other cell: 2.5 cm apart is plenty
    for (int ix = 0; ix < fused.width; ix += 2) {
      if (!fused.covered(ix, iy)) continue;
      const Eigen::Vector2d c = fused.cellCentre(ix, iy);
      const Anchor* nearest = nullptr;
      double best = std::numeric_limits<double>::infinity();
      for (const Anchor& a : anchors)
        if (const double d = (a.position - c).squaredNorm(); d < best) {
          best = d;
          nearest = &a;
        }
      const Eigen::Vector3d truth =
          field.fieldAt(nearest->T_world_atlas * Eigen::Vector3d(c.x(), c.y(), fused.height_m));
      const Channels v = channelsAt(fused, fused.index(ix, iy));
      errors.push_back(
          {v.total - truth.norm(), v.vertical - truth.z(), v.horizontal - truth.head<2>().norm()});
      steel.push_back({truth.norm() - earth.norm(), truth.z() - earth.z(),
                       truth.head<2>().norm() - earth.head<2>().norm()});
    }
  *site = mediansOf(steel);
  return mediansOf(errors);
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 3, first_seed = 1;
  std::vector<std::string> presets{"warehouse", "corridor"}, rigs{"imu", "array7"};
  std::string csv_path = "field_seams.csv", label = "current", hard_iron_path, placement_path;
  bool earth_vertical = true;
  std::vector<std::string> anchor_modes{"combined"};
  for (const auto& [flag, value] :
       parseFlags(argc, argv,
                  {"--seeds", "--first-seed", "--presets", "--rigs", "--label", "--csv",
                   "--earth-vertical", "--hard-iron-csv", "--anchors", "--placement-csv"},
                  "field_seams_bench [--seeds N] [--first-seed S] [--presets a,b,...] "
                  "[--rigs a,b,...] [--label L] [--csv FILE] [--earth-vertical stated|none] "
                  "[--hard-iron-csv FILE] [--anchors combined,earth,observed] "
                  "[--placement-csv FILE]")) {
    if (flag == "--anchors") {
      anchor_modes = splitList(value);
      for (const std::string& mode : anchor_modes)
        if (mode != "combined" && mode != "earth" && mode != "observed") {
          std::fprintf(stderr,
                       "field_seams_bench: --anchors lists combined, earth or observed, not %s\n",
                       mode.c_str());
          return 2;
        }
    }
    if (flag == "--earth-vertical") {
      if (value != "stated" && value != "none") {
        std::fprintf(stderr, "field_seams_bench: --earth-vertical is stated or none, not %s\n",
                     value.c_str());
        return 2;
      }
      earth_vertical = value == "stated";
    }
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--presets") presets = splitList(value);
    if (flag == "--rigs") rigs = splitList(value);
    if (flag == "--label") label = value;
    if (flag == "--csv") csv_path = value;
    if (flag == "--hard-iron-csv") hard_iron_path = value;
    if (flag == "--placement-csv") placement_path = value;
  }
  // Each CSV is appended to, its header written when the file is new; an empty path: none.
  bool cannot_open = false;
  const auto open = [&](const std::string& path, const char* header) -> std::FILE* {
    if (path.empty()) return nullptr;
    const bool new_file = !fs::exists(path);
    std::FILE* file = std::fopen(path.c_str(), "a");
    if (!file) {
      std::fprintf(stderr, "field_seams_bench: cannot open %s\n", path.c_str());
      cannot_open = true;
    } else if (new_file) {
      std::fprintf(file, "%s\n", header);
    }
    return file;
  };
  std::FILE* placement =
      open(placement_path,
           "label,preset,rig,seed,sessions,placed,frame,first_session_group,true_pairs,"
           "aligned_pairs,largest_e_t_m,largest_e_r_deg");
  std::FILE* hard_iron =
      open(hard_iron_path,
           "label,preset,rig,seed,session,placed,vertical_observed,anchor,"
           "true_vertical_bias_uT,calibrated_vertical_bias_uT,offset_vertical_uT,"
           "residual_after_offset_uT,speed_mps,true_vertical_error_uT,"
           "calibrated_vertical_error_uT,residual_at_speed_uT");
  std::FILE* csv = open(csv_path,
                        "label,preset,rig,seed,row,a,b,cells,d_total_uT,d_vertical_uT,"
                        "d_horizontal_uT,abs_total_uT,abs_vertical_uT,abs_horizontal_uT,"
                        "true_hard_iron_z_uT,estimated_hard_iron_z_uT");
  if (cannot_open || !csv) return 1;
  for (const std::string& preset_name : presets)
    for (const std::string& rig : rigs)
      for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
        // "A+B": the first session from rig A's set, the others from B's.
        const std::size_t plus = rig.find('+');
        const auto simulate = [&](const std::string& rig_name) {
          Preset p = presetFor(preset_name);
          sim::applyRigPreset(rig_name, &p.config);
          p.config.magnetometer_errors.model = "realistic";
          return std::make_pair(p, sim::simulateSessions(p.config, p.sessions, seed));
        };
        auto simulated = simulate(plus == std::string::npos ? rig : rig.substr(plus + 1));
        const Preset preset = simulated.first;
        std::vector<Session> sessions = std::move(simulated.second);
        if (plus != std::string::npos)
          sessions.front() = std::move(simulate(rig.substr(0, plus)).second.front());
        const Eigen::Vector3d earth_field_z(
            0.0, 0.0,
            preset.config.earth.magnitude_uT * sim::earthFieldDirection(preset.config.earth).z());
        if (!earth_vertical)
          for (Session& s : sessions) s.rig.earth_field_vertical_uT.reset();
        const sim::SimulatedWorld world(preset.config, seed);
        const MergeConfig config;
        std::vector<Session*> pointers;
        for (Session& s : sessions) pointers.push_back(&s);
        const std::vector<SessionCalibration> calibrations =
            calibrateSessions(pointers, config.matcher.calibration);
        const MergeResult result = mergeSessions(sessions, config);
        const MultiSessionSolution& solution = result.solution;
        if (placement) {
          std::vector<const Session*> session_pointers;
          for (const Session& s : sessions) session_pointers.push_back(&s);
          const AtlasEvaluation evaluation =
              evaluateAtlas(session_pointers, solution.T_atlas_keyframe, solution.connected,
                            result.frame_session);
          int aligned = 0;
          for (const auto& pair : evaluation.pairs) aligned += pair.overlap.aligned() ? 1 : 0;
          double e_t = 0.0, e_r = 0.0;
          for (const auto& frame : evaluation.frames) {
            e_t = std::max(e_t, frame.error.translation_m);
            e_r = std::max(e_r, frame.error.rotation_deg);
          }
          std::fprintf(placement, "%s,%s,%s,%d,%zu,%d,%s,%zu,%zu,%d,%.3f,%.3f\n", label.c_str(),
                       preset_name.c_str(), rig.c_str(), seed, sessions.size(),
                       static_cast<int>(
                           std::count(solution.connected.begin(), solution.connected.end(), true)),
                       sessions[result.frame_session].id.c_str(),
                       treeComponent(0, result.pairs).size(), evaluation.pairs.size(), aligned, e_t,
                       e_r);
          std::fflush(placement);
        }

        // The layers as the atlas's fused map takes them, before their offsets; as
        // buildAtlasOutputs, a session whose every sensor's vertical was estimated anchors B_v.
        // Each anchor below applies its offsets to a copy.
        const FusedMagneticMapConfig atlas_config = AtlasOutputConfig{}.magnetic;
        std::vector<MagneticLayer> placed_layers(sessions.size());
        std::vector<double> speeds(sessions.size());
        for (std::size_t s = 0; s < sessions.size(); ++s) {
          if (solution.connected[s])
            placed_layers[s] =
                buildMagneticLayer(sessions[s], solution.T_atlas_keyframe[s], atlas_config);
          placed_layers[s].vertical_observed = calibrations[s].verticalObserved();
          if (s < result.magnetometer_heights_m.size())
            placed_layers[s].height_above_floor_m = result.magnetometer_heights_m[s];
          speeds[s] = typicalSpeed(sessions[s]);
        }
        // As the atlas does: a layer at another height than most is left out (another field).
        const std::vector<bool> at_one_height =
            layersAtOneHeight(placed_layers, atlas_config.max_height_difference_m);
        for (std::size_t s = 0; s < sessions.size(); ++s)
          if (!at_one_height[s]) {
            // Emptied, but still a session that observed its vertical in the rows below.
            const bool observed = placed_layers[s].vertical_observed;
            placed_layers[s] = MagneticLayer{};
            placed_layers[s].vertical_observed = observed;
          }

        for (const std::string& anchor_mode : anchor_modes) {
          // Rows of the atlas's rule carry the label, the others "label:earth" or ":observed".
          const std::string row_label =
              anchor_mode == "combined" ? label : label + ":" + anchor_mode;
          FieldOffsetConfig anchor_config = atlas_config.offsets;
          if (anchor_mode == "earth")
            anchor_config.observed_vertical_sigma_uT = std::numeric_limits<double>::infinity();
          if (anchor_mode == "observed")
            anchor_config.earth_vertical_sigma_uT = std::numeric_limits<double>::infinity();
          std::vector<MagneticLayer> layers = placed_layers;
          const FieldOffsets offsets = applyFieldOffsets(layers, anchor_config);
          for (std::size_t s = 0; hard_iron && s < sessions.size(); ++s) {
            // A sensor's error along z in the Earth's vertical field: what a level body cannot see.
            // At rest (the hard iron and gains), and at the session's typical speed: the drive
            // current's field is in every reading taken while moving, and at a constant speed a
            // calibration cannot tell it from the hard iron, so the map's B_v carries the sum.
            const auto bias = [&](const MagnetometerCalibration& c, double speed) {
              return (c.distort(earth_field_z, speed) - earth_field_z).z();
            };
            const double speed = speeds[s];
            const auto& stated = sessions[s].rig.calibrations;
            const bool has = !stated.empty() && stated.front().has_value();
            const double nan = std::numeric_limits<double>::quiet_NaN();
            const double calibrated = has ? bias(*stated.front(), 0.0) : nan;
            const double calibrated_moving = has ? bias(*stated.front(), speed) : nan;
            const double truth = bias(sessions[s].true_calibration->front(), 0.0);
            const double truth_moving = bias(sessions[s].true_calibration->front(), speed);
            const double offset_v = offsets.offsets[s].vertical_uT;
            const char* anchor = offsets.earth_anchored[s] && offsets.observed_anchored[s]
                                     ? "combined"
                                 : offsets.earth_anchored[s]    ? "earth"
                                 : offsets.observed_anchored[s] ? "observed"
                                 : offsets.linked[s]            ? "sum0"
                                                                : "none";
            std::fprintf(hard_iron,
                         "%s,%s,%s,%d,%s,%d,%d,%s,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f\n",
                         row_label.c_str(), preset_name.c_str(), rig.c_str(), seed,
                         sessions[s].id.c_str(), static_cast<int>(solution.connected[s]),
                         static_cast<int>(layers[s].vertical_observed), anchor, truth, calibrated,
                         offset_v, truth - calibrated + offset_v, speed, truth_moving,
                         calibrated_moving, truth_moving - calibrated_moving + offset_v);
          }
          if (hard_iron) std::fflush(hard_iron);
          const auto row = [&](const char* kind, const std::string& a, const std::string& b,
                               const Medians& m) {
            std::fprintf(csv, "%s,%s,%s,%d,%s,%s,%s,%zu,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,,\n",
                         row_label.c_str(), preset_name.c_str(), rig.c_str(), seed, kind, a.c_str(),
                         b.c_str(), m.cells, m.signed_.total, m.signed_.vertical,
                         m.signed_.horizontal, m.absolute.total, m.absolute.vertical,
                         m.absolute.horizontal);
          };
          for (std::size_t a = 0; a < sessions.size(); ++a)
            for (std::size_t b = a + 1; b < sessions.size(); ++b) {
              if (!solution.connected[a] || !solution.connected[b]) continue;
              const Medians m = sharedCellMedians(layers[a], layers[b]);
              if (m.cells > 0) row("pair", sessions[a].id, sessions[b].id, m);
            }
          const FusedMagneticMap fused = fuseMagneticLayers(layers);
          Medians site;
          row("fused", "", "", fusedError(fused.map, sessions, solution, world.field, &site));
          row("site", "", "", site);
          for (const Session& s : sessions) {
            const auto& estimated = s.rig.calibrations;
            const double estimated_z = !estimated.empty() && estimated.front()
                                           ? estimated.front()->hard_iron_uT.z()
                                           : std::numeric_limits<double>::quiet_NaN();
            std::fprintf(csv, "%s,%s,%s,%d,session,%s,,,,,,,,,%.3f,%.3f\n", row_label.c_str(),
                         preset_name.c_str(), rig.c_str(), seed, s.id.c_str(),
                         s.true_calibration->front().hard_iron_uT.z(), estimated_z);
          }
          std::fflush(csv);
        }
        std::fprintf(stderr, "%s %s seed %d: %d of %zu sessions placed\n", preset_name.c_str(),
                     rig.c_str(), seed,
                     static_cast<int>(
                         std::count(solution.connected.begin(), solution.connected.end(), true)),
                     sessions.size());
      }
  std::fclose(csv);
  if (hard_iron) std::fclose(hard_iron);
  if (placement) std::fclose(placement);
  return 0;
}
