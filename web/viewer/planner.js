// Planning on click, with a planning service (`dsmplan serve`) behind `service` (the page's own
// server passes /v1/plan, /v1/info and /v1/health on: `dsmplan view --serve URL`). A click on the
// mesh adds a waypoint at the surface point plus the height in the page's field; Plan sends them
// to POST {service}/plan and draws the path with its figures, or shows the service's one line.
//
// For scripts and tests: clicks=x,y;x,y... (the mesh's CRS) clicks each point from straight above
// through the same function as a real click, then plans; height=M sets the field first.
// body[data-plan] says where it is: "idle", "planning", "drawn" or "error"; #plan-request holds
// the body sent, #plan-path the path drawn (the service's CSV), #figures the figures (also as
// data-* attributes, unrounded).
import * as THREE from 'three';

const byId = (id) => document.getElementById(id);

// The request's coordinates to the centimetre: what a user can read, and well inside the mesh's
// own precision (float32 positions relative to the origin).
const centimetres = (v) => Math.round(v * 100) / 100;

export function startPlanner({ service, node, origin, surfaces, camera, canvas, render, radius, parseXyz, tube,
  pathColour, waypointColour, params }) {
  const heightField = byId('height');
  const figures = byId('figures');
  byId('planner').hidden = false;
  const waypoints = [];  // in the mesh's CRS, doubles
  const markers = new THREE.Group();
  node.add(markers);
  let path = null;
  const raycaster = new THREE.Raycaster();

  const say = (text, state, error = false) => {
    figures.textContent = text;
    figures.className = error ? 'error' : '';
    document.body.dataset.plan = state;
  };
  const clearPath = () => {
    if (path) node.remove(path);
    path = null;
    byId('plan-path').textContent = '';
    for (const key of Object.keys(figures.dataset)) delete figures.dataset[key];
  };

  // `world`: a point of the mesh's surface in the scene's frame (a ray's hit).
  function addWaypointAt(world) {
    const height = Number(heightField.value);
    if (heightField.value.trim() === '' || !Number.isFinite(height)) {
      say(`height above the surface: '${heightField.value}' is not a number of metres`, 'error', true);
      return;
    }
    const local = node.worldToLocal(world.clone());  // the CRS minus the origin, z up
    const p = new THREE.Vector3(centimetres(local.x + origin.x), centimetres(local.y + origin.y),
      centimetres(local.z + origin.z + height));
    waypoints.push(p);
    const marker = new THREE.Mesh(new THREE.SphereGeometry(2.5 * radius, 24, 16),
      new THREE.MeshBasicMaterial({ color: waypointColour }));
    marker.position.copy(p.clone().sub(origin));
    markers.add(marker);
    clearPath();
    say(`${waypoints.length} waypoint${waypoints.length > 1 ? 's' : ''}: ` +
      (waypoints.length > 1 ? 'Plan, or click to add more' : 'click another point of the mesh'), 'idle');
    render();
  }

  // The first surface a ray meets, or null.
  const surfaceHit = () => raycaster.intersectObjects(surfaces, false)[0]?.point ?? null;

  // A click (not a drag, which turns the view) on the mesh adds a waypoint there.
  let down = null;
  canvas.addEventListener('pointerdown', (event) => { down = [event.clientX, event.clientY]; });
  canvas.addEventListener('pointerup', (event) => {
    if (!down || Math.hypot(event.clientX - down[0], event.clientY - down[1]) > 4) return;
    const box = canvas.getBoundingClientRect();
    raycaster.setFromCamera(new THREE.Vector2(((event.clientX - box.left) / box.width) * 2 - 1,
      -((event.clientY - box.top) / box.height) * 2 + 1), camera);
    const hit = surfaceHit();
    if (hit) addWaypointAt(hit);
  });

  // As if (x, y) of the mesh's CRS were clicked with the camera straight above it.
  function clickAbove(x, y) {
    node.updateWorldMatrix(true, false);
    const from = node.localToWorld(new THREE.Vector3(x - origin.x, y - origin.y, 1e6));
    raycaster.set(from, new THREE.Vector3(0, 0, -1).transformDirection(node.matrixWorld));
    const hit = surfaceHit();
    if (!hit) throw new Error(`clicks: (${x}, ${y}) is not over the mesh`);
    addWaypointAt(hit);
  }

  async function plan() {
    if (waypoints.length < 2) return say('two or more waypoints are needed: click the mesh', 'error', true);
    const body = JSON.stringify({ waypoints: waypoints.map((p) => [p.x, p.y, p.z]), format: 'csv' });
    byId('plan-request').textContent = body;
    clearPath();
    say(`planning a path through ${waypoints.length} waypoints…`, 'planning');
    let answer = null;
    try {
      const response = await fetch(`${service}/plan`,
        { method: 'POST', headers: { 'Content-Type': 'application/json' }, body });
      const text = await response.text();
      try { answer = JSON.parse(text); } catch { answer = null; }
      if (!response.ok || typeof answer?.path !== 'string') {
        throw new Error(answer?.error ?? `HTTP ${response.status} ${response.statusText}`);
      }
    } catch (error) {
      return say(`no path: ${error.message}`, 'error', true);
    }
    const points = parseXyz(answer.path, 'the planned path');
    path = tube(points.map((p) => p.clone().sub(origin)), radius, pathColour);
    node.add(path);
    byId('plan-path').textContent = answer.path;
    const s = answer.stats ?? {};
    Object.assign(figures.dataset, { points: points.length, lengthM: s.path_length_m,
      minClearanceM: s.min_clearance_m, maxAglM: s.max_agl_m, ground: s.ground });
    say(`path: ${points.length} points, ${s.path_length_m?.toFixed(1)} m; least clearance ` +
      `${s.min_clearance_m?.toFixed(2)} m; at most ${s.max_agl_m?.toFixed(1)} m above the ground (${s.ground})`,
    'drawn');
    render();
  }

  byId('plan').addEventListener('click', () => plan());
  byId('clear').addEventListener('click', () => {
    waypoints.length = 0;
    markers.clear();
    clearPath();
    say('no waypoints yet', 'idle');
    render();
  });
  say('no waypoints yet: click the mesh', 'idle');

  // What the service holds, and whether it plans in the mesh's CRS at all.
  const info = fetch(`${service}/info`).then(async (response) => {
    const answer = await response.json().catch(() => null);
    if (!response.ok) throw new Error(answer?.error ?? `HTTP ${response.status} ${response.statusText}`);
    return answer;
  });
  return info.then((answer) => {
    const meshEpsg = params.meshCrs?.epsg;
    if (meshEpsg && answer.crs?.epsg && meshEpsg !== answer.crs.epsg) {
      throw new Error(`it plans in EPSG:${answer.crs.epsg}, the mesh is in EPSG:${meshEpsg}`);
    }
  }).then(() => {
    if (params.height !== null) heightField.value = params.height;
    if (!params.clicks) return undefined;
    try {
      for (const xy of params.clicks.split(';')) {
        const [x, y] = xy.split(',').map(Number);
        if (!Number.isFinite(x) || !Number.isFinite(y)) throw new Error(`clicks: '${xy}' is not x,y`);
        clickAbove(x, y);
      }
    } catch (error) {
      return say(error.message, 'error', true);
    }
    return plan();
  }, (error) => say(`planning service: ${error.message}`, 'error', true));
}
