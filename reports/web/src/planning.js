// Planning viewer: anatomy (surface voxels), the robot's tubes with their diameters along the path (slider + play),
// the tip trajectory, the goal with its tolerance, collisions in red, and the friction band (ghost shapes).
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { readData, h, fmt, publish, header, DEG } from './common.js';

const d = readData();
const app = document.getElementById('app');
const N = d.waypoints;
const nt = d.tubes.length;
const t0 = performance.now();

// Layout: viewport + side panel + controls.
const view = h('div', { class: 'viewport', id: 'viewport' });
const slider = h('input', { type: 'range', min: 0, max: Math.max(0, N - 1), value: 0, step: 1, id: 'waypoint-slider', 'aria-label': 'waypoint' });
const play = h('button', { id: 'play', type: 'button' }, '▶ play');
const label = h('span', { class: 'wp-label', id: 'wp-label' });
const status = h('div', { class: 'wp-status', id: 'wp-status' });
const cfgBox = h('div', { class: 'wp-config', id: 'wp-config' });
const chkAnat = h('input', { type: 'checkbox', checked: true, id: 'show-anatomy' });
const chkBand = h('input', { type: 'checkbox', checked: true, id: 'show-band' });
const chkCut = h('input', { type: 'checkbox', checked: true, id: 'cutaway' });
const opacity = h('input', { type: 'range', min: 5, max: 100, value: 100, id: 'anatomy-opacity' });
const resetBtn = h('button', { type: 'button', id: 'reset-view' }, 'frame robot');
const wholeBtn = h('button', { type: 'button', id: 'whole-view' }, 'whole anatomy');
const info = d.info || {};
const solvedText = info.solved === undefined ? '' : info.solved ? 'solved' : 'not solved';
const panel = h('aside', { class: 'side card' },
  h('h2', {}, 'Path'),
  h('p', {}, `${N} waypoints; robot ${d.robot}; anatomy ${d.environment}` + (solvedText ? `; ${solvedText}` : '')),
  h('p', {}, `${d.collisions} waypoints in collision, ${d.failures} not converged; friction μ′ = ${fmt(d.friction.boundary)}`),
  info.replay ? h('p', {}, `replay: tip error ${fmt(info.replay.tip_error * 1e3)} mm, min clearance ${fmt(info.replay.min_clearance * 1e3)} mm, ${info.replay.snaps} snaps`) : null,
  h('p', { class: 'note' }, `Anatomy: ${d.voxel_info.drawn} surface voxels drawn of ${d.voxel_info.occupied_leaves} occupied leaves` +
    (d.voxel_info.coarsening > 1 ? ` (coarsened ×${d.voxel_info.coarsening})` : '') + `; map resolution ${fmt(d.voxel_info.resolution * 1e3)} mm.`),
  h('h3', {}, 'Legend'),
  h('ul', { class: 'legend' },
    d.tubes.map((t, i) => h('li', {}, h('span', { class: 'sw', style: `background:${tubeColor(i)}` }), `tube ${i + 1}, Ø ${fmt(t.outer_diameter * 1e3)} mm`)),
    h('li', {}, h('span', { class: 'sw', style: 'background:#e0201b' }), 'collision / invalid'),
    h('li', {}, h('span', { class: 'sw', style: 'background:#1a9850' }), 'goal and tolerance'),
    h('li', {}, h('span', { class: 'sw', style: 'background:#555' }), 'tip trajectory'),
    d.bands.length ? h('li', {}, h('span', { class: 'sw', style: 'background:#7b3294' }), 'friction band (ghost shapes)') : null),
  h('h3', {}, 'Waypoint'), label, status, cfgBox,
  h('h3', {}, 'Display'),
  h('label', {}, chkAnat, ' anatomy'), h('label', { title: 'Hide the anatomy between the camera and the robot or its tip path (and just around them)' }, chkCut, ' cut away around the robot'),
  h('label', {}, ' opacity ', opacity),
  d.bands.length ? h('label', {}, chkBand, ' friction band') : null, h('div', { class: 'view-buttons' }, resetBtn, ' ', wholeBtn),
  h('p', { class: 'note' }, 'Drag to orbit, right-drag to pan, wheel to zoom. Keys ← → step through the path.'));
