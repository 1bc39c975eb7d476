// What the command files share (apps/command.hpp): the error lines and exit codes, progress,
// --stats, --json, --3dtiles.
#include "command.hpp"

#include <cstdio>
#include <new>

#include "dsmplan/export.hpp"
#include "dsmplan/raster_io.hpp"
#include "usage.hpp"

namespace dsmplan::cli {

namespace {

// True while a progress line is unfinished, so an error message starts on a line of its own.
bool progress_line_open = false;

// One line on stderr, on a line of its own; returns the exit code.
int fail(const std::string& message, int exit_code) {
  end_progress_line();
  std::fprintf(stderr, "dsmplan: %s\n", message.c_str());
  return exit_code;
}

}  // namespace

const char* const kCrsHelp =
    "CRS of the input (EPSG:n, WKT or PROJ), overriding what the file states, as gdal_translate -a_srs; "
    "needed when it states none";

int run_command(CLI::App& app, const std::vector<Command>& commands, const MpiFarm& farm, int argc, char** argv) {
  try {
    refuse_unknown_names(app, argc, argv);
    refuse_single_dash_long_options(app, argc, argv);
    app.parse(argc, argv);
    const bool worker = farm.active() && farm.rank() > 0;  // makes blocks for rank 0, says nothing
    for (const Command& command : commands) {
      if (!*command.app) continue;
      if (!worker)
        command.run();
      else if (command.serve)
        command.serve();
    }
  } catch (const CLI::ParseError& error) {
    if (error.get_exit_code() == 0) return app.exit(error);  // --help, --version
    // Usage errors: one line, exit 2.
    std::string message = error.what();
    if (message.empty()) message = "the command line is incomplete (dsmplan --help)";
    return fail(message, 2);
  } catch (const ArgumentError& error) {
    return fail(flag_message(error), 2);  // a bad option value: a usage error too
  } catch (const Error& error) {
    return fail(error.what(), 1);
  } catch (const std::bad_alloc&) {
    return fail("out of memory: use a coarser --res or a smaller area", 1);
  } catch (const std::exception& error) {
    return fail(std::string("internal error: ") + error.what(), 3);
  }
  return 0;
}

void end_progress_line() {
  if (progress_line_open) std::printf("\n");
  progress_line_open = false;
  std::fflush(stdout);
}

Progress terminal_progress(bool quiet) {
  if (quiet) return {};
  return [](double fraction) {
    progress_line_open = fraction < 1;
    return print_terminal_progress(fraction);
  };
}

void write_stats(const std::string& stats, const Json& report, const std::vector<std::string>& outputs) {
  if (!stats.empty()) write_text_file_or_remove(stats, report.dump(2) + "\n", outputs);
}

void print_json(const Json& report) { std::fputs((report.dump(2) + "\n").c_str(), stdout); }

void add_tileset_options(CLI::App* command, bool& tileset, VerticalOptions& vertical) {
  command->add_flag(
      "--3dtiles", tileset,
      "With a .glb: write a 3D Tiles 1.1 tileset.json beside it that places the mesh on the globe (Cesium)");
  command->add_option("--vertical-crs", vertical.vertical_crs,
                      "With --3dtiles: vertical CRS of the heights when the DSM does not say (e.g. EPSG:7837)");
  command->add_flag(
      "--allow-approximate-vertical", vertical.allow_approximate_vertical,
      "With --3dtiles: heights of an unknown or grid-less vertical datum taken as EGM96 heights (about 1 m off)");
}

void add_zone_options(CLI::App* command, ZoneFiles& zones) {
  command->add_option("--no-fly", zones.files,
                      "No-fly zones to draw (EUROCAE ED-269 JSON or GeoJSON, as dsmplan plan reads them; repeatable)");
  command
      ->add_option("--no-fly-blocking", zones.blocking,
                   "Restrictions drawn as blocking (default PROHIBITED,REQ_AUTHORISATION); the others in amber")
      ->delimiter(',');
  command->add_option("--vertical-crs", zones.vertical.vertical_crs,
                      "With --no-fly: vertical CRS of the DSM's heights when the file does not say (e.g. EPSG:7837), "
                      "for AMSL and WGS 84 limits");
  command->add_flag("--allow-approximate-vertical", zones.vertical.allow_approximate_vertical,
                    "With --no-fly: heights of an unknown or grid-less vertical datum taken as EGM96 heights (about "
                    "1 m off)");
}

void add_zone_inputs(const ZoneFiles& zones, std::vector<NamedFile>& inputs) {
  for (const std::string& file : zones.files) inputs.push_back({"--no-fly", file});
}

}  // namespace dsmplan::cli
