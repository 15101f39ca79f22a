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
  h('label', {}, chkAnat, ' anatomy'), h('label', { title: 'Hide the anatomy between the camera and the robot' }, chkCut, ' cut away the near side'),
  h('label', {}, ' opacity ', opacity),
  d.bands.length ? h('label', {}, chkBand, ' friction band') : null, resetBtn,
  h('p', { class: 'note' }, 'Drag to orbit, right-drag to pan, wheel to zoom. Keys ← → step through the path.'));
app.appendChild(header(d.title || 'Planning viewer', `${d.robot} in ${d.environment} — mode ${d.mode}`));
app.appendChild(h('div', { class: 'viewer' }, h('div', { class: 'view-col' }, view, h('div', { class: 'controls' }, play, slider)), panel));

function tubeColor(i) { return ['#4a7fb5', '#e8a33d', '#5fb35f', '#a05fb3', '#b35f5f'][i % 5]; }

// Scene.
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.localClippingEnabled = true;
renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
view.appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f5f7);
scene.add(new THREE.HemisphereLight(0xffffff, 0x8899aa, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(40, 1, 1e-4, 10);
scene.add(camera);
camera.add(sun);
sun.position.set(0.3, 0.5, 1);
const controls = new OrbitControls(camera, renderer.domElement);
controls.enableDamping = false;

// Bounds of the robot path (+ goal) for framing.
const lo = new THREE.Vector3(...d.bounds.lo), hi = new THREE.Vector3(...d.bounds.hi);
const center = lo.clone().add(hi).multiplyScalar(0.5);
const size = Math.max(hi.clone().sub(lo).length(), 0.03);
camera.near = size / 500; camera.far = size * 200; camera.updateProjectionMatrix();
function frame() {
  const base = new THREE.Vector3(...d.base.z).normalize();
  // Look from the side of the insertion axis, slightly from above.
  let side = new THREE.Vector3(0, 0, 1).cross(base);
  if (side.lengthSq() < 1e-6) side = new THREE.Vector3(1, 0, 0);
  side.normalize();
  const dir = side.multiplyScalar(1).add(base.clone().multiplyScalar(-0.35)).add(new THREE.Vector3(0, 0, 0.45)).normalize();
  camera.position.copy(center.clone().add(dir.multiplyScalar(size * 1.5)));
  camera.up.set(0, 0, 1);
  controls.target.copy(center);
  controls.update();
}

// Anatomy: surface voxels as one instanced mesh.
const vox = d.voxels;
const nv = vox.length / 4;
// Cutaway: a clipping plane through the path's centre, facing the camera, hides the anatomy on the near side.
const cutPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 0);
// Opaque by default (cheap: hidden voxels are depth-rejected); the opacity slider makes it translucent.
const anatMat = new THREE.MeshLambertMaterial({ color: 0xc9706b, transparent: false, opacity: 1, depthWrite: true,
  clippingPlanes: [cutPlane], side: THREE.DoubleSide });
function updateCut() {
  const n = camera.position.clone().sub(center).normalize().negate();
  // Keep points p with n.p + c >= 0, i.e. behind the centre (+ a margin of a tenth of the view size) as seen from the camera.
  cutPlane.setFromNormalAndCoplanarPoint(n, center.clone().addScaledVector(n, -0.1 * size));
  if ((anatMat.clippingPlanes.length > 0) !== chkCut.checked) {
    anatMat.clippingPlanes = chkCut.checked ? [cutPlane] : [];
    anatMat.needsUpdate = true;
  }
}
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
const tips = d.shapes.map((p) => (p.length >= 3 ? [p[p.length - 3], p[p.length - 2], p[p.length - 1]] : [0, 0, 0]));
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
  renderer.domElement.style.width = '100%';
  renderer.domElement.style.height = '100%';
  camera.aspect = w / hgt;
  camera.updateProjectionMatrix();
  render();
}
let frames = 0;
// Renders at most once per animation frame (slider drags and playback request many updates).
let pending = false;
function draw() { pending = false; updateCut(); renderer.render(scene, camera); ++frames; }
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
resetBtn.addEventListener('click', () => { frame(); render(); });

frame();
resize();
showWaypoint(0);
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
});
