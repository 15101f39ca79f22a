// Diagnosis report: verdict, located mismatch (binned residuals by direction of approach with the noise band),
// measured vs nominal vs fitted curves, candidates with held-out RMSE and BIC, fitted parameters with intervals.
import { readData, h, fmt, unitOf, chart, line, publish, header, table, COLORS, PALETTE, DEG } from './common.js';

const data = readData();
const rep = data.report;
const plot = data.plot;
const app = document.getElementById('app');

const quantities = Object.keys(rep.baseline.heldout_rmse || {});
// The noise of a quantity: {sigma, source, ...} (a number in reports written before the noise carried its source).
const noiseOf = (q) => {
  const n = (rep.noise || {})[q];
  return n == null ? null : (typeof n === 'number' ? n : n.sigma);
};
// RMS of the per-row error norm of pure noise: a position has 3 noisy components, a unit tangent 2.
const noiseNormFactor = (q) => (q === 'twist' ? 1 : q === 'tip_tangent' ? Math.SQRT2 : Math.sqrt(3));

// A parameter is a number or a 3-vector (tip_load force, gravity direction); its interval [lo, hi] or one per
// component.
function valueText(v) {
  return Array.isArray(v) ? `(${v.map((x) => fmt(x)).join(', ')})` : fmt(v);
}
function intervalText(iv) {
  if (!iv) return '';
  return Array.isArray(iv[0]) ? iv.map((x) => `[${fmt(x[0])}, ${fmt(x[1])}]`).join(' ') : `[${fmt(iv[0])}, ${fmt(iv[1])}]`;
}
// An interval with finite bounds: [lo, hi], or one [lo, hi] per component.
function hasInterval(iv) {
  if (!Array.isArray(iv) || !iv.length) return false;
  return (Array.isArray(iv[0]) ? iv : [iv]).every((x) => Array.isArray(x) && x.length === 2 && x.every(Number.isFinite));
}
function paramText(params, intervals) {
  return Object.entries(params || {}).map(([k, v]) => {
    const iv = (intervals || {})[k];
    return `${k} = ${valueText(v)}` + (iv ? ` ${intervalText(iv)}` : '');
  }).join('; ');
}
function rmseText(m) {
  return quantities.map((q) => {
    const u = unitOf(q);
    return `${q}: ${fmt((m || {})[q] * u.scale)}${u.unit ? ' ' + u.unit : ''}`;
  }).join(', ');
}

// Header and verdict.
app.appendChild(header('Diagnosis report',
  `${data.recording_rows} recorded rows (${rep.rows} used, every ${rep.stride}. row), ${data.tubes} tubes, ` +
  `frame: ${rep.frame}, ${rep.folds} held-out blocks, ${rep.replays} replays in ${fmt(rep.seconds, 3)} s`));
const un = rep.unexplained;
const verdict = rep.verdict.length ? rep.verdict.join(' + ') + (un ? ' (partial explanation)' : '')
  : (un ? 'not explained by any candidate' : 'nothing left out');
app.appendChild(h('section', { class: 'card verdict ' + (rep.verdict.length ? 'found' : 'none'), id: 'verdict' },
  h('h2', {}, 'Verdict: ', h('span', { class: 'verdict-name' }, verdict)),
  rep.reliable === false ? h('p', { class: 'warnings' }, 'Unreliable: too many rows could not be evaluated (see below).') : null,
  h('p', {}, rep.summary || ''),
  rep.warnings && rep.warnings.length ? h('ul', { class: 'warnings' }, rep.warnings.map((w) => h('li', {}, w))) : null));

// What the final model leaves unexplained.
if (un) {
  app.appendChild(h('section', { class: 'card', id: 'unexplained' }, h('h2', {}, 'Left unexplained'),
    h('p', {}, `The final model explains ${fmt(100 * un.fraction_explained, 3)} % of the baseline's excess held-out ` +
      `error; ${un.where}. Held-out residuals: ${fmt(un.heldout_ratio, 3)} × the noise variance (p = ${fmt(un.heldout_p, 2)}).`),
    (un.mismatch || []).length ? table(['signature', 'variable', 'quantity', 'p-value', 'where'],
      un.mismatch.slice(0, 12).map((f) => [f.signature, f.variable, f.quantity, fmt(f.p_value, 3), f.where])) : null));
}

