#pragma once
// The fused magnetic map of an atlas (paper Section III-C, Eq. 12): every session's magnetometer
// readings re-placed at its optimised keyframe poses, mapped on one grid of the atlas frame, and
// cells covered by several sessions fused by inverse-variance weighting.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/self_calibration.hpp"
#include "mm4mm/merge/field_offsets.hpp"
#include "mm4mm/merge/magnetic_change.hpp"
#include "mm4mm/merge/magnetic_layer.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// The grid and the error model that gives each session's cells a variance (µT^2):
///
///   var = sensor_bias^2 + sensor_noise^2 / max(1, n) + (gradient * d)^2
///
/// with n the readings that fell inside the cell and d the distance (m) from the cell centre to
/// the nearest reading. The bias of a sensor is constant over a session, so repeated readings do
/// not average it out, but it is independent between sessions; white noise averages over the
/// readings in a cell; and a cell filled by interpolation between tracks is only as good as the
/// field is smooth over the gap, which the last term models as a linear departure with distance.
/// Every field applies to all sessions (B_h, B_v, B_F and the horizontal components alike).
struct FusedMagneticMapConfig {
  /// Cell size (m) and interpolation of each session's map; cells of all sessions share one grid
  /// aligned with multiples of the cell size in the atlas frame.
  MagneticMapConfig map;
  double sensor_noise_uT = 0.2;  ///< white noise of one reading (µT, per axis)
  double sensor_bias_uT = 0.3;   ///< per-sensor constant bias (µT, per axis), one draw per session
  /// How fast the field departs from a linear blend away from the readings (µT/m): a few µT/m
  /// indoors, tens near steel.
  double gradient_uT_per_m = 2.0;
  /// Near the floor the field changes with height (MergeConfig::max_height_difference_m, the
  /// same 0.2 m): a placed session whose magnetometers are further than this (m) from the height
  /// most sessions share read another field, and is left out of the fused map and its offsets
  /// (layersAtOneHeight). Infinite: every session fused.
  double max_height_difference_m = 0.2;
  /// One field across sessions (field_offsets.hpp): each session's offset solved from the cells
  /// it shares with others and applied to its layer before fusing.
  FieldOffsetConfig offsets;
  /// Change between sessions (magnetic_change.hpp, issue 18): every pair of fused sessions whose
  /// layers share cells compared after the offsets. Its regions are reported, not acted on.
  bool detect_changes = true;
  MagneticChangeConfig change;

  /// False, with the offending field named in `error`, when a setting is out of range.
  bool IsValid(std::string* error) const;
};

/// Two fused sessions compared for change (magnetic_change.hpp): indices into the sessions given
/// to fuseMagneticMaps, a < b; the cells both cover (m²) and the regions where the field changed.
struct LayerChange {
  int a = 0;
  int b = 0;
  double compared_m2 = 0.0;
  std::vector<MagneticChangeRegion> regions;
};

/// The fused map (values in µT, atlas frame) with, per cell, the fused variance 1 / sum(1/var_s)
/// (µT^2; NaN where uncovered) and the number of sessions that covered it (0 where uncovered).
struct FusedMagneticMap {
  MagneticMap map;
  std::vector<float> variance_uT2;
  std::vector<std::uint16_t> session_count;
  /// Where two or more sessions cover a cell, the largest difference of B_F between them (µT):
  /// the seams a user sees where one session's coverage meets the next. NaN elsewhere.
  std::vector<float> spread_total_uT;
  /// The offsets applied to the layers before fusing (fuseMagneticMaps; one per session given),
  /// with the pairs they were solved from and the anchor.
  FieldOffsets offsets;
  /// Per session given to fuseMagneticMaps: where it was left out, its magnetometers at another
  /// height than the one most sessions share (layersAtOneHeight), that height difference (m, its
  /// minus the first kept layer's); unset for the sessions fused.
  std::vector<std::optional<double>> other_height_m;
  /// Every pair of fused sessions whose layers share cells, in order of (a, b), with the regions
  /// where their field differs past what both maps' uncertainty explains (detect_changes); only
  /// the pairs with a session of `changes_of`.
  std::vector<LayerChange> changes;
  /// Their cells on the fused map's grid, regions numbered as `changes` lists them (grid set and
  /// no cell compared where no pair was).
  ChangeMap change_map;
  /// Per session given: whether its pairs were compared for change (every session, unless
  /// fuseMagneticMaps was given fewer; all false without detect_changes).
  std::vector<bool> changes_of;
  /// Per session given: left out of the change comparison because its calibration had nothing to
  /// check itself against (SessionFacts::calibration): a difference of a few µT from it says
  /// nothing about the building.
  std::vector<bool> change_unchecked;
};

