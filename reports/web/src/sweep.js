// Sweep report: tip twist and tip position vs the swept angle in both directions (friction band shaded),
// and the stability measure.
import { readData, h, fmt, chart, line, publish, header, table, COLORS, PALETTE, DEG } from './common.js';

const d = readData();
const app = document.getElementById('app');
const fr = d.friction || {};
app.appendChild(header(`Sweep of tube ${d.tube} — ${d.robot}`,
  `${d.angle.length} steps; friction: boundary μ′ = ${fmt(fr.boundary)}, distributed μ = ${fmt(fr.distributed)} (${fr.mode || ''})`));

const rows = d.angle.length;
const dirs = [1, -1].filter((s) => d.direction.includes(s));
const unstable = d.stable.reduce((s, v, k) => s + (d.converged[k] && !v ? 1 : 0), 0);
const snaps = d.snapped.reduce((s, v) => s + v, 0);
const failed = d.converged.reduce((s, v) => s + (v ? 0 : 1), 0);
app.appendChild(h('section', { class: 'card', id: 'summary' }, h('h2', {}, 'Summary'),
  table(['steps', 'not converged', 'unstable', 'snaps', 'band angles'], [[String(rows), String(failed), String(unstable), String(snaps), String(d.band.length)]])));

const grid = h('div', { class: 'grid' });
app.appendChild(grid);
const pts = (y, dir, scale) => {
  const out = [];
  for (let k = 0; k < rows; ++k) if (d.direction[k] === dir) out.push({ x: d.angle[k] * DEG, y: y[k] === null ? NaN : y[k] * scale });
  return out;
};
const dirName = (s) => (s > 0 ? 'increasing' : 'decreasing');
const dirColor = (s) => (s > 0 ? COLORS.plus : COLORS.minus);

for (let i = 0; i < d.tubes - 1; ++i) {
  const ds = [];
  if (d.band.length) {
    const bmin = d.band.map((b) => ({ x: b.angle * DEG, y: b.twist_min[i] === null ? NaN : b.twist_min[i] * DEG }));
    const bmax = d.band.map((b) => ({ x: b.angle * DEG, y: b.twist_max[i] === null ? NaN : b.twist_max[i] * DEG }));
    ds.push(line('_band min', bmin, 'rgba(120,120,120,0.5)', { borderWidth: 0.8 }));
    ds.push(line('friction band', bmax, 'rgba(120,120,120,0.5)', { borderWidth: 0.8, fill: '-1', backgroundColor: COLORS.band }));
  }
  for (const s of dirs) ds.push(line(`twist, ${dirName(s)}`, pts(d.twist[i], s, DEG), dirColor(s), { borderWidth: 2 }));
  const snapPts = [];
  for (let k = 0; k < rows; ++k) if (d.snapped[k] && d.twist[i][k] !== null) snapPts.push({ x: d.angle[k] * DEG, y: d.twist[i][k] * DEG });
  if (snapPts.length) ds.push({ label: 'snap', data: snapPts, showLine: false, pointRadius: 5, pointStyle: 'triangle', borderColor: '#d62728', backgroundColor: '#d62728' });
  chart(grid, {
    title: `Tip twist of tube ${i + 2} vs rotation of tube ${d.tube}`, xLabel: `alpha_${d.tube} (deg)`, yLabel: `twist_${i + 2} (deg)`,
    datasets: ds, note: d.band.length ? 'Shaded: the friction band (every equilibrium reachable under some history).' : 'Frictionless: both directions coincide unless the branch snaps.',
  });
}
const tipDs = [];
for (let c = 0; c < 3; ++c)
  for (const s of dirs)
    tipDs.push(line(`tip ${'xyz'[c]}, ${dirName(s)}`, pts(d.tip[c], s, 1e3), PALETTE[c], { borderDash: s > 0 ? [] : [6, 4] }));
chart(grid, { title: 'Tip position vs rotation', xLabel: `alpha_${d.tube} (deg)`, yLabel: 'tip (mm, base frame)', datasets: tipDs,
  note: 'Solid: increasing angle; dashed: decreasing.' });
if (d.band.length) {
  chart(grid, { title: 'Tip spread of the friction band', xLabel: `alpha_${d.tube} (deg)`, yLabel: 'tip spread (mm)',
    datasets: [line('tip spread', d.band.map((b) => ({ x: b.angle * DEG, y: (b.tip_spread ?? NaN) * 1e3 })), PALETTE[4], { pointRadius: 2 })] });
}
const stabDs = dirs.map((s) => line(`stability, ${dirName(s)}`, pts(d.stability, s, 1), dirColor(s), { borderWidth: 2 }));
const un = [];
for (let k = 0; k < rows; ++k) if (d.converged[k] && !d.stable[k]) un.push({ x: d.angle[k] * DEG, y: d.stability[k] });
if (un.length) stabDs.push({ label: 'unstable', data: un, showLine: false, pointRadius: 4, borderColor: '#d62728', backgroundColor: '#d62728' });
const x0 = Math.min(...d.angle) * DEG, x1 = Math.max(...d.angle) * DEG;
stabDs.push(line('_zero', [{ x: x0, y: 0 }, { x: x1, y: 0 }], '#888', { borderDash: [3, 3], borderWidth: 1 }));
chart(grid, { title: 'Stability measure', xLabel: `alpha_${d.tube} (deg)`, yLabel: 'det of the torsional stability Jacobian',
  datasets: stabDs, note: 'Positive: stable equilibrium; it falls to zero at a fold where the robot snaps.' });

publish('sweep', { rows });
