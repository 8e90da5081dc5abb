#pragma once
// One field across sessions (issue 32): each session is calibrated on its own, and what a session
// cannot observe alone stays wrong (on a level robot the vertical hard iron is held at 0, the
// horizontal known to about a µT). Where two placed sessions cover the same cells of the atlas
// they should read the same field; the constant by which they differ is the difference of their
// offsets. This stage estimates one offset per session on B_h and B_v from every pair's shared
// cells and applies it to the session's layer before the layers are fused, so the fused map has
// no seams where one session's coverage meets the next.
//
// The shared cells fix only differences; the common constant is the anchor, stated in the
// result, never whichever session came first:
//  - B_v: what knows it absolutely, combined by the inverse of each one's variance: the sessions
//    that observed their own vertical hard iron (a tilting body's calibration estimates it:
//    MagneticLayer::vertical_observed), each wanting its own B_v kept, and the Earth's vertical
//    field stated at the site (SensorRig::earth_field_vertical_uT, from a geomagnetic model),
//    wanting the group's median B_v on it. One observing session's vertical is off by 2.65 uT
//    (RMS), a building's median B_v off the Earth's by 1.43 uT (steel; RMS), on the tuning
//    worlds (scripts/choose_anchor_sigmas.py): a lone handheld session among level robots moves
//    the Earth's anchor a little, four of them as much as the Earth. A level robot's unobservable
//    vertical hard iron, often 10 uT or more, is then carried by what it shares its floor with. A
//    session linked to none is anchored alone on the Earth's field where it is stated.
//  - Otherwise, and always for B_h (which each calibration already scales to the Earth's
//    horizontal field where it is stated), the offsets of the sessions linked by shared cells sum
//    to zero: their mean calibration is kept.

#include <string>
#include <vector>

#include "mm4mm/merge/magnetic_layer.hpp"

namespace mm4mm {

struct FieldOffsetConfig {
  bool enabled = true;
  /// Two sessions' layers are compared where they share at least this many cells (400 cells of
  /// 5 cm: 1 m², a few metres of one track crossing another's swath): fewer would let a few
  /// cells of interpolation error set an offset.
  int min_shared_cells = 400;
  /// The anchor's weights (sigmas in uT; .inf leaves a reference out): one session's own
  /// vertical estimate where its body tilted, and a building's median B_v about the Earth's
  /// stated vertical field. Chosen by scripts/choose_anchor_sigmas.py on the tuning worlds.
  double observed_vertical_sigma_uT = 2.65;
  double earth_vertical_sigma_uT = 1.43;

  /// False, with the offending field named in `error`, when a setting is out of range.
  bool IsValid(std::string* error) const;
};

/// A session's offset: added to its B_h and B_v (µT), B_F following from them.
struct FieldOffset {
  double horizontal_uT = 0.0;
  double vertical_uT = 0.0;
};

/// The shared cells of one pair of layers: how many, and the median of a − b per channel.
struct LayerDisagreement {
  int a = 0, b = 0;
  int cells = 0;
  double horizontal_uT = 0.0;
  double vertical_uT = 0.0;
  double total_uT = 0.0;
};

struct FieldOffsets {
  std::vector<FieldOffset> offsets;  ///< one per layer; zero where `linked` is false
  /// Per layer: shares at least min_shared_cells with another layer, so its offset was solved.
  std::vector<bool> linked;
  /// Per layer: the Earth's vertical field stated with the sessions took part in its B_v anchor.
  std::vector<bool> earth_anchored;
  /// The pairs of layers that share at least min_shared_cells, with their disagreement before
  /// the offsets (after applying them, each pair's median difference is the solve's residual).
  std::vector<LayerDisagreement> pairs;
  /// How the common constant was fixed, for the report.
  std::string anchor;
  /// Per layer: the sessions of its group that observed their own vertical hard iron took part
  /// in its B_v anchor.
  std::vector<bool> observed_anchored;
};

/// One cell both layers cover: a − b per channel (µT).
struct CellDifference {
  double horizontal_uT = 0.0;
  double vertical_uT = 0.0;
  double total_uT = 0.0;
};

/// a − b at every cell layers `a` and `b` both cover (their grids share one lattice, as
/// buildMagneticLayer makes them; empty where either layer is). Throws std::invalid_argument when
/// the grids are not on one lattice.
std::vector<CellDifference> sharedCellDifferences(const MagneticLayer& a, const MagneticLayer& b);

/// The shared cells of layers `a` and `b`: how many and the median differences a − b. Same
/// errors as sharedCellDifferences.
LayerDisagreement layerDisagreement(const MagneticLayer& a, const MagneticLayer& b);

/// Offsets o_s that make every linked pair agree, o_s − o_t = −median(a − b), in the least-squares
/// sense with each pair weighted by the square root of its shared cells, and with the offsets of
/// each group of linked layers summing to zero; then, in each group (a layer with no partner is a
/// group of one), one constant c added to its B_v offsets: the weighted mean, with weights
/// 1/sigma², of −o_s for every layer that observed its own vertical (keeping its B_v) and of the
/// shift that puts the median B_v over the group's cells on the Earth's vertical field stated
/// (the mean of the values where layers state different ones). A group with neither keeps its
/// offsets summing to zero; a layer alone with no Earth field keeps zero. Empty layers are
/// ignored. Throws std::invalid_argument on an invalid config.
FieldOffsets estimateFieldOffsets(const std::vector<MagneticLayer>& layers,
                                  const FieldOffsetConfig& config);

/// `layer` with `offset` added to every covered cell's B_h and B_v, and B_F changed by what that
/// does to |(B_h, B_v)|; the session-frame horizontal components are left as they are (a constant
/// on B_h has no one direction in the session frame).
MagneticLayer withFieldOffset(MagneticLayer layer, const FieldOffset& offset);

/// estimateFieldOffsets on `layers`, then withFieldOffset on each linked or anchored one, in place:
/// what the fused map does to its layers before fusing them.
FieldOffsets applyFieldOffsets(std::vector<MagneticLayer>& layers, const FieldOffsetConfig& config);

}  // namespace mm4mm
