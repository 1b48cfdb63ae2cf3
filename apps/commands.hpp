// The subcommands of `pliant`, one file each (cmd_*.cpp). A command registers its options on
// the CLI11 app and returns the action main() runs when it was chosen. Actions throw
// InputError (exit 2) or DivergenceError (exit 3); main() turns those into exit codes.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>

namespace pliant::cli {

struct Command {
  CLI::App* sub = nullptr;
  std::function<int()> action;
};

Command add_run_command(CLI::App& app);
Command add_info_command(CLI::App& app);
Command add_mesh_command(CLI::App& app);

}  // namespace pliant::cli
