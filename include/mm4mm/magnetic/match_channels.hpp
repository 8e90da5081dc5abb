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
};

/// Values of map `b`'s cell `index` in the channels, expressed in map a's frame when b is
/// rotated by `yaw_rad` into it. Returns the channel count (2 or 3).
int channelValues(const MagneticMap& map, std::size_t index, MatchChannels channels,
                  double yaw_rad, double* values);

}  // namespace mm4mm
