// graph.g2o: the same text read as one session's graph and as an atlas's inter-session edges.
#include "fuzz_input.hpp"
#include "mm4mm/io/g2o_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = mm4mm::fuzz::scratchDirectory() / "graph.g2o";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readSessionGraphG2o(file); });
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readInterSessionEdgesG2o(file); });
  return 0;
}