app.appendChild(header(d.title || 'Planning viewer', `${d.robot} in ${d.environment} — mode ${d.mode}`));
app.appendChild(h('div', { class: 'viewer' }, h('div', { class: 'view-col' }, view, h('div', { class: 'controls' }, play, slider)), panel));

function tubeColor(i) { return ['#4a7fb5', '#e8a33d', '#5fb35f', '#a05fb3', '#b35f5f'][i % 5]; }

// Scene.
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.localClippingEnabled = true;
renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
renderer.setClearColor(0x000000, 0);  // render targets (the cutaway pass); the scene has its own background
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f5f7);
scene.add(new THREE.HemisphereLight(0xffffff, 0x8899aa, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(40, 1, 1e-4, 10);
camera.up.set(0, 0, 1);  // before the controls are made: their orbit axis is the camera's up
scene.add(camera);
camera.add(sun);
sun.position.set(0.3, 0.5, 1);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;

// Bounds of the robot path (+ goal).
const lo = new THREE.Vector3(...d.bounds.lo), hi = new THREE.Vector3(...d.bounds.hi);
const size = Math.max(hi.clone().sub(lo).length(), 0.03);
const vox = d.voxels;
const nv = vox.length / 4;
const tips = d.shapes.map((p) => (p.length >= 3 ? [p[p.length - 3], p[p.length - 2], p[p.length - 1]] : [0, 0, 0]));

// The first view frames the robot's backbone at the first and the last waypoint, the tip path and the goal.
const framePts = [];
for (const k of new Set([0, N - 1])) framePts.push(...pointsOf(d.shapes[k]));
for (const t of tips) framePts.push(new THREE.Vector3(...t));
if (d.goal) framePts.push(new THREE.Vector3(...d.goal.position));
if (!framePts.length) framePts.push(lo.clone(), hi.clone());
// The anatomy's extent (the "whole anatomy" view).
const anatLo = lo.clone(), anatHi = hi.clone();
for (let k = 0; k < nv; ++k) {
  const h2 = vox[4 * k + 3] / 2;
  for (let c = 0; c < 3; ++c) {
    anatLo.setComponent(c, Math.min(anatLo.getComponent(c), vox[4 * k + c] - h2));
    anatHi.setComponent(c, Math.max(anatHi.getComponent(c), vox[4 * k + c] + h2));
  }
}
const anatSize = Math.max(size, anatHi.clone().sub(anatLo).length());
camera.near = size / 500; camera.far = anatSize * 20; camera.updateProjectionMatrix();

// Anatomy cells on a hash grid (cell: the smallest drawn voxel), to count what lies between a camera and the robot.
const occ = (() => {
  let cell = Infinity;
  for (let k = 0; k < nv; ++k) cell = Math.min(cell, vox[4 * k + 3]);
  if (!(cell > 0 && Number.isFinite(cell))) return null;
  const key = (i, j, l) => ((i + 65536) * 131072 + (j + 65536)) * 131072 + (l + 65536);
  const cells = new Set();
  for (let k = 0; k < nv; ++k) {
    const s = vox[4 * k + 3], m = Math.min(8, Math.max(1, Math.round(s / cell)));
    for (let a = 0; a < m; ++a) for (let b = 0; b < m; ++b) for (let c = 0; c < m; ++c) {
      cells.add(key(Math.floor((vox[4 * k] + ((a + 0.5) / m - 0.5) * s) / cell),
        Math.floor((vox[4 * k + 1] + ((b + 0.5) / m - 0.5) * s) / cell),
        Math.floor((vox[4 * k + 2] + ((c + 0.5) / m - 0.5) * s) / cell)));
    }
  }
  return { cell, has: (p) => cells.has(key(Math.floor(p.x / cell), Math.floor(p.y / cell), Math.floor(p.z / cell))) };
})();

// Camera basis for a view direction `dir` (unit, from the target towards the camera), up = +z.
function viewBasis(dir) {
  const right = new THREE.Vector3(0, 0, 1).cross(dir);
  if (right.lengthSq() < 1e-9) right.set(1, 0, 0);
  right.normalize();
  return { right, up: dir.clone().cross(right).normalize() };
}
// Spread of the framed points seen along `dir` (sum of the standard deviations in the image plane): larger is a
// more side-on, less foreshortened view of the path.
function spreadAlong(dir) {
  const { right, up } = viewBasis(dir);
  let sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  for (const p of framePts) {
    const x = p.dot(right), y = p.dot(up);
    sx += x; sy += y; sxx += x * x; syy += y * y; sxy += x * y;
  }
  const n = framePts.length;
  const a = sxx / n - (sx / n) ** 2, c = syy / n - (sy / n) ** 2, b = sxy / n - (sx / n) * (sy / n);
  const tr = a + c, det = a * c - b * b, disc = Math.sqrt(Math.max(0, tr * tr / 4 - det));
  return Math.sqrt(Math.max(0, tr / 2 + disc)) + Math.sqrt(Math.max(0, tr / 2 - disc));
}
// Anatomy cells crossed by rays from points of the robot and the path towards a camera at `dist` along `dir`
// (mean per ray; cells within `skip` of the point are not counted: the cutaway removes them anyway).
const rayPts = framePts.filter((p, i) => i % Math.max(1, Math.floor(framePts.length / 96)) === 0);
function occludersAlong(dir, dist, skip) {
  if (!occ) return 0;
  const step = Math.max(occ.cell, dist / 600);
  let n = 0;
  const q = new THREE.Vector3();
  for (const p of rayPts)
    for (let t = skip; t < dist; t += step) if (occ.has(q.copy(p).addScaledVector(dir, t))) ++n;
  return n / rayPts.length;
}
// Candidate directions: the cube's faces, edges and corners (not straight along ±z, the orbit axis). Among the
// side-on ones (spread >= 60 % of the best), the one with the fewest anatomy cells in front of the robot and path.
const cutRadius = Math.max(4 * Math.max(...d.tubes.map((t) => t.outer_diameter)), 0.04 * size);
function chooseView() {
  const c = [];
  for (let x = -1; x <= 1; ++x) for (let y = -1; y <= 1; ++y) for (let z = -1; z <= 1; ++z)
    if ((x || y) && (x || y || z)) c.push(new THREE.Vector3(x, y, z).normalize());
  const scored = c.map((dir) => ({ dir, spread: spreadAlong(dir) }));
  const best = Math.max(...scored.map((s) => s.spread));
  const side = scored.filter((s) => s.spread >= 0.6 * best);
  for (const s of side) s.occluders = occludersAlong(s.dir, 1.5 * size, cutRadius);
  side.sort((a, b) => a.occluders - b.occluders || b.spread - a.spread);
  return side[0];
}
// Puts the camera on `dir` so that every point is in view with a margin.
function frameOn(points, dir, margin = 1.12) {
  const { right, up } = viewBasis(dir);
  const bmin = new THREE.Vector3(Infinity, Infinity, Infinity), bmax = bmin.clone().negate();
  for (const p of points) { bmin.min(p); bmax.max(p); }
  const c0 = bmin.clone().add(bmax).multiplyScalar(0.5);
  let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
  for (const p of points) {
    const x = p.clone().sub(c0).dot(right), y = p.clone().sub(c0).dot(up);
    x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y);
  }
  const target = c0.clone().addScaledVector(right, (x0 + x1) / 2).addScaledVector(up, (y0 + y1) / 2);
  const tv = Math.tan((camera.fov * Math.PI) / 360), th = tv * camera.aspect;
  let dist = 0;
  for (const p of points) {
    const q = p.clone().sub(target);
    dist = Math.max(dist, (margin * Math.abs(q.dot(right))) / th + q.dot(dir), (margin * Math.abs(q.dot(up))) / tv + q.dot(dir));
  }
  dist = Math.max(dist, size / 20);
  camera.position.copy(target).addScaledVector(dir, dist);
  controls.target.copy(target);
  controls.update();
}
let firstView = null;
function frame() {
  const t = performance.now();
  if (!firstView) firstView = chooseView();
  frameOn(framePts, firstView.dir);
  firstView.ms = firstView.ms || performance.now() - t;
}
function frameAnatomy() {
  const pts = [];
  for (let k = 0; k < 8; ++k)
    pts.push(new THREE.Vector3(k & 1 ? anatHi.x : anatLo.x, k & 2 ? anatHi.y : anatLo.y, k & 4 ? anatHi.z : anatLo.z));
  frameOn(pts, camera.position.clone().sub(controls.target).normalize(), 1.02);
}

// Anatomy: surface voxels as one instanced mesh. Opaque by default (cheap: hidden voxels are depth-rejected); the
// opacity slider makes it translucent.
// Cutaway, following the camera: (1) a clipping plane facing the camera hides the anatomy nearer than the robot, its
// tip path and the goal (less `cutRadius`): the outer wall of a chamber; (2) what lies in front of the robot and the
// path as seen from the camera, or within `cutRadius` of them, is not drawn: a first pass draws the far side of "halo"
// spheres (radius cutRadius) strung along the robot and the path into a texture (packed depth, 0 where there is no
// halo), and the anatomy's fragment shader discards fragments nearer than it. The rest stays as context.
const cutPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 0);
const cutTarget = new THREE.WebGLRenderTarget(1, 1, { minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter });
const cut = { cutTex: { value: cutTarget.texture }, cutSize: { value: new THREE.Vector2(1, 1) }, cutOn: { value: 1 } };
const anatMat = new THREE.MeshLambertMaterial({ color: 0xc9706b, transparent: false, opacity: 1, depthWrite: true,
  clippingPlanes: [cutPlane], side: THREE.DoubleSide });
