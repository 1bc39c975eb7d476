// dsmplan's 3D Tiles test driver: serves page.html, CesiumJS and a folder holding tileset.json
// (and its GLB) on 127.0.0.1, loads the page in headless Chromium (SwiftShader's WebGL) and
// prints what CesiumJS answered: {"heights": [...], "centre": [lon, lat, h], "radius": r}, the
// heights of the mesh under the given lon/lat (WGS 84 ellipsoidal), or {"error": "..."}.
// Usage: node place.js CHROMIUM CESIUM_PACKAGE_DIR DATA_DIR POINTS_JSON PROFILE_DIR
// Exit 0 with the page's answer on stdout, 2 when the page could not be loaded at all.
'use strict';
const fs = require('fs');
const http = require('http');
const path = require('path');
const {execFile} = require('child_process');

const types = {'.html': 'text/html', '.js': 'text/javascript', '.json': 'application/json', '.css': 'text/css',
               '.glb': 'model/gltf-binary', '.png': 'image/png', '.jpg': 'image/jpeg', '.svg': 'image/svg+xml',
               '.wasm': 'application/wasm', '.xml': 'text/xml'};

function serve(roots) {
  return http.createServer((request, response) => {
    const url = new URL(request.url, 'http://localhost');
    let file = null;
    if (url.pathname === '/') file = path.join(__dirname, 'page.html');
    for (const [prefix, dir] of Object.entries(roots)) {
      if (url.pathname.startsWith(prefix)) file = path.join(dir, decodeURIComponent(url.pathname.slice(prefix.length)));
    }
    if (!file || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
      response.writeHead(404).end();
      return;
    }
    response.writeHead(200, {'Content-Type': types[path.extname(file)] || 'application/octet-stream'});
    fs.createReadStream(file).pipe(response);
  });
}

function main([chromium, cesium, data, points, profile]) {
  if (!profile) {
    console.error('usage: node place.js CHROMIUM CESIUM_PACKAGE_DIR DATA_DIR POINTS_JSON PROFILE_DIR');
    process.exitCode = 2;
    return;
  }
  const server = serve({'/cesium/': cesium, '/data/': data});
  server.listen(0, '127.0.0.1', () => attempt(1));
  // Virtual time runs ahead while the page waits on its web workers; on a loaded machine the
  // budget can end before CesiumJS answers ("pending"): then the page is loaded again, at most
  // three times.
  function attempt(n) {
    const url = `http://127.0.0.1:${server.address().port}/?points=${encodeURIComponent(points)}`;
    const args = ['--headless=new', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
                  '--window-size=800,600', '--virtual-time-budget=120000', `--user-data-dir=${profile}-${n}`,
                  '--dump-dom', url];
    execFile(chromium, args, {maxBuffer: 64 << 20, timeout: 300000}, (error, stdout, stderr) => {
      const match = /<pre id="result">([^<]*)<\/pre>/.exec(stdout);
      if (!error && match && match[1] === 'pending' && n < 3) {
        attempt(n + 1);
        return;
      }
      server.close();
      if (error || !match) {
        console.error(`place.js: ${chromium} failed${error ? ': ' + error.message : ''}\n${stderr.slice(-4000)}`);
        process.exitCode = 2;
        return;
      }
      process.stdout.write(match[1].replace(/&quot;/g, '"').replace(/&lt;/g, '<').replace(/&gt;/g, '>')
                               .replace(/&amp;/g, '&') + '\n');
    });
  }
}

main(process.argv.slice(2));
