// dsmplan's 3D viewer: the GLB of `dsmplan mesh|simplify -o X.glb`, shaded by height, and the
// path of `dsmplan plan -o X.csv` as a magenta tube with the waypoints as cyan spheres.
//
// Query parameters: mesh=URL (required), path=URL, waypoints=URL (CSV "x,y,z" in the mesh's CRS),
// radius=M (the path's radius in CRS units; default 1/300 of the mesh's diagonal), service=URL
// (a planning service's /v1: click the mesh to plan, planner.js; with clicks=, height=),
// zones=URL (no-fly zones' JSON of `dsmplan view --no-fly`: translucent prisms, zones.js).
//
// When everything is drawn: body[data-state] = "ready", window.dsmplanReady = true and the title
// ends in "ready"; on a failure data-state = "error" and one line in #status says why. Frames
// are drawn on demand (not in a loop), so a headless browser sees the page go idle.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { startPlanner } from './planner.js';
import { drawZones, surfaceOf } from './zones.js';

// Unlit, so these exact colours are in a screenshot (the tests look for them).
const PATH_COLOUR = 0xff00ff;
const WAYPOINT_COLOUR = 0x00ffff;
// Height ramp of the mesh: green, tan, off-white; far from magenta and cyan.
const RAMP = [0x3a6b35, 0xc8b27a, 0xf4f1ea].map((hex) => new THREE.Color(hex));

const statusLine = document.getElementById('status');
const canvas = document.getElementById('view');

function fail(message) {
  statusLine.textContent = `dsmplan viewer: ${message}`;
  statusLine.className = 'error';
  document.body.dataset.state = 'error';
  document.title = 'dsmplan viewer: error';
  window.dsmplanReady = false;
}

