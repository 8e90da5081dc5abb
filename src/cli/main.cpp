// mm4mm command line: wires the subcommands and turns errors into one message and an exit code.

#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <csignal>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>

#include "commands.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/input_error.hpp"

int main(int argc, char** argv) {
  using namespace mm4mm::cli;
  spdlog::set_pattern("[%H:%M:%S] %v");
  // Past a file size limit (ulimit -f) the kernel's default is to kill the process, silently and
  // with its scratch left behind; ignored, the write fails (EFBIG) and the writer's own error
  // path reports the file and leaves the previous atlas as it was.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"mm4mm: merges the maps of many robot mapping sessions using the magnetic field"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "mm4mm 0.1.0");
  // Results never depend on it (CliEndToEnd.TheSameInputsGiveTheSameAtlasWithAnyThreadCount); it
  // bounds the cores a run takes.
  std::unique_ptr<tbb::global_control> thread_limit;
  app.add_option_function<int>(
         "--threads",
         [&thread_limit](int threads) {
           thread_limit = std::make_unique<tbb::global_control>(
               tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
         },
         "worker threads (default: one per core); the results are the same with any number")
      ->check(CLI::Range(1, 4096));
  app.fallthrough();  // `mm4mm merge ... --threads 2` as well as `mm4mm --threads 2 merge ...`
  addSimulateCommand(app);
  addRenderCommand(app);
  addMapCommand(app);
  addMatchCommand(app);
  addMergeCommand(app);
  addAddCommand(app);
  addEvalCommand(app);
  addConfigCommand(app);
  addImportCommand(app);
  addExportCommand(app);
  addChangesCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a command's own non-zero outcome, already reported
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kBadInput;
  } catch (const mm4mm::AtlasBusy& e) {
    std::fprintf(stderr, "mm4mm: %s\n", e.what());
    return kAtlasBusy;
  } catch (const mm4mm::cli::NotEnoughMemory& e) {
    std::fprintf(stderr, "mm4mm: error: %s\n", e.what());
    return kNotEnoughMemory;
  } catch (const mm4mm::InputError& e) {
    std::fprintf(stderr, "mm4mm: error: %s\n", e.what());
    return kBadInput;
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "mm4mm: error: %s\n", e.what());
    return kBadInput;
  } catch (const mm4mm::OutputError& e) {
    std::fprintf(stderr, "mm4mm: error: %s\n", e.what());
    return kOutputFailed;
  } catch (const std::filesystem::filesystem_error& e) {
    std::fprintf(stderr, "mm4mm: error: %s\n", e.what());
    return kOutputFailed;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mm4mm: internal error: %s\n", e.what());
    return kInternalError;
  }
  return kSuccess;
}