/// What the merge knows of a session beyond its readings, for fuseMagneticMaps.
struct SessionFacts {
  /// Its calibration estimated the vertical hard iron (MagneticLayer::vertical_observed).
  bool vertical_observed = false;
  /// Its magnetometers' height above the floor, where known (MagneticLayer::height_above_floor_m).
  std::optional<double> height_above_floor_m;
  /// What its calibration leaves in its readings (MagneticLayer::calibration_uT and
  /// calibration_checked).
  CalibrationEvidence calibration;
  /// Its pairs are compared for change (layerChanges): an add compares only the new session's.
  bool compare_changes = true;
};

/// Every pair of `layers` whose coverage shares cells compared for change (magneticChange, a's
/// grid), in order of (a, b); where `of` is given (one flag per layer), only the pairs with a
/// flagged layer: an add compares the new session with the others, not every pair again. A layer
/// whose calibration is not checked (MagneticLayer::calibration_checked) is compared with none.
/// The layers must hold their field offsets already. Where `cells` is given, its grid (origin,
/// cell size, width, height; the fused map's, say) set and every compared layer on its lattice
/// and inside it, its per-cell values are filled from every pair compared; the same, whatever
/// order the pairs ran in. Throws std::invalid_argument when `of` is neither empty nor one flag per
/// layer, or a compared layer is not on `cells`' grid.
std::vector<LayerChange> layerChanges(const std::vector<MagneticLayer>& layers,
                                      const MagneticChangeConfig& config,
                                      const std::vector<bool>& of = {}, ChangeMap* cells = nullptr);

/// Each layer's height for the rule below (m): its height above the floor where every non-empty
/// layer knows it (MagneticLayer::height_above_floor_m), else its map's height_m (its sensors'
/// mean z in the atlas frame, which an odometry's tilt moves along a chain of sessions).
std::vector<double> layerHeights(const std::vector<MagneticLayer>& layers);

/// Which of `heights` (m; nullopt: nothing read there) share the height most of them share: the
/// reference is the given height with the most given heights within `max_difference_m` of it
/// (ties: the earliest); true for the given heights within `max_difference_m` of that, false for
/// the others and the ones not given.
std::vector<bool> atOneHeight(const std::vector<std::optional<double>>& heights,
                              double max_difference_m);

/// atOneHeight over the non-empty layers, their heights from layerHeights.
std::vector<bool> layersAtOneHeight(const std::vector<MagneticLayer>& layers,
                                    double max_difference_m);

/// The session's readings placed at its optimised keyframe poses `T_atlas_keyframe` (body to
/// atlas frame, one per keyframe; the keyframe times are kept), mapped with buildMagneticMap, and
/// each covered cell's variance from the model above. A session whose readings all fall outside
/// its keyframes' time span gives an empty layer. Throws std::invalid_argument on an invalid
/// config or a pose count that differs from the keyframe count.
MagneticLayer buildMagneticLayer(const Session& session,
                                 const std::vector<Eigen::Isometry3d>& T_atlas_keyframe,
                                 const FusedMagneticMapConfig& config);

/// Eq. 12 as a product of Gaussians per cell: the fused value of each fingerprint component is
/// sum(v_s / var_s) / sum(1 / var_s) over the layers covering the cell. The result's grid spans
/// all layers. Layers must share one cell size and have origins on one grid (buildMagneticMap
/// snaps origins to multiples of the cell size); throws std::invalid_argument otherwise, or when
/// a layer's vectors do not match its size. Empty layers are ignored; no layers give an empty map.
FusedMagneticMap fuseMagneticLayers(const std::vector<MagneticLayer>& layers);

/// buildMagneticLayer for every session (in parallel), the layers at another height than most
/// left out (layersAtOneHeight with config.max_height_difference_m; said in `other_height_m`), the
/// field offsets estimated from the others and applied to them (unless config.offsets.enabled is
/// false), then fuseMagneticLayers. Pass only
/// the sessions that belong in the atlas; `facts` (empty: SessionFacts{} for each, or one per
/// session) what the merge knows of each. Throws std::invalid_argument (see checkAtlasPoses in
/// merge/atlas_poses.hpp) on inconsistent input or an invalid config.
FusedMagneticMap fuseMagneticMaps(
    const std::vector<Session>& sessions,
    const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
    const FusedMagneticMapConfig& config = {}, const std::vector<SessionFacts>& facts = {});

}  // namespace mm4mm
