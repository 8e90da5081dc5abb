#include "mm4mm/atlas/pipeline_config.hpp"

namespace mm4mm {

bool PipelineConfig::IsValid(std::string* error) const {
  std::string inner;
  const auto within = [&](const char* key, bool valid) {
    if (!valid && error) *error = std::string(key) + "." + inner;
    return valid;
  };
  return within("merge", merge.IsValid(&inner)) && within("outputs", outputs.IsValid(&inner));
}

}  // namespace mm4mm
