// No-fly zones as translucent prisms (`dsmplan view --no-fly FILE`): each zone of zones.json
// (view_zones.cpp: rings in the mesh's CRS, floor and ceiling) from its floor to its ceiling,
// in dark red when it blocks and amber otherwise (the colours of dsmplan render, picture.hpp),
// outlined, and named by a label over its top.
//
// Heights: a CRS height as it is; an AGL limit on the mesh's surface under each corner (the DSM
// the mesh was made from, as `dsmplan plan` counts AGL without a DTM), the mesh's lowest point
// where a corner is off the mesh; an unlimited floor at the mesh's lowest point, an unlimited
// ceiling 120 m above its highest (the open category's ceiling over the tallest roof).
// For scripts and tests, #zones lists every prism drawn with its figures, taken from the
// corners drawn: data-floor-min/max, data-ceiling-min/max (CRS heights), data-thickness-min/max
// (ceiling less floor at a corner), data-corners, data-blocks, data-first-corner (x,y,floor,ceiling).
import * as THREE from 'three';

const BLOCKING = 0xcc0000;
const OTHER = 0xe68c00;
export const UNLIMITED_CEILING_ABOVE_TOP = 120;

// The mesh's surface as a function of x, y (node-local, the CRS less the origin): its triangles
// binned on a grid over x, y once, so that each corner asks a few triangles, not all of them.
export function surfaceOf(surfaces, node) {
  const triangles = [];
  const a = new THREE.Vector3();
  for (const object of surfaces) {
    const position = object.geometry.getAttribute('position');
    const index = object.geometry.index;
    const toNode = object === node ? new THREE.Matrix4() : object.matrix;
    const count = index ? index.count : position.count;
    for (let i = 0; i + 2 < count; i += 3) {
      const t = [];
      for (let k = 0; k < 3; ++k) {
        a.fromBufferAttribute(position, index ? index.getX(i + k) : i + k).applyMatrix4(toNode);
        t.push(a.x, a.y, a.z);
      }
      triangles.push(t);
    }
  }
  const box = new THREE.Box2();
  for (const t of triangles) for (let k = 0; k < 9; k += 3) box.expandByPoint(new THREE.Vector2(t[k], t[k + 1]));
  const size = box.getSize(new THREE.Vector2());
  const n = Math.max(1, Math.ceil(Math.sqrt(triangles.length / 4)));
  const cell = Math.max(size.x, size.y, 1e-9) / n;
  const bins = new Map();
  const bin = (x, y) => Math.floor((x - box.min.x) / cell) * (n + 1) + Math.floor((y - box.min.y) / cell);
  triangles.forEach((t, i) => {
    const [x0, x1] = [Math.min(t[0], t[3], t[6]), Math.max(t[0], t[3], t[6])];
    const [y0, y1] = [Math.min(t[1], t[4], t[7]), Math.max(t[1], t[4], t[7])];
    for (let x = Math.floor((x0 - box.min.x) / cell); x <= Math.floor((x1 - box.min.x) / cell); ++x) {
      for (let y = Math.floor((y0 - box.min.y) / cell); y <= Math.floor((y1 - box.min.y) / cell); ++y) {
        const key = x * (n + 1) + y;
        if (!bins.has(key)) bins.set(key, []);
        bins.get(key).push(i);
      }
    }
  });
  // The highest triangle over (x, y), or NaN off the mesh.
  return (x, y) => {
    let z = NaN;
    for (const i of bins.get(bin(x, y)) ?? []) {
      const t = triangles[i];
      const d = (t[4] - t[7]) * (t[0] - t[6]) + (t[6] - t[3]) * (t[1] - t[7]);
      if (d === 0) continue;
      const u = ((t[4] - t[7]) * (x - t[6]) + (t[6] - t[3]) * (y - t[7])) / d;
      const v = ((t[7] - t[1]) * (x - t[6]) + (t[0] - t[6]) * (y - t[7])) / d;
      const e = -1e-9;
      if (u < e || v < e || u + v > 1 - e) continue;
      const h = u * t[2] + v * t[5] + (1 - u - v) * t[8];
      if (!(h <= z)) z = h;
    }
    return z;
  };
}

// A caption on a canvas, as a sprite `height` high (metres), always facing the camera.
function label(text, colour, height) {
  const canvas = document.createElement('canvas');
  const context = canvas.getContext('2d');
  const font = 'bold 40px sans-serif';
  context.font = font;
  canvas.width = Math.ceil(context.measureText(text).width) + 24;
  canvas.height = 56;
  context.font = font;
  context.fillStyle = 'rgba(255, 255, 255, 0.85)';
  context.fillRect(0, 0, canvas.width, canvas.height);
  context.fillStyle = `#${colour.toString(16).padStart(6, '0')}`;
  context.textBaseline = 'middle';
  context.fillText(text, 12, canvas.height / 2);
  const sprite = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(canvas), depthTest: false }));
  sprite.scale.set((height * canvas.width) / canvas.height, height, 1);
  sprite.renderOrder = 2;
  return sprite;
}