function updateCut() {
  const fwd = camera.getWorldDirection(new THREE.Vector3());
  let near = Infinity;
  const q = new THREE.Vector3();
  for (const p of rayPts) near = Math.min(near, q.copy(p).sub(camera.position).dot(fwd));
  for (const p of robotPts) near = Math.min(near, q.copy(p).sub(camera.position).dot(fwd));
  cutPlane.setFromNormalAndCoplanarPoint(fwd, camera.position.clone().addScaledVector(fwd, near - cutRadius));
  if ((anatMat.clippingPlanes.length > 0) !== chkCut.checked) {
    anatMat.clippingPlanes = chkCut.checked ? [cutPlane] : [];
    anatMat.needsUpdate = true;
  }
}
anatMat.onBeforeCompile = (sh) => {
  Object.assign(sh.uniforms, cut);
  sh.fragmentShader = 'uniform sampler2D cutTex;\nuniform vec2 cutSize;\nuniform float cutOn;\n' +
    sh.fragmentShader.replace('#include <clipping_planes_fragment>', '#include <clipping_planes_fragment>\n' +
      '  if (cutOn > 0.5 && gl_FragCoord.z < unpackRGBAToDepth(texture2D(cutTex, gl_FragCoord.xy / cutSize))) discard;')
    // Inner faces (seen where the cut opens a voxel, or through translucent anatomy) darker: the cut reads as a section.
    .replace('#include <color_fragment>', '#include <color_fragment>\n  if (!gl_FrontFacing) diffuseColor.rgb *= 0.55;');
};
const anatomy = new THREE.InstancedMesh(new THREE.BoxGeometry(1, 1, 1), anatMat, Math.max(1, nv));
{
  const m = new THREE.Matrix4();
  for (let k = 0; k < nv; ++k) {
    const s = vox[4 * k + 3];
    m.makeScale(s, s, s).setPosition(vox[4 * k], vox[4 * k + 1], vox[4 * k + 2]);
    anatomy.setMatrixAt(k, m);
  }
  anatomy.count = nv;
  anatomy.instanceMatrix.needsUpdate = true;
  anatomy.renderOrder = 2;
}
scene.add(anatomy);
const haloScene = new THREE.Scene();
const haloMat = new THREE.ShaderMaterial({
  side: THREE.BackSide,
  vertexShader: '#include <common>\nvoid main() {\n#include <begin_vertex>\n#include <project_vertex>\n}',
  fragmentShader: '#include <packing>\nvoid main() { gl_FragColor = packDepthToRGBA(gl_FragCoord.z); }',
});
const haloGeo = new THREE.SphereGeometry(cutRadius, 12, 8);
// Spheres every half radius along a polyline (at most `cap`).
function haloCentres(pts, cap) {
  let len = 0;
  for (let k = 1; k < pts.length; ++k) len += pts[k].distanceTo(pts[k - 1]);
  const step = Math.max(cutRadius / 2, len / cap);
  const out = pts.length ? [pts[0]] : [];
  let acc = 0;
  for (let k = 1; k < pts.length; ++k) {
    const a = pts[k - 1], seg = pts[k].distanceTo(a);
    for (let s = step - acc; s <= seg; s += step) out.push(a.clone().lerp(pts[k], s / seg));
    acc = (acc + seg) % step;
  }
  if (pts.length > 1) out.push(pts[pts.length - 1]);
  return out;
}
function haloMesh(centres, cap) {
  const mesh = new THREE.InstancedMesh(haloGeo, haloMat, cap + 2);
  mesh.frustumCulled = false;
  setHalo(mesh, centres);
  haloScene.add(mesh);
  return mesh;
}
function setHalo(mesh, centres) {
  const m = new THREE.Matrix4();
  const n = Math.min(centres.length, mesh.instanceMatrix.count);
  for (let k = 0; k < n; ++k) mesh.setMatrixAt(k, m.makeTranslation(centres[k].x, centres[k].y, centres[k].z));
  mesh.count = n;
  mesh.instanceMatrix.needsUpdate = true;
}
haloMesh(haloCentres(tips.map((t) => new THREE.Vector3(...t)), 300), 300);
const robotHalo = haloMesh([], 200);
if (d.goal) haloMesh([new THREE.Vector3(...d.goal.position)], 1);

