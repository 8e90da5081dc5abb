// report.json: the session pairs an atlas keeps for the next `add` (ids, verdicts, scores,
// transforms, ICP-EM and geometric verification).
#include "fuzz_input.hpp"
#include "mm4mm/io/atlas_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = mm4mm::fuzz::scratchDirectory() / "report.json";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readAtlasReportPairs(file, {"s0", "s1", "s2"}); });
  return 0;
}
