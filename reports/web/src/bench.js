// Benchmark campaign report (`ctr bench merge --html`): success rates and replay outcomes per query / mode / planner,
// and the distribution of the time to solution (fraction of runs solved within t, and every solved run's time).
import { Chart, BarController, BarElement, CategoryScale } from 'chart.js';
import { readData, h, fmt, chart, line, publish, header, table, allCharts, PALETTE } from './common.js';

Chart.register(BarController, BarElement, CategoryScale);

const d = readData();
const app = document.getElementById('app');
const clock = d.clock === 'cpu' ? 'CPU s' : 's';
app.appendChild(header(`Benchmark campaign — ${d.campaign}`,
  `${d.runs} of ${d.expected_runs} runs (${d.units} of ${d.expected_units} units × ${d.runs_per_seed} runs per seed), ` +
  `time limit ${fmt(d.time_limit)} ${clock}; experiments in ${d.database}: ${d.experiments.join(', ')}` +
  (d.complete ? '' : ` — INCOMPLETE: ${d.missing.length} unit(s) missing`)));

const OUTCOMES = [
  ['clean', '#2ca02c', 'replay clean'],
  ['collision', '#d62728', 'replay collides'],
  ['snap', '#9467bd', 'replay snaps'],
  ['goal missed', '#ff7f0e', 'replay misses the goal'],
  ['other', '#8c564b', 'replay fails otherwise'],
  ['unsolved', '#bbbbbb', 'planner unsolved'],
];
const rowLabel = (r) => `${r.query} / ${r.mode} / ${r.planner}`;
const planners = [...new Set(d.rows.map((r) => r.planner))].sort();
const colorOf = (p) => PALETTE[planners.indexOf(p) % PALETTE.length];
const groups = [...new Set(d.rows.map((r) => `${r.query} / ${r.mode}`))];

// Table.
const pct = (a, n) => (n ? `${a}/${n} (${Math.round((100 * a) / n)} %)` : '–');
app.appendChild(h('section', { class: 'card', id: 'summary' }, h('h2', {}, 'Per query, mode and planner'),
  table(['query', 'mode', 'planner', 'runs', 'planner solved', 'replay clean', 'collisions', 'snaps', 'goal missed',
    `median time (${clock})`, `min – max (${clock})`],
  d.rows.map((r) => [r.query, r.mode, `${r.planner} (${r.ompl_planner})`, String(r.runs), pct(r.solved, r.runs),
    pct(r.replay_clean, r.runs), String(r.replay_collisions), String(r.replay_snaps), String(r.replay_goal_missed),
    fmt(r.time.median), r.time.min === null ? '–' : `${fmt(r.time.min)} – ${fmt(r.time.max)}`]),
  { id: 'summary-table' })));

const grid = h('div', { class: 'grid' });
app.appendChild(grid);

function barChart(title, labels, datasets, { stacked = false, yLabel = '', yMax } = {}) {
  const canvas = h('canvas');
  grid.appendChild(h('figure', { class: 'card chart' },
    h('div', { class: 'chart-box', style: `height:${Math.max(320, 40 + 18 * labels.length)}px` }, canvas)));
  const c = new Chart(canvas, {
    type: 'bar',
    data: { labels, datasets },
    options: {
      responsive: true,
      indexAxis: 'y',
      plugins: { title: { display: true, text: title, font: { size: 14, weight: 'bold' } }, legend: { display: true } },
      scales: { x: { stacked, beginAtZero: true, max: yMax, title: { display: !!yLabel, text: yLabel } }, y: { stacked } },
    },
  });
  allCharts().push(c);
  return c;
}

// Success rates: planner solved and replay clean, per row.
const labels = d.rows.map(rowLabel);
barChart('Success rate', labels, [
  { label: 'planner solved', data: d.rows.map((r) => (r.runs ? (100 * r.solved) / r.runs : 0)), backgroundColor: '#1f77b4' },
  { label: 'replay clean (solved and replayed collision-free, stable, on the goal)',
    data: d.rows.map((r) => (r.runs ? (100 * r.replay_clean) / r.runs : 0)), backgroundColor: '#2ca02c' },
], { yLabel: '% of runs', yMax: 100 });

// Replay outcomes: every run in one category.
barChart('Replay outcomes (runs)', labels, OUTCOMES.map(([key, color, name]) => ({
  label: name,
  data: d.rows.map((r) => d.run_outcomes.filter((o) => rowLabel(o) === rowLabel(r) && o.outcome === key).length),
  backgroundColor: color,
})), { stacked: true, yLabel: 'runs' });

// Time to solution: fraction of runs solved within t (unsolved runs never count), per query and mode.
for (const g of groups) {
  const rows = d.rows.filter((r) => `${r.query} / ${r.mode}` === g);
  const ds = rows.map((r) => {
    const ts = r.times.filter((t) => t !== null).sort((a, b) => a - b);
    const pts = [{ x: 0, y: 0 }];
    ts.forEach((t, k) => { pts.push({ x: t, y: (100 * k) / r.runs }); pts.push({ x: t, y: (100 * (k + 1)) / r.runs }); });
    pts.push({ x: d.time_limit, y: (100 * ts.length) / r.runs });
    return line(r.planner, pts, colorOf(r.planner), { borderWidth: 2 });
  });
  chart(grid, { title: `Time to solution — ${g}`, xLabel: `time (${clock})`, yLabel: '% of runs solved within t', datasets: ds,
    extra: { scales: { x: { type: 'linear', min: 0, title: { display: true, text: `time (${clock})` } },
      y: { type: 'linear', min: 0, max: 100, title: { display: true, text: '% of runs solved within t' } } } },
    note: `Each step is a solved run; the curve ends at the time limit (${fmt(d.time_limit)} ${clock}) at the success rate.` });
}

// Every solved run's time, by row (jittered strip).
const strip = d.rows.map((r, i) => {
  const pts = [];
  r.times.forEach((t, k) => { if (t !== null) pts.push({ x: t, y: i + 0.3 * Math.sin(2.4 * k) }); });
  return { label: `_${rowLabel(r)}`, data: pts, showLine: false, pointRadius: 3, borderColor: colorOf(r.planner), backgroundColor: colorOf(r.planner) };
});
strip.push(...planners.map((p) => ({ label: p, data: [], showLine: false, pointRadius: 3, borderColor: colorOf(p), backgroundColor: colorOf(p) })));
chart(grid, {
  title: 'Time to solution of every solved run', xLabel: `time (${clock})`, yLabel: '', datasets: strip,
  height: Math.max(320, 60 + 28 * d.rows.length),
  extra: { scales: { x: { type: 'linear', min: 0, title: { display: true, text: `time (${clock})` } },
    y: { type: 'linear', min: -0.5, max: d.rows.length - 0.5, reverse: true,
      afterBuildTicks: (axis) => { axis.ticks = labels.map((_, i) => ({ value: i })); },
      ticks: { autoSkip: false, callback: (v) => labels[Math.round(v)] ?? '' } } } },
});

if (!d.complete) {
  app.appendChild(h('section', { class: 'card', id: 'missing' }, h('h2', {}, 'Missing units'),
    h('ul', {}, d.missing.map((m) => h('li', {}, m)))));
}

publish('bench', { rows: d.rows.length, runs: d.runs });
