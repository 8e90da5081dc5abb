#pragma once
// Every setting `mm4mm merge` and `mm4mm add` run with, in one value: what a config file holds
// (configs/mm4mm.yaml, io/config_io.hpp), what `mm4mm config --dump` prints and what an atlas
// stores (config.yaml), so that a later `add` runs as the `merge` that built the atlas did.
// The calibration step's settings are `merge.matcher.calibration`; `match` and `map` use
// `merge.matcher`.

#include <string>

#include "mm4mm/atlas/atlas_outputs.hpp"
#include "mm4mm/merge/merge_sessions.hpp"

namespace mm4mm {

struct PipelineConfig {
  MergeConfig merge;
  AtlasOutputConfig outputs;

  /// False, with the offending key's dotted path (e.g. `merge.matcher.pso.particles`) first in
  /// `error`.
  bool IsValid(std::string* error) const;
};

}  // namespace mm4mm