// Goal.
if (d.goal) {
  const g = new THREE.Vector3(...d.goal.position);
  const r = Math.max(d.goal.tolerance, size / 400);
  const tol = new THREE.Mesh(new THREE.SphereGeometry(r, 32, 16), new THREE.MeshLambertMaterial({ color: 0x1a9850, transparent: true, opacity: 0.3, depthWrite: false }));
  tol.position.copy(g);
  const dot = new THREE.Mesh(new THREE.SphereGeometry(r * 0.2, 16, 8), new THREE.MeshLambertMaterial({ color: 0x1a9850 }));
  dot.position.copy(g);
  scene.add(tol, dot);
}

// Tip trajectory, coloured red where the waypoint is invalid.
{
  const pos = new Float32Array(N * 3), col = new Float32Array(N * 3);
  for (let k = 0; k < N; ++k) {
    pos.set(tips[k], 3 * k);
    col.set(d.valid[k] ? [0.25, 0.25, 0.25] : [0.88, 0.12, 0.1], 3 * k);
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  g.setAttribute('color', new THREE.BufferAttribute(col, 3));
  scene.add(new THREE.Line(g, new THREE.LineBasicMaterial({ vertexColors: true })));
}
// Base marker (where the tubes leave the actuation unit).
{
  const b = new THREE.Mesh(new THREE.SphereGeometry(size / 150, 16, 8), new THREE.MeshLambertMaterial({ color: 0x333333 }));
  b.position.set(...d.base.origin);
  scene.add(b);
}

// Robot: one tube mesh per tube, rebuilt for the current waypoint.
const tubeMats = d.tubes.map((t, i) => new THREE.MeshPhongMaterial({ color: tubeColor(i), shininess: 60 }));
const badMat = new THREE.MeshPhongMaterial({ color: 0xe0201b, shininess: 30, emissive: 0x400000 });
const robot = new THREE.Group();
scene.add(robot);
const tipMarker = new THREE.Mesh(new THREE.SphereGeometry(1, 16, 8), new THREE.MeshLambertMaterial({ color: 0x111111 }));
scene.add(tipMarker);

function pointsOf(flat) {
  const out = [];
  for (let k = 0; k + 2 < flat.length; k += 3) out.push(new THREE.Vector3(flat[k], flat[k + 1], flat[k + 2]));
  return out;
}
// Points of a shape from arc length 0 to `end` (interpolated at the end).
function upTo(pts, len, end) {
  const m = pts.length;
  if (m < 2 || !(len > 0)) return pts;
  const out = [];
  for (let k = 0; k < m; ++k) {
    const s = (len * k) / (m - 1);
    if (s <= end + 1e-9) { out.push(pts[k]); continue; }
    const s0 = (len * (k - 1)) / (m - 1);
    const f = (end - s0) / (s - s0);
    if (k > 0 && f > 1e-3) out.push(pts[k - 1].clone().lerp(pts[k], f));
    break;
  }
  // Drop coincident points: a zero-length span makes the centripetal spline (and so the tube mesh) degenerate.
  const clean = [];
  for (const p of out) if (!clean.length || p.distanceTo(clean[clean.length - 1]) > 1e-6) clean.push(p);
  return clean;
}
let current = -1;
let robotPts = [];
let geometrySignature = 0;
function showWaypoint(k) {
  k = Math.max(0, Math.min(N - 1, Math.round(k)));
  current = k;
  for (const c of robot.children) c.geometry.dispose();
  robot.clear();
  const pts = pointsOf(d.shapes[k]);
  const len = d.lengths[k];
  const ok = !!d.valid[k];
  geometrySignature = 0;
  for (let i = 0; i < nt; ++i) {
    const seg = upTo(pts, len, d.ends[k][i]);
    if (seg.length < 2) continue;
    const curve = new THREE.CatmullRomCurve3(seg, false, 'centripetal');
    const r = d.tubes[i].outer_diameter / 2;
    const geo = new THREE.TubeGeometry(curve, Math.max(8, seg.length * 2), r, 14, false);
    const mesh = new THREE.Mesh(geo, ok ? tubeMats[i] : badMat);
    mesh.name = `tube-${i + 1}`;
    robot.add(mesh);
    const p = geo.attributes.position.array;
    for (let q = 0; q < p.length; q += 97) geometrySignature += p[q];
  }
  robotPts = upTo(pts, len, Math.max(...d.ends[k]));
  setHalo(robotHalo, haloCentres(robotPts, 200));
  const tip = pts[pts.length - 1];
  if (tip) {
    tipMarker.position.copy(tip);
    tipMarker.scale.setScalar(d.tubes[nt - 1].outer_diameter * 0.9);
  }
  updateBand(k);
  slider.value = String(k);
  label.textContent = `waypoint ${k} of ${N - 1}`;
  const reason = d.reasons[String(k)];
  status.textContent = ok ? 'valid: converged, stable, collision-free' : `invalid: ${reason || ''}`;
  status.className = 'wp-status ' + (ok ? 'ok' : 'bad');
  const q = d.configurations[k];
  cfgBox.textContent = 'α (deg): ' + q.slice(0, nt).map((v) => fmt(v * DEG, 3)).join(', ') +
    '\nβ (mm): ' + q.slice(nt).map((v) => fmt(v * 1e3, 4)).join(', ');
  render();
}

// Friction band: ghost shapes of the nearest waypoint where it was computed.
const bandGroup = new THREE.Group();
scene.add(bandGroup);
const bandMat = new THREE.LineBasicMaterial({ color: 0x7b3294, transparent: true, opacity: 0.55 });
const bandSpacing = d.bands.length > 1 ? (N - 1) / (d.bands.length - 1) : N;
let bandShown = -1;
function updateBand(k) {
  let best = null;
  for (const b of d.bands) if (!best || Math.abs(b.waypoint - k) < Math.abs(best.waypoint - k)) best = b;
  const show = best && chkBand.checked && Math.abs(best.waypoint - k) <= Math.max(1, bandSpacing / 2);
  if (!show) { bandGroup.visible = false; return; }
  bandGroup.visible = true;
  if (bandShown === best.waypoint) return;
  bandShown = best.waypoint;
  for (const c of bandGroup.children) c.geometry.dispose();
  bandGroup.clear();
  for (const s of best.shapes) bandGroup.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints(pointsOf(s)), bandMat));
  status.title = `friction band of waypoint ${best.waypoint}: tip spread ${fmt(best.tip_spread * 1e3)} mm`;
}