// Look-alikes the recording cannot tell apart.
const ties = [];
for (const f of rep.findings) for (const r of (f.ambiguous_with || [])) ties.push([f.effect, r.effect, fmt(r.delta_bic, 4), fmt(r.heldout_p, 2), r.why]);
if (ties.length) {
  app.appendChild(h('section', { class: 'card', id: 'ambiguous' }, h('h2', {}, 'Look-alikes this recording cannot tell apart'),
    table(['accepted', 'rival', 'rival ΔBIC', 'p (accepted better held out)', 'evidence'], ties)));
}

// Rows the model could not evaluate.
if ((rep.failed_rows || []).length) {
  app.appendChild(h('section', { class: 'card', id: 'failed-rows' }, h('h2', {}, `Rows not evaluated (${rep.failed_rows.length})`),
    h('p', { class: 'note' }, 'Excluded from every residual, fit, noise estimate and held-out score; never replaced by another row\'s output.'),
    table(['row', 'model', 'reason'], rep.failed_rows.slice(0, 50).map((r) => [String(r.row), r.model, r.reason]))));
}

// Fitted parameters.
const eff = (rep.final && rep.final.effects) || [];
if (eff.length) {
  // One row per parameter: one-parameter effects carry "interval95": [lo, hi]; gravity (scale, direction) and
  // tip_load (force) carry one interval per parameter name.
  // A parameter without a usable interval of the final fit shows '–' (a finding's interval is that of its own
  // round's fit, not of the final joint fit, so it is not borrowed).
  const rows = eff.flatMap((e) => {
    const keys = Object.keys(e).filter((k) => !['effect', 'tube', 'interval95'].includes(k));
    return keys.map((k) => {
      const iv = e.interval95 && !Array.isArray(e.interval95) ? e.interval95[k] : e.interval95;
      return [e.effect + (e.tube !== undefined ? ` (tube ${e.tube})` : ''), k, valueText(e[k]), hasInterval(iv) ? intervalText(iv) : '–'];
    });
  });
  app.appendChild(h('section', { class: 'card', id: 'parameters' }, h('h2', {}, 'Fitted parameters (all rows)'),
    table(['effect', 'parameter', 'value', '95 % interval'], rows, { class: 'params' }),
    h('p', { class: 'note' }, 'Gauss-Newton intervals with a pre-whitened Newey-West (HAC) covariance over rows: robust to serially correlated model error.')));
}

// Held-out error before / after.
app.appendChild(h('section', { class: 'card', id: 'scores' }, h('h2', {}, 'Held-out error'),
  table(['quantity', 'noise (1σ)', 'nominal', rep.final.model], quantities.map((q) => {
    const u = unitOf(q);
    const t = (v) => fmt(v * u.scale) + (u.unit ? ' ' + u.unit : '');
    return [q, noiseOf(q) ? t(noiseOf(q)) : '–', t(rep.baseline.heldout_rmse[q]), t(rep.final.heldout_rmse[q])];
  })),
  h('p', { class: 'note' }, `BIC: nominal ${fmt(rep.baseline.bic, 6)}, final ${fmt(rep.final.bic, 6)}.`)));