// Every zone as a prism in the mesh node's frame; returns the group (added to `node`).
export function drawZones({ zones, node, origin, surfaceAt, low, high, labelHeight }) {
  const group = new THREE.Group();
  const list = document.getElementById('zones');
  const top = high + UNLIMITED_CEILING_ABOVE_TOP;
  const at = (limit, x, y, floor) => {
    if (limit.reference === 'crs') return limit.height;
    if (limit.reference === 'ground') {
      const ground = surfaceAt(x - origin.x, y - origin.y) + origin.z;
      return (Number.isFinite(ground) ? ground : low) + limit.height;
    }
    return floor ? low : top;
  };
  zones.forEach((zone) => {
    const colour = zone.blocks ? BLOCKING : OTHER;
    // Each ring's corners with their floor and ceiling, node-local.
    const rings = zone.rings.map((ring) => ring.map(([x, y]) => ({
      x: x - origin.x, y: y - origin.y,
      floor: at(zone.floor, x, y, true) - origin.z, ceiling: at(zone.ceiling, x, y, false) - origin.z,
    })));
    const positions = [];
    const lines = [];
    const push = (out, c, z) => out.push(c.x, c.y, z);
    for (const ring of rings) {
      ring.forEach((c, k) => {
        const d = ring[(k + 1) % ring.length];
        for (const [p, zp] of [[c, c.floor], [d, d.floor], [d, d.ceiling], [c, c.floor], [d, d.ceiling], [c, c.ceiling]]) {
          push(positions, p, zp);
        }
        for (const [p, zp] of [[c, c.floor], [c, c.ceiling], [c, c.floor], [d, d.floor], [c, c.ceiling], [d, d.ceiling]]) {
          push(lines, p, zp);
        }
      });
    }
    // The caps: the outer ring with its holes, triangulated on x, y.
    const flat = rings.map((ring) => ring.map((c) => new THREE.Vector2(c.x, c.y)));
    const corners = rings.flat();
    for (const face of THREE.ShapeUtils.triangulateShape(flat[0], flat.slice(1))) {
      for (const key of ['floor', 'ceiling']) for (const i of face) push(positions, corners[i], corners[i][key]);
    }
    const walls = new THREE.BufferGeometry();
    walls.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
    const prism = new THREE.Mesh(walls, new THREE.MeshBasicMaterial({
      color: colour, transparent: true, opacity: 0.22, side: THREE.DoubleSide, depthWrite: false,
    }));
    prism.renderOrder = 1;  // after the opaque mesh, so that the roofs show through
    const outline = new THREE.BufferGeometry();
    outline.setAttribute('position', new THREE.Float32BufferAttribute(lines, 3));
    const zoneGroup = new THREE.Group();
    zoneGroup.name = zone.caption;
    zoneGroup.add(prism, new THREE.LineSegments(outline, new THREE.LineBasicMaterial({ color: colour })));
    const box = new THREE.Box2().setFromPoints(flat[0]);
    const centre = box.getCenter(new THREE.Vector2());
    const ceiling = Math.max(...rings[0].map((c) => c.ceiling));
    const caption = label(zone.caption, colour, labelHeight);
    caption.position.set(centre.x, centre.y, ceiling + labelHeight);
    zoneGroup.add(caption);
    group.add(zoneGroup);

    // What was drawn, in CRS heights, for scripts and tests.
    const item = document.createElement('li');
    item.textContent = `${zone.caption}: ${zone.label}`;
    const span = (values) => [Math.min(...values), Math.max(...values)].map((v) => String(v + origin.z));
    const [floorMin, floorMax] = span(corners.map((c) => c.floor));
    const [ceilingMin, ceilingMax] = span(corners.map((c) => c.ceiling));
    const thickness = corners.map((c) => c.ceiling - c.floor);
    Object.assign(item.dataset, {
      caption: zone.caption, blocks: zone.blocks, corners: corners.length, rings: rings.length,
      floorMin, floorMax, ceilingMin, ceilingMax,
      thicknessMin: Math.min(...thickness), thicknessMax: Math.max(...thickness),
      firstCorner: [corners[0].x + origin.x, corners[0].y + origin.y, corners[0].floor + origin.z,
        corners[0].ceiling + origin.z].join(','),
    });
    list.appendChild(item);
  });
  node.add(group);
  return group;
}
