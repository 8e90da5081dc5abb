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
//  - B_v: where some of a group's sessions observed their own vertical hard iron (a tilting
//    body's calibration estimates it: MagneticLayer::vertical_observed), their B_v is kept: the
//    group's B_v offsets are shifted so that theirs average zero. A level robot's B_v is then
//    carried by a handheld or tilting session that shares its floor. This comes before the
//    Earth's field: on the simulator's handheld sessions (tuning seeds 1-3,
//    docs/bench/field_seams_hard_iron.csv) it left 7 of 12 warehouse sessions' vertical within
//    1 uT where the Earth's field left 1 of 12, and matched it in the corridor (2 of 6 each).
//  - Else, where the sessions state the Earth's vertical field at the site (SensorRig::
//    earth_field_vertical_uT, from a geomagnetic model), the median B_v of the sessions' cells is
//    put on it. Steel makes the indoor field depart from the Earth's by several µT cell by cell,
//    but over a building those departures nearly cancel (their median is within 0.4-2.6 µT of the
//    Earth's in the simulator's warehouses, under 1 µT in its corridors:
//    docs/bench/field_seams.csv, site rows), while a level robot's unobservable vertical hard iron
//    is often 10 µT or more. A session linked to none is anchored alone.
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
  /// Per layer: its B_v put on the Earth's vertical field stated with the sessions (the anchor).
  std::vector<bool> earth_anchored;
  /// The pairs of layers that share at least min_shared_cells, with their disagreement before
  /// the offsets (after applying them, each pair's median difference is the solve's residual).
  std::vector<LayerDisagreement> pairs;
  /// How the common constant was fixed, for the report.
  std::string anchor;
  /// Per layer: its group's B_v anchored on the sessions that observed their own vertical hard
  /// iron (no Earth field stated in the group).
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
/// group of one) where a layer states the Earth's vertical field, one constant added to the
/// group's B_v offsets so that the median B_v over its layers' cells is the stated value (their
/// mean where layers state different values); in a group where none states it but some layers
/// observed their own vertical hard iron, the constant that makes those layers' B_v offsets
/// average zero. Layers with no partner and no Earth field keep zero. Empty layers are ignored.
/// Throws std::invalid_argument on an invalid config.
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
