// Pictures of a parameter study (`pliant study`): its Pareto front of cost against error and its
// convergence curves, as PNG plots with labelled axes and units, drawn with plot.hpp from a
// study::StudyResult. Library pliant_study_plots (raster/study/), built with pliant_study: the
// engine's study code draws nothing, since engine/ does not depend on raster/.
//
//   const study::StudyResult r = study::run_study(options);
//   for (const auto& f : raster::write_study_plots(r, options.out_dir).files) fmt::print("{}\n", f);
#pragma once
#include <filesystem>
#include <string>
#include <vector>

#include "pliant/raster/plot.hpp"
#include "pliant/perf/study.hpp"

namespace pliant::raster {

// Cost (x: wall seconds per simulated second, or tet-steps, as the study's CostKind) against the
// largest |relative error| over the quantities, in % (y); each axis is logarithmic when its
// values span a factor of 5 or more. Every run with an error is a grey dot; the front is a line
// through its runs, cheapest first, each labelled "#N" (N: its row in study.csv and study.md).
// Runs without an error (diverged, invalid, not measurable, the reference run) and, on a log
// axis, runs of zero error cannot be drawn: the title counts them.
Plot study_pareto_plot(const study::StudyResult& result);

// The convergence of each quantity: its |relative error| in % against the sweep that changes the
// mesh (x: the number of tets), or, when no sweep changes the mesh, against the first sweep whose
// values are all numbers (x: that value, in its scene unit when known); one series per
// combination of the other sweeps, in grid order, points sorted along x (a gap where a run has
// no error). Log axes as above. More than 4 lines: the legend goes below the plot (see below).
// Lines that coincide at the plot's size are drawn once and share a legend entry (plot.hpp).
struct ConvergencePlots {
  std::vector<Plot> panels;  // one per quantity; empty when there is nothing to show (why_none)
  std::string sweep;         // the path of the sweep along x
  bool x_is_tets = false;    // x is the number of tets (the sweep changes the mesh)
  std::string why_none;      // e.g. "no sweep changes the mesh or takes numbers"
};
ConvergencePlots study_convergence_plots(const study::StudyResult& result);

struct StudyPlotFiles {
  std::vector<std::string> files;  // paths written
  std::vector<std::string> notes;  // plots not written, and why
};

// Writes DIR/pareto.png (800x600) and DIR/convergence.png (one panel per quantity, side by side;
// a panel is 800x600, or with more than 4 lines 24 pixels taller per line, their legend going
// below the plot) into an existing folder; a plot with nothing to show is not written and a note
// says why. Throws InputError naming the file when it cannot be written.
StudyPlotFiles write_study_plots(const study::StudyResult& result, const std::filesystem::path& dir);

}  // namespace pliant::raster
