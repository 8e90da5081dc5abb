#pragma once
// Which field components two magnetic maps are compared on.

#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/planar_transform.hpp"

namespace mm4mm {

enum class MatchChannels {
  /// Levelled horizontal magnitude and vertical component (B_h, B_v): independent of heading.
  kLevelled,
  /// Session-frame (B_x, B_y) rotated by the candidate yaw, and B_v: uses the heading, so only
  /// where the relative heading of the two sessions' magnetometers is trusted.
  kRotatedVector,
  /// Vertical component and total intensity (B_v, B_F): for rigs with an uncalibrated offset in
  /// the body frame, which turns B_h with the heading while B_v and B_F stay put.
  kVerticalTotal,
  /// The vertical component alone: a level body's hard iron shifts it by a constant and its soft
  /// iron turns a few per cent of the horizontal field into it, so it hardly depends on heading
  /// before any calibration.
  kVertical,
};

/// How many values `channels` gives per cell.
int channelCount(MatchChannels channels);

/// How two maps' values over an overlap are compared.
enum class CorrelationStatistic {
  /// Pearson's r: invariant to an offset and a scale between the maps.
  kPearson,
  /// Lin's concordance correlation: like r, but an offset or a scale between the maps lowers it.
  /// The same field measured twice agrees in value, not only in shape.
  kConcordance,
};

/// The statistic from sums over `n` pairs: cov = Σ(a−ā)·(b−b̄), var_a = Σ(a−ā)², var_b likewise,
/// summed over channels, and `mean_difference_squared` = Σ over channels of (ā − b̄)².
double correlationOf(CorrelationStatistic statistic, double cov, double var_a, double var_b,
                     double mean_difference_squared, double n);

/// Values of map `b`'s cell `index` in the channels, expressed in map a's frame when b is
/// rotated by `yaw_rad` into it. Returns the channel count (1 to 3).
int channelValues(const MagneticMap& map, std::size_t index, MatchChannels channels, double yaw_rad,
                  double* values);

}  // namespace mm4mm
