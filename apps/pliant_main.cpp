// pliant — the command line. Each subcommand lives in its own cmd_*.cpp (see commands.hpp).
// Exit codes: 0 success, 2 invalid input (message on stderr), 3 the simulation diverged.
#include <filesystem>
#include <new>

#include <fmt/format.h>

#include <vector>

#include "commands.hpp"
#include "pliant/error.hpp"

int main(int argc, char** argv) {
  using namespace pliant;
  constexpr int kExitInternal = 1;  // the environment or a bug, not the input
  constexpr int kExitInput = 2;
  constexpr int kExitDiverged = 3;
  CLI::App app{"pliant: real-time soft elastic bodies (explicit FEM after Debunne 2000)"};
  app.require_subcommand(1);
  const std::vector<cli::Command> commands = {
      cli::add_run_command(app),
      cli::add_info_command(app),
      cli::add_mesh_command(app),
      cli::add_bench_command(app),
      cli::add_study_command(app),
      cli::add_stability_command(app),
      cli::add_stress_command(app),
      cli::add_render_command(app),
  };
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : kExitInput;
  }
  try {
    for (const auto& c : commands)
      if (*c.sub) return c.action();
  } catch (const InputError& e) {
    fmt::print(stderr, "pliant: error: {}\n", e.what());
    return kExitInput;
  } catch (const DivergenceError& e) {
    fmt::print(stderr, "\npliant: {}\n", e.what());
    return kExitDiverged;
  } catch (const std::filesystem::filesystem_error& e) {  // a path the user gave: --out, a scene's files
    fmt::print(stderr, "pliant: error: {}\n", e.what());
    return kExitInput;
  } catch (const std::bad_alloc&) {
    fmt::print(stderr, "pliant: error: out of memory\n");
    return kExitInternal;
  } catch (const std::exception& e) {  // not the input's fault: the environment (OSMesa...) or a bug
    fmt::print(stderr, "pliant: internal error: {}\n", e.what());
    return kExitInternal;
  }
  return 0;
}
