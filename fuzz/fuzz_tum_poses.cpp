// poses.txt, trajectories/<id>.txt and ground_truth.txt: TUM text.
#include "fuzz_input.hpp"
#include "mm4mm/io/tum_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = mm4mm::fuzz::scratchDirectory() / "poses.txt";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readTumPoses(file); });
  return 0;
}
