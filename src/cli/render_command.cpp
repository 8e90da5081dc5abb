// mm4mm render: top-down pictures of a session (and, later, of an atlas).

#include <spdlog/spdlog.h>

#include <filesystem>
#include <memory>

#include "commands.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/render/session_render.hpp"

namespace mm4mm::cli {
namespace {

struct RenderOptions {
  std::string input;
  std::string out;
  double pixels_per_metre = 10.0;
};

void runRender(const RenderOptions& options) {
  const std::filesystem::path input(options.input);
  if (!std::filesystem::exists(input / "session.yaml"))
    throw InputError(options.input, 0, "not a session directory (no session.yaml)");
  SessionRenderOptions render;
  render.pixels_per_metre = options.pixels_per_metre;
  std::string problem;
  if (!render.IsValid(&problem)) throw std::invalid_argument("render options: " + problem);
  const Session session = readSession(input);
  renderSessionPng(session, render, options.out);
  spdlog::info("wrote {}", options.out);
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  auto options = std::make_shared<RenderOptions>();
  CLI::App* command =
      app.add_subcommand("render", "Draw a session: point cloud, trajectory, magnetic samples");
  command->add_option("input", options->input, "session directory")->required();
  command->add_option("--out", options->out, "PNG file to write")->required();
  command->add_option("--pixels-per-metre", options->pixels_per_metre, "picture scale");
  command->callback([options] { runRender(*options); });
}

}  // namespace mm4mm::cli
