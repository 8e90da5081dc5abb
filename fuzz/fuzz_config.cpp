// Config YAML: the same text read as a pipeline config and as a simulation preset.
#include "fuzz_input.hpp"
#include "mm4mm/io/config_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = mm4mm::fuzz::scratchDirectory() / "config.yaml";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::loadPipelineConfig(file); });
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::loadSimulationConfig(file); });
  return 0;
}
