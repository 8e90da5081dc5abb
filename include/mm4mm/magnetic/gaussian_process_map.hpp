#pragma once
// Magnetic map of a single magnetometer's track by Gaussian-process regression. A lone sensor
// sweeps a line, and two sessions' lines only cross: painted footprints leave a few m² in
// common, too little to match. The GP fills the space between neighbouring passes where the
// samples constrain it and leaves the rest uncovered, so the common area grows with the
// coverage, not with the crossings.

#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"

namespace mm4mm {

/// Posterior mean of every channel (B_h, B_v, B_F, session-frame B_x, B_y) on a grid of
/// `cell_size_m`, each channel an independent GP with the same kernel. Cells whose posterior
/// std exceeds `config.max_std_ratio` of the prior's, or that lie farther than two length
/// scales from every sample, hold NaN. Samples of every sensor are used as one track.
MagneticMap buildGaussianProcessMap(const std::vector<PlacedFingerprint>& samples,
                                    double cell_size_m, const GaussianProcessMapConfig& config);

}  // namespace mm4mm
