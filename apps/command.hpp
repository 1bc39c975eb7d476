// The subcommands of the dsmplan binary, one source file each (command_info.cpp, ...), as GDAL's
// apps/gdalalg_raster_*.cpp: each registers its flags and help, and when chosen, puts what
// CLI11 parsed into the library's options struct and calls the library's job function. The
// checks of the options are the library's (a C++ or Python caller gets the same errors); what
// stays here is argv's syntax: lists and pairs written as one word, flags that name a choice.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "dsmplan/core.hpp"
#include "dsmplan/mpi_farm.hpp"
#include "dsmplan/picture_job.hpp"
#include "dsmplan/tools.hpp"

namespace dsmplan::cli {

/// What every command shares: the MPI farm (active only under mpirun) and -q.
struct Session {
  const MpiFarm& farm;
  bool quiet = false;
  int exit_code = 0;  ///< when the command ran but not all of it succeeded (plan --routes: 4)
};

/// One subcommand, registered on the app; `run` does its job when `*app` was chosen.
struct Command {
  Command(CLI::App* app, std::function<void()> run, std::function<void()> serve = {})
      : app(app), run(std::move(run)), serve(std::move(serve)) {}
  CLI::App* app;
  std::function<void()> run;
  /// What an MPI worker rank does for this command (only simplify farms out); empty: nothing.
  std::function<void()> serve;
};

Command info_command(CLI::App& app, Session& session);
Command grid_command(CLI::App& app, Session& session);
Command stereo_command(CLI::App& app, Session& session);
Command mesh_command(CLI::App& app, Session& session);
Command simplify_command(CLI::App& app, Session& session);
Command render_command(CLI::App& app, Session& session);
Command profile_command(CLI::App& app, Session& session);
Command plan_command(CLI::App& app, Session& session);
Command view_command(CLI::App& app, Session& session);
Command serve_command(CLI::App& app, Session& session);

/// Parses argv and runs the chosen command (on an MPI worker rank: its `serve`, if any), turning
/// every error into one line on stderr and the exit code: 2 a usage error (ArgumentError
/// included), 1 an Error, 3 anything else (an internal error); 0 when all went well.
int run_command(CLI::App& app, const std::vector<Command>& commands, const MpiFarm& farm, int argc, char** argv);

// ---- helpers of the command files ----------------------------------------------------------

/// --crs means the same for every command.
extern const char* const kCrsHelp;

/// GDAL's terminal progress ("0...10...20...100 - done."), or nothing with -q.
Progress terminal_progress(bool quiet);
/// Before a message on stderr after a run with progress: ends an unfinished progress line and
/// flushes stdout (the progress is there), so the message starts on a line of its own.
void end_progress_line();

/// --stats after the main output: when it cannot be written, the main output is removed too,
/// so a run leaves all its files or none.
void write_stats(const std::string& stats, const Json& report, const std::vector<std::string>& outputs);

/// A report on stdout as --json prints it: indented by two, with a newline.
void print_json(const Json& report);

/// --3dtiles and the heights it needs, on `dsmplan mesh` and `simplify`.
void add_tileset_options(CLI::App* command, bool& tileset, VerticalOptions& vertical);

/// --no-fly, --no-fly-blocking and the heights they need, on `dsmplan render` and `profile`.
void add_zone_options(CLI::App* command, ZoneFiles& zones);

/// The zone files as inputs refuse_overwrites() checks.
void add_zone_inputs(const ZoneFiles& zones, std::vector<NamedFile>& inputs);

}  // namespace dsmplan::cli
