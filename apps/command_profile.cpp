// dsmplan profile: profile_job() (dsmplan/picture_job.hpp).
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "dsmplan/picture_job.hpp"
#include "usage.hpp"

namespace dsmplan::cli {

namespace {

struct ProfileArguments {
  ProfileJobOptions options;
  bool json = false;
  std::string of;
};

void run_profile(const ProfileArguments& request, bool quiet) {
  const ProfileJobOptions& profile = request.options;
  std::vector<NamedFile> inputs{
      {"DSM", profile.dsm}, {"--path", profile.path}, {"--dtm", profile.dtm}, {"--waypoints", profile.waypoints}};
  add_zone_inputs(profile.no_fly, inputs);
  refuse_overwrites(inputs, {{"-o", profile.output}});
  check_single_format(request.of, {"png"});
  const ProfileReport report = profile_job(profile, terminal_progress(quiet));
  if (request.json)
    print_json(to_json(report));
  else if (!quiet)
    std::fputs(to_text(report).c_str(), stdout);
}

}  // namespace

Command profile_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<ProfileArguments>();
  ProfileJobOptions& profile = request->options;
  CLI::App* command = app.add_subcommand(
      "profile", "Draw a path's height profile over the DSM below it, the terrain and the ceiling, as a PNG");
  command->add_option("DSM", profile.dsm, "Raster file (the DSM the path was planned over)")->required();
  command->add_option("--path", profile.path, "Path CSV (dsmplan plan -o PATH.csv): x,y,z in the DSM's CRS")
      ->required();
  command->add_option("-o,--output", profile.output, "Picture: .png")->required();
  command->add_option("--dtm", profile.dtm,
                      "Terrain raster (the DSM's CRS, any resolution): a line, and the ceiling's ground");
  command->add_option("--waypoints", profile.waypoints, "Waypoint CSV: numbered markers on the path");
  command->add_option("--safety", profile.profile.safety, "Half-height of the band around the path (m)")
      ->capture_default_str();
  command->add_option("--max-agl", profile.profile.max_agl, "Ceiling above the ground (m; the DTM, else the DSM)")
      ->capture_default_str();
  add_zone_options(command, profile.no_fly);
  command->add_option("--title", profile.profile.title, "Title (default: the path's and the DSM's file names)");
  command->add_option("--width", profile.profile.width, "Picture width, pixels")->capture_default_str();
  command->add_option("--height", profile.profile.height, "Picture height, pixels")->capture_default_str();
  command->add_flag("-q,--quiet", session.quiet, "No progress output and no summary line");
  command->add_flag("--json", request->json, "Print the summary as JSON");
  command->add_option("--of", request->of, "Output format: png (the only one)");
  return {command, [request, &session] { run_profile(*request, session.quiet); }};
}

}  // namespace dsmplan::cli
