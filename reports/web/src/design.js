// Design report (`ctr design --html`): the designed robot against the query's own, which queries each solves, the
// search (every candidate's score) and the clearance along the designed paths, with links to their viewers.
import { readData, h, fmt, chart, line, publish, header, table, PALETTE } from './common.js';

const d = readData();
const app = document.getElementById('app');
const evals = d.evaluations || [];
const queries = d.queries || [];
const mm = (v) => (v === null || v === undefined ? '–' : `${fmt(v * 1e3, 3)} mm`);
const pct = (v) => (v === null || v === undefined ? '–' : `${fmt(v * 100, 3)} %`);

app.appendChild(header(`Robot design — ${queries.map((q) => q.query).join(', ')}`,
  `${d.solved ? 'solved' : 'not solved'}: ${d.message || ''} — ${evals.length} candidates, ` +
  `${fmt(d.wall_time, 3)} s wall, shard ${d.shard}`));

// The query's own robot: the first candidate of the first generation when it lies in the space.
const base = d.base || null;
const baseEval = base && base.in_space ? evals.find((e) => e.generation === 0 && e.index === 0) || null : null;
const best = d.design || null;

// Robot: starting vs designed, per tube.
const robotRows = [];
const tubes = Math.max(base ? base.tubes.length : 0, best ? best.design.length : 0);
for (let i = 0; i < tubes; ++i) {
  const b = base ? base.tubes[i] : null;
  const t = best ? best.design[i] : null;
  const cell = (o, k, f) => (o ? f(o[k]) : '–');
  robotRows.push([String(i + 1), (t && t.name) || (b && b.name) || '',
    `${cell(b, 'straight_length', mm)} → ${cell(t, 'straight_length', mm)}`,
    `${cell(b, 'curved_length', mm)} → ${cell(t, 'curved_length', mm)}`,
    `${cell(b, 'curvature', (v) => fmt(v, 4))} → ${cell(t, 'curvature', (v) => fmt(v, 4))}`,
    `${cell(b, 'outer_diameter', mm)} / ${cell(b, 'inner_diameter', mm)} → ${cell(t, 'outer_diameter', mm)} / ${cell(t, 'inner_diameter', mm)}`,
    `${cell(b, 'strain', pct)} → ${cell(t, 'strain', pct)}`]);
}
app.appendChild(h('section', { class: 'card', id: 'robot' }, h('h2', {}, 'Robot: the query\'s own → the design'),
  table(['tube', 'name', 'straight length', 'curved length', 'precurvature (1/m)', 'outer / inner diameter', 'strain'],
    robotRows, { id: 'robot-table' }),
  base && !base.in_space ? h('p', {}, 'The query\'s own robot lies outside the design space: it was not evaluated.') : null));

// Per query: what each robot made of it.
const outcome = (ev, k) => {
  const q = ev && ev.queries ? ev.queries[k] : null;
  if (!q) return ['–', '–', '–'];
  return [q.stage, mm(q.closest), q.stage === 'solved' ? mm(q.min_clearance) : mm(q.goal_clearance) + ' (goal)'];
};
const viewerOf = (name) => (d.paths || []).find((p) => p.query === name && p.viewer);
app.appendChild(h(
    'section', {class: 'card', id: 'queries'}, h('h2', {}, 'Queries'),
    table(
        [
          'query', 'own robot: stage', 'closest', 'clearance', 'design: stage', 'closest', 'clearance', 'plans clean',
          'independent plans', 'viewer'
        ],
        queries.map((q, k) => {
          const o = outcome(baseEval, k);
          const n = outcome(best, k);
          const bq = best && best.queries ? best.queries[k] : null;
          const v = viewerOf(q.query);
          const c = bq && bq.confirmation ? bq.confirmation : null;
          return [
            q.query, ...o, ...n, bq ? `${bq.plans_solved}/${bq.plans}` : '–',
            c ? `${c.solved}/${c.plans} (${pct(c.success_rate)})` : '–', v ? h('a', {href: v.viewer}, 'open') : '–'
          ];
        }),
        {id: 'queries-table'}),
    h('p', {},
      'Stages, worst first: start_invalid, unreachable (the tip never reaches the target), no_valid_goal (it ' +
          'reaches it only in collision or unstably), no_path, solved (planned with clean replays). Clearance: the smallest ' +
          'along the replayed paths when solved, else the best clearance of a shape with the tip on the target. ' +
          'Independent plans: the design kept (the best finalist) planned again with other seeds as `ctr plan` plans the ' +
          'written query, solved with a clean replay / made (docs/design.md "Finalists").')));

const grid = h('div', { class: 'grid' });
app.appendChild(grid);

// The search: badness (0 = every query solved) of each candidate in evaluation order, per start.
const starts = [...new Set(evals.map((e) => e.start))].sort((a, b) => a - b);
const ds = starts.map((s, i) => ({
  label: `start ${s}`, showLine: false, pointRadius: 3, borderColor: PALETTE[i % PALETTE.length],
  backgroundColor: PALETTE[i % PALETTE.length],
  data: evals.filter((e) => e.start === s).map((e) => ({ x: e.index, y: e.score.badness ?? NaN })),
}));
chart(grid, { title: 'Search: feasibility of each candidate', xLabel: 'candidate (order of evaluation)', yLabel: 'badness (0: solves every query)',
  datasets: ds, note: 'Per query: 0 solved, 1 no clean path, 2 no valid goal, 3 target not reached, 4 invalid start, plus the progress within the stage.' });
const solvedEvals = evals.filter((e) => e.score.solved && e.score.clearance !== null);
if (solvedEvals.length) {
  chart(grid, { title: 'Search: clearance of the candidates that solve every query', xLabel: 'candidate (order of evaluation)', yLabel: 'smallest clearance (mm)',
    datasets: starts.map((s, i) => ({ label: `start ${s}`, showLine: false, pointRadius: 3, borderColor: PALETTE[i % PALETTE.length],
      backgroundColor: PALETTE[i % PALETTE.length],
      data: solvedEvals.filter((e) => e.start === s).map((e) => ({ x: e.index, y: e.score.clearance * 1e3 })) })) });
}

// Clearance along the designed paths.
const paths = (d.paths || []).filter((p) => p.tip_travel.length > 0);
if (paths.length) {
  chart(grid, { title: 'Clearance along the designed paths', xLabel: 'tip travel (mm)', yLabel: 'clearance (mm)',
    datasets: paths.map((p, i) => line(p.query, p.tip_travel.map((t, k) => ({ x: t * 1e3, y: p.clearance[k] === null ? NaN : p.clearance[k] * 1e3 })),
      PALETTE[i % PALETTE.length], { borderWidth: 2 })),
    note: 'Distance-field clearance of the replayed robot shape at each waypoint of the path written to ' +
      'paths/QUERY.csv, the first plan (gaps: not computed); the table\'s clearance is the smallest over every plan ' +
      'made, confirmations included.' });
}

publish('design', { evaluations: evals.length, queries: queries.length, paths: paths.length });
