// dsmplan/view.hpp: `dsmplan view`, the 3D viewer served over HTTP, as a library function.
#pragma once

#include <functional>
#include <string>

namespace dsmplan {

// ---- dsmplan view ---------------------------------------------------------------------------

struct ViewOptions {
  std::string mesh;       ///< GLB of `dsmplan mesh|simplify -o X.glb`
  std::string path;       ///< optional path CSV (x,y,z in the mesh's CRS, as `dsmplan plan -o X.csv`)
  std::string waypoints;  ///< optional waypoint CSV (x,y,z)
  std::string host = "127.0.0.1";
  int port = 8080;  ///< 0: any free port (the URL names the one taken)
  /// The viewer's static files: index.html, viewer.js and node_modules/three (the build puts
  /// them in build/web/viewer). Empty: default_viewer_dir().
  std::string viewer_dir;
  /// Seconds a client has to send each request, head and body, from its first byte: past it
  /// the connection is closed (408), so that slow clients cannot hold the server's threads.
  double request_deadline_seconds = 10;
};

/// web/viewer beside the running executable (build/dsmplan -> build/web/viewer).
std::string default_viewer_dir();

/// The 3D viewer (web/viewer: three.js) over HTTP: serves the viewer folder at / and the given
/// files as /data/mesh.glb, /data/path.csv, /data/waypoints.csv, nothing else (a request naming
/// ".." is refused). Checks every file first (the mesh a GLB, the CSVs readable as x,y,z, the
/// viewer folder complete: InputError), binds (ArgumentError("--port") when the port is taken), calls
/// `listening` with the page's URL, then serves until the process is stopped.
void serve_view(const ViewOptions& options, const std::function<void(const std::string& url)>& listening);

}  // namespace dsmplan