function resize() {
  const w = view.clientWidth || 800, hgt = view.clientHeight || 600;
  renderer.setSize(w, hgt, false);
  const db = renderer.getDrawingBufferSize(new THREE.Vector2());
  cutTarget.setSize(db.x, db.y);
  cut.cutSize.value.copy(db);
  renderer.domElement.style.width = '100%';
  renderer.domElement.style.height = '100%';
  camera.aspect = w / hgt;
  camera.updateProjectionMatrix();
  render();
}
let frames = 0;
// Renders at most once per animation frame (slider drags and playback request many updates).
let pending = false;
function draw() {
  pending = false;
  cut.cutOn.value = chkCut.checked ? 1 : 0;
  updateCut();
  if (chkCut.checked && anatomy.visible) {
    camera.updateMatrixWorld();
    renderer.setRenderTarget(cutTarget);
    renderer.render(haloScene, camera);
    renderer.setRenderTarget(null);
  }
  renderer.render(scene, camera);
  ++frames;
}
function render() {
  if (pending) return;
  pending = true;
  requestAnimationFrame(draw);
}
controls.addEventListener('change', render);
window.addEventListener('resize', resize);

slider.addEventListener('input', () => showWaypoint(Number(slider.value)));
let playing = false, last = 0, acc = 0;
const speed = Math.max(10, N / 12);  // waypoints per second: a whole path in about 12 s
function tick(t) {
  if (!playing) return;
  const dt = last ? (t - last) / 1000 : 0;
  last = t;
  acc += dt * speed;
  if (acc >= 1) {
    const next = current + Math.floor(acc);
    acc -= Math.floor(acc);
    if (next >= N - 1) { showWaypoint(N - 1); setPlaying(false); return; }
    showWaypoint(next);
  }
  requestAnimationFrame(tick);
}
function setPlaying(p) {
  playing = p;
  play.textContent = p ? '❚❚ pause' : '▶ play';
  if (p) { if (current >= N - 1) showWaypoint(0); last = 0; acc = 0; requestAnimationFrame(tick); }
}
play.addEventListener('click', () => setPlaying(!playing));
window.addEventListener('keydown', (e) => {
  if (e.key === 'ArrowRight') showWaypoint(current + 1);
  if (e.key === 'ArrowLeft') showWaypoint(current - 1);
});
chkAnat.addEventListener('change', () => { anatomy.visible = chkAnat.checked; render(); });
chkCut.addEventListener('change', render);
chkBand.addEventListener('change', () => { bandShown = -1; updateBand(current); render(); });
opacity.addEventListener('input', () => {
  anatMat.opacity = Number(opacity.value) / 100;
  const solid = anatMat.opacity > 0.97;
  if (anatMat.transparent === solid) { anatMat.transparent = !solid; anatMat.depthWrite = solid; anatMat.needsUpdate = true; }
  render();
});
// "frame robot": the first view again (cutaway on); "whole anatomy": all of it from the current side (cutaway off).
resetBtn.addEventListener('click', () => { chkCut.checked = true; frame(); render(); });
wholeBtn.addEventListener('click', () => { chkCut.checked = false; frameAnatomy(); render(); });

// First view: the robot at the last waypoint (at the goal, when the plan solved) with its whole path, framed.
resize();
frame();
showWaypoint(N - 1);
draw();
const loadMs = performance.now() - t0;
publish('planning', {
  waypoints: N,
  voxels: nv,
  loadMs,
  frames: () => frames,
  nextFrame: () => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(() => r(frames)))),
  current: () => current,
  setWaypoint: (k) => { showWaypoint(k); return current; },
  robotSignature: () => geometrySignature,
  robotMeshes: () => robot.children.length,
  robotMaterials: () => robot.children.map((c) => (c.material === badMat ? 'collision' : 'ok')),
  bandVisible: () => bandGroup.visible && bandGroup.children.length,
  bands: d.bands.map((b) => b.waypoint),
  firstView: { waypoint: N - 1, direction: firstView.dir.toArray(), spread: firstView.spread,
    occluders: firstView.occluders, ms: firstView.ms, cutRadius },
  tubeColors: d.tubes.map((t, i) => tubeColor(i)),
  tubeCount: nt,
});
