// mm4mm config: the settings merge and add run with, as YAML.

#include <cstdio>
#include <memory>
#include <string>

#include "commands.hpp"
#include "mm4mm/io/config_io.hpp"

namespace mm4mm::cli {
namespace {

struct ConfigOptions {
  std::string config;  // empty: the defaults
  bool dump = false;
};

void runConfig(const ConfigOptions& options) {
  const PipelineConfig config =
      options.config.empty() ? PipelineConfig{} : loadPipelineConfig(options.config);
  if (options.dump)
    std::fputs(pipelineConfigYaml(config).c_str(), stdout);
  else
    std::printf("%s: valid\n", options.config.empty() ? "the defaults" : options.config.c_str());
}

}  // namespace

void addConfigCommand(CLI::App& app) {
  auto options = std::make_shared<ConfigOptions>();
  CLI::App* command = app.add_subcommand(
      "config", "Check a config file, or print every setting of merge and add as YAML (--dump)");
  command
      ->add_option("--config", options->config,
                   "config YAML (configs/mm4mm.yaml); without it, the defaults")
      ->check(CLI::ExistingFile);
  command->add_flag("--dump", options->dump,
                    "print the effective config, every key, in the format --config reads");
  command->callback([options] { runConfig(*options); });
}

}  // namespace mm4mm::cli
