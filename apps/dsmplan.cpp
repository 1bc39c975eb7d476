// dsmplan: the command-line face of the library. Each command (apps/command_*.cpp) parses argv
// into the option structs of dsmplan/tools.hpp, calls the tool, and prints or writes the report;
// nothing else.
#include <CLI/CLI.hpp>

#include "command.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/mpi_farm.hpp"

using namespace dsmplan;

int main(int argc, char** argv) {
  remove_partial_outputs_on_signals();
  const MpiFarm farm(argc, argv);  // active only under mpirun with 2 or more ranks
  CLI::App app{"dsmplan: DSM to conservative obstacle mesh and UAV paths (Adolf & Hirschmueller)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "dsmplan " DSMPLAN_VERSION);
  cli::Session session{farm};
  // In the order `dsmplan --help` lists them.
  const std::vector<cli::Command> commands = {
      cli::info_command(app, session),    cli::grid_command(app, session),     cli::stereo_command(app, session),
      cli::mesh_command(app, session),    cli::simplify_command(app, session), cli::render_command(app, session),
      cli::profile_command(app, session), cli::plan_command(app, session),     cli::view_command(app, session),
      cli::serve_command(app, session),
  };
  const int failed = cli::run_command(app, commands, farm, argc, argv);
  return failed ? failed : session.exit_code;
}
