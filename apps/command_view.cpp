// dsmplan view: serve_view() (dsmplan/view.hpp) until the process is stopped.
#include <cstdio>
#include <memory>

#include "command.hpp"
#include "dsmplan/view.hpp"

namespace dsmplan::cli {

namespace {

struct ViewArguments {
  ViewOptions options;
  bool json = false;
};

void run_view(const ViewArguments& request) {
  serve_view(request.options, [json = request.json](const std::string& url) {
    // Flushed: a script or test reading stdout through a pipe needs the URL now.
    if (json)
      std::printf("%s\n", Json{{"url", url}}.dump().c_str());
    else
      std::printf("Serving the 3D viewer at %s (Ctrl-C stops)\n", url.c_str());
    std::fflush(stdout);
  });
}

}  // namespace

Command view_command(CLI::App& app, Session& session) {
  auto request = std::make_shared<ViewArguments>();
  ViewOptions& view = request->options;
  CLI::App* command = app.add_subcommand(
      "view", "Show a GLB mesh and a path in 3D in the browser: serves the three.js viewer on localhost until Ctrl-C");
  command->add_option("MESH", view.mesh, "Mesh: .glb (dsmplan mesh|simplify -o MESH.glb)")->required();
  command->add_option("--path", view.path, "Path CSV (dsmplan plan -o PATH.csv): x,y,z in the mesh's CRS");
  command->add_option("--waypoints", view.waypoints,
                      "Waypoint CSV: x,y,z in the mesh's CRS, or x,y,agl (heights above --dtm, else --dsm)");
  command->add_option("--dtm", view.dtm, "Terrain raster an x,y,agl waypoint file's heights are measured from");
  command->add_option("--dsm", view.dsm, "DSM raster an x,y,agl waypoint file's heights are measured from (no --dtm)");
  command->add_option("--port", view.port, "TCP port (0: any free one)")->capture_default_str();
  command->add_option("--host", view.host, "Address to listen on")->capture_default_str();
  command->add_option("--viewer-dir", view.viewer_dir,
                      "The viewer's files (index.html, viewer.js, node_modules/three); default: web/viewer beside "
                      "the dsmplan binary");
  command->add_option("--serve", view.serve,
                      "Address of a planning service (dsmplan serve, http://HOST:PORT): click the mesh to plan");
  command->add_option("--serve-token-file", view.serve_token_file,
                      "File whose first line is the service's bearer token (its --token-file)");
  add_zone_options(command, view.no_fly);
  command->add_flag("--json", request->json, "Print the viewer's address as JSON ({\"url\": ...})");
  command->add_flag("-q,--quiet", session.quiet, "Accepted for every command; the address is still printed");
  return {command, [request] { run_view(*request); }};
}

}  // namespace dsmplan::cli