async function fetchText(url) {
  let response;
  try {
    response = await fetch(url);
  } catch (error) {
    throw new Error(`${url}: ${error.message}`);
  }
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status} ${response.statusText}`);
  return response.text();
}

// "x,y,z" lines as dsmplan reads and writes them: blank lines and '#' comments skipped, a first
// line that is not numbers is a header; anything else is an error naming the line.
function parseXyz(text, url) {
  const points = [];
  let header = false;
  text.split(/\r?\n/).forEach((raw, i) => {
    const line = raw.trim();
    if (line === '' || line.startsWith('#')) return;
    const values = line.split(',').map((t) => (t.trim() === '' ? NaN : Number(t)));
    if (values.length === 3 && values.every(Number.isFinite)) {
      points.push(new THREE.Vector3(...values));
    } else if (points.length === 0 && !header) {
      header = true;
    } else {
      throw new Error(`${url} line ${i + 1}: not three numbers x,y,z`);
    }
  });
  return points;
}

// Vertex colours by height: positions are in the CRS's axes (z up) relative to the origin.
function colourByHeight(geometry) {
  const position = geometry.getAttribute('position');
  let lo = Infinity;
  let hi = -Infinity;
  for (let i = 0; i < position.count; ++i) {
    lo = Math.min(lo, position.getZ(i));
    hi = Math.max(hi, position.getZ(i));
  }
  const colours = new Float32Array(3 * position.count);
  const c = new THREE.Color();
  for (let i = 0; i < position.count; ++i) {
    const t = hi > lo ? (position.getZ(i) - lo) / (hi - lo) : 0;
    const k = Math.min(RAMP.length - 2, Math.floor(t * (RAMP.length - 1)));
    c.lerpColors(RAMP[k], RAMP[k + 1], t * (RAMP.length - 1) - k);
    c.toArray(colours, 3 * i);
  }
  geometry.setAttribute('color', new THREE.BufferAttribute(colours, 3));
}

// A polyline as a tube: one open cylinder per segment and a sphere at every point (so corners
// are closed), two instanced meshes. `points` are local to the mesh node (CRS minus origin).
function tube(points, radius, colour) {
  const material = new THREE.MeshBasicMaterial({ color: colour });
  const group = new THREE.Group();
  const joints = new THREE.InstancedMesh(new THREE.SphereGeometry(radius, 16, 12), material, points.length);
  const m = new THREE.Matrix4();
  points.forEach((p, i) => joints.setMatrixAt(i, m.makeTranslation(p.x, p.y, p.z)));
  group.add(joints);
  if (points.length > 1) {
    const segments = new THREE.InstancedMesh(
      new THREE.CylinderGeometry(radius, radius, 1, 16, 1, true), material, points.length - 1);
    const up = new THREE.Vector3(0, 1, 0);  // the cylinder's axis
    const q = new THREE.Quaternion();
    const d = new THREE.Vector3();
    const mid = new THREE.Vector3();
    for (let i = 0; i + 1 < points.length; ++i) {
      d.subVectors(points[i + 1], points[i]);
      const length = d.length();
      q.setFromUnitVectors(up, length > 0 ? d.clone().divideScalar(length) : up);
      mid.addVectors(points[i], points[i + 1]).multiplyScalar(0.5);
      segments.setMatrixAt(i, m.compose(mid, q, new THREE.Vector3(1, Math.max(length, 1e-6), 1)));
    }
    group.add(segments);
  }
  return group;
}

async function main() {
  const params = new URLSearchParams(window.location.search);
  const meshUrl = params.get('mesh');
  if (!meshUrl) throw new Error('no mesh: open the page with ?mesh=URL of a GLB');

  const zonesUrl = params.get('zones');
  const [gltf, path, waypoints, zones] = await Promise.all([
    new GLTFLoader().loadAsync(meshUrl).catch((error) => {
      throw new Error(`${meshUrl}: ${error.message}`);
    }),
    params.get('path') ? fetchText(params.get('path')).then((t) => parseXyz(t, params.get('path'))) : null,
    params.get('waypoints')
      ? fetchText(params.get('waypoints')).then((t) => parseXyz(t, params.get('waypoints')))
      : null,
    zonesUrl ? fetchText(zonesUrl).then((t) => JSON.parse(t).zones) : null,
  ]);

  // dsmplan's GLB (src/io/glb_writer.cpp): scene -> root node (rotation z-up to y-up) ->
  // mesh node (translation = asset.extras.origin) with float32 positions = CRS - origin.
  const origin = gltf.asset?.extras?.origin;
  if (!Array.isArray(origin) || origin.length !== 3) throw new Error(`${meshUrl}: no asset.extras.origin (not a dsmplan GLB)`);
  const root = gltf.scene.children[0];
  const node = root?.children[0];
  if (!node) throw new Error(`${meshUrl}: no mesh node under the root node (not a dsmplan GLB)`);
  const originVector = new THREE.Vector3(...origin);
  if (node.position.distanceTo(originVector) > 1e-9 * (1 + originVector.length())) {
    throw new Error(`${meshUrl}: the mesh node's translation is not asset.extras.origin`);
  }
  let triangles = 0;
  const surfaces = [];  // the GLB's own meshes, what a click may hit (not the path or waypoints)
  node.traverse((object) => {
    if (!object.isMesh) return;
    surfaces.push(object);
    colourByHeight(object.geometry);
    triangles += object.geometry.index ? object.geometry.index.count / 3 : 0;
    // Flat shading needs no normals (the GLB has none); both sides, as a surface has no inside.
    object.material = new THREE.MeshStandardMaterial({
      vertexColors: true, flatShading: true, side: THREE.DoubleSide, roughness: 0.95, metalness: 0,
    });
  });
  if (triangles === 0) throw new Error(`${meshUrl}: the mesh has no triangles`);

  // The path and waypoints in the mesh node's own frame: CRS minus origin, subtracted here in
  // doubles (float32 cannot hold 5.7e6 to the centimetre), then the same rotation by the root
  // node, so path and mesh line up exactly.
  const box = new THREE.Box3().setFromObject(gltf.scene);  // world: y is the CRS height (origin included)
  const radius = Number(params.get('radius')) || box.getSize(new THREE.Vector3()).length() / 300;
  const local = (points) => points.map((p) => p.clone().sub(originVector));
  const crs = gltf.asset.extras.crs?.name;
  let summary = `${meshUrl.split('/').pop()}${crs ? ` (${crs})` : ''}: ${triangles} triangles`;
  if (path) {
    if (path.length < 2) throw new Error(`${params.get('path')}: fewer than two points`);
    node.add(tube(local(path), radius, PATH_COLOUR));
    let length = 0;
    for (let i = 1; i < path.length; ++i) length += path[i].distanceTo(path[i - 1]);
    summary += `; path: ${path.length} points, ${length.toFixed(1)} m`;
  }
  if (waypoints) {
    const spheres = new THREE.Group();
    for (const p of local(waypoints)) {
      const sphere = new THREE.Mesh(
        new THREE.SphereGeometry(2.5 * radius, 24, 16), new THREE.MeshBasicMaterial({ color: WAYPOINT_COLOUR }));
      sphere.position.copy(p);
      spheres.add(sphere);
    }
    node.add(spheres);
    summary += `; ${waypoints.length} waypoints`;
  }

  if (zones) {
    const size = box.getSize(new THREE.Vector3());
    drawZones({ zones, node, origin: originVector, surfaceAt: surfaceOf(surfaces, node),
      low: box.min.y, high: box.max.y, labelHeight: size.length() / 60 });
    summary += `; ${zones.length} no-fly zone${zones.length === 1 ? '' : 's'}`;
  }

  // Centre the scene at 0 so the camera's numbers stay small.
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xffffff);
  scene.add(gltf.scene);
  gltf.scene.position.sub(box.getCenter(new THREE.Vector3()));
  scene.add(new THREE.HemisphereLight(0xffffff, 0x808080, 1.8));
  const sun = new THREE.DirectionalLight(0xffffff, 1.6);
  sun.position.set(-0.5, 1, 0.3);  // from the north-west, as hillshades are lit
  scene.add(sun);

  // Oblique view from the south-east (glTF: x east, y up, z south), the whole mesh in frame.
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio);
  const sphere = box.getBoundingSphere(new THREE.Sphere());
  const camera = new THREE.PerspectiveCamera(40, 1, sphere.radius / 100, sphere.radius * 20);
  // The bounding sphere fits at radius / sin(half the fov); a flat city fits somewhat closer.
  const distance = 0.85 * sphere.radius / Math.sin(THREE.MathUtils.degToRad(20));
  camera.position.set(0.45, 0.75, 0.9).normalize().multiplyScalar(distance);
  const controls = new OrbitControls(camera, canvas);
  controls.target.set(0, 0, 0);
  controls.update();

  const render = () => renderer.render(scene, camera);
  const resize = () => {
    renderer.setSize(window.innerWidth, window.innerHeight, false);
    camera.aspect = window.innerWidth / Math.max(1, window.innerHeight);
    camera.updateProjectionMatrix();
    render();
  };
  controls.addEventListener('change', render);
  window.addEventListener('resize', resize);
  resize();

  statusLine.textContent = summary;
  const service = params.get('service');
  if (service) {
    startPlanner({ service, node, origin: originVector, surfaces, camera, canvas, render, radius, parseXyz, tube,
      pathColour: PATH_COLOUR, waypointColour: WAYPOINT_COLOUR,
      params: { meshCrs: gltf.asset.extras.crs, clicks: params.get('clicks'), height: params.get('height') } });
  }
  document.body.dataset.state = 'ready';
  document.title = 'dsmplan viewer: ready';
  window.dsmplanReady = true;
}

main().catch((error) => fail(error.message));