// Located mismatch.
const mm = h('section', { class: 'card', id: 'mismatch' }, h('h2', {}, 'Where the nominal model misses'));
app.appendChild(mm);
if (rep.mismatch.length) {
  mm.appendChild(table(['signature', 'variable', 'quantity', 'p-value', 'where'],
    rep.mismatch.map((f) => [f.signature, f.variable, f.quantity, fmt(f.p_value, 3), f.where])));
} else {
  mm.appendChild(h('p', {}, 'No test found residuals beyond the noise.'));
}
const binGrid = h('div', { class: 'grid' });
mm.appendChild(binGrid);
// Pairs (variable, quantity): those with findings first, then the rest, at most 6.
const pairs = [];
const addPair = (v, q) => { if (!pairs.some((p) => p[0] === v && p[1] === q)) pairs.push([v, q]); };
for (const f of rep.mismatch) if (/^(alpha|beta)_/.test(f.variable)) addPair(f.variable, f.quantity);
for (const b of plot.residual_bins.nominal) addPair(b.variable, b.quantity);
for (const [v, q] of pairs.slice(0, 6)) {
  const uq = unitOf(q), uv = unitOf(v);
  const ds = [];
  const pts = (model, dir) => plot.residual_bins[model]
    .filter((b) => b.variable === v && b.quantity === q && b.direction === dir && b.count > 0)
    .sort((a, b) => a.lo - b.lo)
    .map((b) => ({ x: 0.5 * (b.lo + b.hi) * uv.scale, y: b.rms * uq.scale }));
  const nom_p = pts('nominal', 1), nom_m = pts('nominal', -1);
  const xs = nom_p.concat(nom_m).map((p) => p.x);
  const x0 = Math.min(...xs), x1 = Math.max(...xs);
  const sigma = noiseOf(q);
  if (sigma && xs.length) {
    const level = noiseNormFactor(q) * sigma * uq.scale;
    ds.push(line('noise level', [{ x: x0, y: level }, { x: x1, y: level }], 'rgba(44,160,44,0.9)',
      { fill: { target: 'origin' }, backgroundColor: COLORS.noise, borderDash: [2, 2], borderWidth: 1 }));
  }
  ds.push(line('nominal, increasing', nom_p, COLORS.plus, { pointRadius: 2.5 }));
  ds.push(line('nominal, decreasing', nom_m, COLORS.minus, { pointRadius: 2.5 }));
  if (rep.verdict.length) {
    ds.push(line('fitted, increasing', pts('fitted', 1), COLORS.plus, { borderDash: [6, 4], pointRadius: 0 }));
    ds.push(line('fitted, decreasing', pts('fitted', -1), COLORS.minus, { borderDash: [6, 4], pointRadius: 0 }));
  }
  chart(binGrid, {
    title: `${q} residual vs ${v}`, xLabel: `${v} (${uv.unit})`, yLabel: `RMS residual (${uq.unit || '–'})`, datasets: ds,
    note: `Binned residual RMS, split by direction of approach of ${v}; shaded: the level pure measurement noise would give.`,
    height: 280,
  });
}

