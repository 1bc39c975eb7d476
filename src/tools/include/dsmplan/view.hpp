// dsmplan/view.hpp: `dsmplan view`, the 3D viewer served over HTTP, as a library function.
#pragma once

#include <functional>
#include <string>

#include "dsmplan/picture_job.hpp"

namespace dsmplan {

// ---- dsmplan view ---------------------------------------------------------------------------

struct ViewOptions {
  std::string mesh;       ///< GLB of `dsmplan mesh|simplify -o X.glb`
  std::string path;       ///< optional path CSV (x,y,z in the mesh's CRS, as `dsmplan plan -o X.csv`)
  std::string waypoints;  ///< optional waypoint CSV (x,y,z, or x,y,agl measured from `dtm`, else `dsm`)
  /// Rasters an x,y,agl waypoint file's heights are measured from, as `dsmplan plan --dtm` and
  /// `--dsm` count them (the DTM when given, else the DSM); an agl file without either is refused.
  std::string dtm, dsm;
  std::string host = "127.0.0.1";
  int port = 8080;  ///< 0: any free port (the URL names the one taken)
  /// The viewer's static files: index.html, viewer.js and node_modules/three (the build puts
  /// them in build/web/viewer). Empty: default_viewer_dir().
  std::string viewer_dir;
  /// Seconds a client has to send each request, head and body, from its first byte: past it
  /// the connection is closed (408), so that slow clients cannot hold the server's threads.
  double request_deadline_seconds = 10;
  /// Optional address of a planning service (`dsmplan serve`), http://HOST[:PORT]: the page then
  /// plans on click, and the server passes its POST /v1/plan, GET /v1/info and GET /v1/health,
  /// nothing else, to that one address (so the page has one origin and never sees the token).
  std::string serve;
  /// Optional file holding the service's bearer token (its --token-file), sent with every
  /// request passed on; needs `serve`.
  std::string serve_token_file;
  /// Optional no-fly zones drawn as translucent prisms from floor to ceiling, read as `dsmplan
  /// plan --no-fly` reads them into the GLB's CRS (asset.extras.crs). AGL limits stand on the
  /// mesh's surface under each corner (the DSM's, as plan counts them without a DTM); an
  /// unlimited floor starts at the mesh's lowest point, an unlimited ceiling is drawn 120 m
  /// above its highest (the open category's ceiling over the tallest roof).
  ZoneFiles no_fly;
};

/// web/viewer beside the running executable (build/dsmplan -> build/web/viewer).
std::string default_viewer_dir();

/// The 3D viewer (web/viewer: three.js) over HTTP: serves the viewer folder at / and the given
/// files as /data/mesh.glb, /data/path.csv, /data/waypoints.csv (and the zones as
/// /data/zones.json), nothing else (a request naming
/// ".." is refused); with `serve`, also the service's three routes under /v1 (a POST only as
/// application/json and from the page's own origin, so that another site cannot plan through it). Checks every file
/// first (the mesh a GLB, the CSVs readable as x,y,z, the viewer folder complete: InputError), binds
/// (ArgumentError("--port") when the port is taken), calls `listening` with the page's URL, then serves until the
/// process is stopped.
void serve_view(const ViewOptions& options, const std::function<void(const std::string& url)>& listening);

}  // namespace dsmplan
