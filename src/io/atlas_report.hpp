#pragma once
// Internal to src/io: report.json and timings.json of an atlas (docs/design.md "Atlas
// directory"). writeAtlas writes them; readAtlasReportPairs (atlas_io.hpp) reads the pairs back.

#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "mm4mm/atlas/atlas_outputs.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm::io_detail {

/// report.json: everything but wall-clock times, so that the same inputs and seed give it byte
/// for byte, whatever the thread count or the machine's load.
/// The evaluation and the fused map's field offsets come from `outputs`.
nlohmann::json reportJson(const std::vector<Session>& sessions, const MergeResult& result,
                          const AtlasOutputs& outputs);

/// timings.json: the wall-clock seconds of every stage and of every pair.
nlohmann::json timingsJson(const std::vector<Session>& sessions, const MergeResult& result,
                           const AtlasOutputs& timings);

}  // namespace mm4mm::io_detail