// Measured vs nominal vs fitted curves.
const cv = h('section', { class: 'card', id: 'curves' }, h('h2', {}, 'Measured, nominal and fitted model'));
app.appendChild(cv);
const curveGrid = h('div', { class: 'grid' });
cv.appendChild(curveGrid);
const rows = plot.rows;
const angleVars = plot.variables.filter((v) => v.angle);
const mainVar = angleVars[0] || plot.variables[0];
const hasFit = rep.verdict.length > 0;
// Measured values of every recording row (the diagnosis may have used every k-th row only).
const full = data.recording || {};
const fullVar = mainVar && (full.variables || []).find((v) => v.name === mainVar.name);
const measuredAll = (key, col, scale) => {
  const M = full[key];
  if (!M || !fullVar) return null;
  const pts = [];
  for (let k = 0; k < M.length; ++k)
    pts.push({ x: fullVar.value[k] * (fullVar.angle ? DEG : 1e3), y: M[k][col] === null ? NaN : M[k][col] * scale });
  return { m: 'measured', pts };
};
const series3 = (key, col, scale, x) => ['measured', 'nominal', 'fitted'].map((m) => {
  if (m === 'measured') { const all = measuredAll(key, col, scale); if (all) return all; }
  const M = plot[m][key];
  if (!M) return null;
  const pts = [];
  for (let k = 0; k < M.length; ++k) {
    const y = M[k][col];
    // A wrapped angle (359 deg -> 0 deg) breaks the line instead of drawing across the plot.
    if (k > 0 && mainVar && mainVar.angle && Math.abs(x(k) - x(k - 1)) > 180) pts.push({ x: x(k - 1), y: null });
    pts.push({ x: x(k), y: y === null ? NaN : y * scale });
  }
  return { m, pts };
}).filter(Boolean);
if (plot.measured.twist && mainVar) {
  // Twist vs motor angle (paper Fig. 11-12).
  const n = plot.measured.twist[0] ? plot.measured.twist[0].length : 0;
  for (let c = 0; c < n; ++c) {
    const xs = (k) => mainVar.value[k] * (mainVar.angle ? DEG : 1e3);
    const ds = series3('twist', c, DEG, xs).filter((s) => s.m !== 'fitted' || hasFit).map((s) => line(s.m, s.pts, COLORS[s.m],
      s.m === 'measured' ? { showLine: false, pointRadius: 1.5 } : { borderWidth: 1.4 }));
    chart(curveGrid, { title: `Tip twist of tube ${c + 2} vs ${mainVar.name}`, xLabel: `${mainVar.name} (${mainVar.angle ? 'deg' : 'mm'})`,
      yLabel: 'twist (deg)', datasets: ds, note: 'As in Lock & Dupont Fig. 11–12: the loop opens where friction holds the tubes.' });
  }
}
if (plot.measured.tip_position) {
  const t = plot.time;
  const xs = (k) => (t ? t[k] : k);
  const err = (m) => plot[m].tip_position.map((p, k) => {
    const q = plot.measured.tip_position[k];
    if (!p || !q || p.some((v) => v === null) || q.some((v) => v === null)) return { x: xs(k), y: NaN };
    return { x: xs(k), y: 1e3 * Math.hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]) };
  });
  const ds = [line('nominal', err('nominal'), COLORS.nominal)];
  if (hasFit) ds.push(line('fitted', err('fitted'), COLORS.fitted));
  const sigma = noiseOf('tip_position');
  if (sigma) {
    const x0 = xs(0), x1 = xs(rows - 1), lv = Math.sqrt(3) * sigma * 1e3;
    ds.unshift(line('noise level', [{ x: x0, y: lv }, { x: x1, y: lv }], 'rgba(44,160,44,0.9)',
      { fill: { target: 'origin' }, backgroundColor: COLORS.noise, borderDash: [2, 2], borderWidth: 1 }));
  }
  chart(curveGrid, { title: 'Tip position error along the recording', xLabel: t ? 'time (s)' : 'row', yLabel: 'tip error (mm)', datasets: ds,
    note: 'Distance between the measured tip and the model’s prediction at every row used.' });
  if (mainVar) {
    const xsv = (k) => mainVar.value[k] * (mainVar.angle ? DEG : 1e3);
    for (let c = 0; c < 3; ++c) {
      const ds2 = series3('tip_position', c, 1e3, xsv).filter((s) => s.m !== 'fitted' || hasFit).map((s) => line(s.m, s.pts, COLORS[s.m],
        s.m === 'measured' ? { showLine: false, pointRadius: 1.2 } : { borderWidth: 1.2 }));
      chart(curveGrid, { title: `Tip ${'xyz'[c]} vs ${mainVar.name}`, xLabel: `${mainVar.name} (${mainVar.angle ? 'deg' : 'mm'})`,
        yLabel: `tip ${'xyz'[c]} (mm)`, datasets: ds2, height: 240 });
    }
  }
}

// Candidates.
const cand = h('section', { class: 'card', id: 'candidates' }, h('h2', {}, 'Candidates tried'));
app.appendChild(cand);
const candRows = [{ cells: ['nominal (baseline)', '–', '', '–', rmseText(rep.baseline.heldout_rmse), fmt(rep.baseline.bic, 6), '–', '–', ''], attrs: { class: 'baseline' } }]
  .concat(rep.findings.map((f) => ({
    attrs: { class: f.accepted ? 'accepted candidate' : 'candidate' },
    cells: [f.effect, String(f.round), f.accepted ? 'yes' : 'no', paramText(f.parameters, f.interval95), rmseText(f.heldout_rmse),
      '', fmt(f.delta_bic, 4), fmt(f.heldout_p, 3), f.explanation],
  })));
cand.appendChild(table(['effect', 'round', 'accepted', 'parameters [95 % interval]', 'held-out RMSE', 'BIC', 'ΔBIC', 'held-out p', 'why'],
  candRows, { class: 'candidates', id: 'candidates-table' }));

publish('diagnosis', { candidateRows: () => document.querySelectorAll('#candidates-table tbody tr.candidate, #candidates-table tbody tr.accepted').length });
