// The subcommands of `pliant`, one file each (cmd_*.cpp). A command registers its options on
// the CLI11 app and returns the action main() runs when it was chosen. Actions throw
// InputError (exit 2) or DivergenceError (exit 3); main() turns those into exit codes.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>
#include <optional>
#include <string>

namespace pliant::cli {

struct Command {
  CLI::App* sub = nullptr;
  std::function<int()> action;
};

Command add_run_command(CLI::App& app);        // cmd_run.cpp
Command add_info_command(CLI::App& app);       // cmd_info.cpp
Command add_mesh_command(CLI::App& app);       // cmd_mesh.cpp
Command add_bench_command(CLI::App& app);      // cmd_bench.cpp
Command add_study_command(CLI::App& app);      // cmd_study.cpp
Command add_stability_command(CLI::App& app);  // cmd_stability.cpp
Command add_stress_command(CLI::App& app);     // cmd_stress.cpp
Command add_render_command(CLI::App& app);     // cmd_render.cpp

// The view options of `pliant render` and `pliant run`'s pictures (cmd_render.cpp): --up,
// --azimuth, --elevation; and their check (InputError naming the option).
void add_view_options(CLI::App* sub, std::string& up, std::optional<double>& azimuth, std::optional<double>& elevation);
void set_view(std::optional<double>& azimuth_out, std::optional<double>& elevation_out, std::optional<double> azimuth,
              std::optional<double> elevation);

// Refuses an output path that is the input file (`pliant mesh cube.msh -o cube.msh` replaced the
// mesh by VTU data under its old name; render, by a PNG): InputError naming `option`
// (cmd_render.cpp).
void refuse_overwriting_input(const std::string& input, const std::string& output, const char* option);

}  // namespace pliant::cli
