#!/usr/bin/env python3
"""Robust mode against exact mode: successes and planning time on the example queries and on unseen Med-MPD queries.

Usage: scripts/robust_vs_exact.py BUILD_DIR OUT_DIR [--seeds N] [--time T] [--jobs J] [--quick]

Runs `ctr plan QUERY --mode exact|robust --seed S --cpu-time --time T --json ...` for every query, both modes, seeds
1..N (default 3 seeds, 30 CPU s per run), at most J runs at a time (default 2; the example queries' planner,
`portfolio`, runs two threads per run). The queries:

  example  every examples/queries/*.yaml, as they are;
  unseen   queries written into OUT_DIR/unseen/ (never into the checkout): the lung patients with a goal in the
           examples (2, 3, 4) from other bronchoscope poses (`base_start: start2`, `start3`), and other patients than
           the examples' (brain 3 and 4, liver 2 and 4), whose environment descriptions are written into
           OUT_DIR/unseen/environments/ like examples/environments/medmpd_*.yaml (the map cropped to the extent of
           the organ's mask image as `ctr env info` maps it, plus 14.5 mm for the brain (as the examples: the brain
           image is cropped to the brain) and 20 mm for the liver (its image is the CT's whole field of view), and
           grown to hold the start pose). Each uses the robot, friction,
           start configuration and goal tolerance of the example query of its organ (robot paths made absolute). A
           candidate that `ctr plan` refuses (exit code 2: e.g. a start in collision) is replaced by the next one
           (a 1 CPU s frictionless screening run decides; whether it solves is not looked at); 10 are kept.

BUILD_DIR/apps/ctr is first copied to OUT_DIR/ctr and that copy is run (the build may change meanwhile). Runs whose
JSON is already in OUT_DIR/runs/ are kept (a run interrupted can be resumed with the same arguments).
--quick: 2 example and 2 unseen queries, 1 seed, 5 CPU s (a smoke run).

Each run leaves OUT_DIR/runs/NAME.json (ctr plan --json) and NAME.path.csv (the replayed path, ctr plan --path).
Writes OUT_DIR/runs.csv and OUT_DIR/runs.json (every run: outcome, planning time, message, replay), OUT_DIR/table.md
(the Markdown table of docs/planning.md "Robust vs exact, measured") and prints the table. Needs the Med-MPD data set
(scripts/fetch-data.sh fetches it) in the data folder: $CTR_DATA, else ../shared/data beside the checkout, else data/
in the checkout.
"""
import argparse, collections, concurrent.futures, csv, json, os, shutil, statistics, subprocess, sys, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


sys.path.insert(0, os.path.join(ROOT, 'scripts'))
from known_answer_cases import DATA, require_data  # noqa: E402  (the one lookup of the data folder)


EXAMPLES = os.path.join(ROOT, 'examples')
ROBOTS = os.path.join(EXAMPLES, 'robots')
MODES = ('exact', 'robust')

# Start configuration, friction and tolerance of the example query of each organ (examples/queries/medmpd_*.yaml).
LUNG = dict(robot='medmpd_lung.yaml', beta=[-0.118, -0.218, -0.318], target='nodule')
BRAIN = dict(robot='medmpd_brain.yaml', beta=[-0.11, -0.19, -0.25], target='globus_pallidus')        # patient 1
BRAIN_NEAR = dict(robot='medmpd_brain.yaml', beta=[-0.118, -0.198, -0.258], target='globus_pallidus')  # patient 2
LIVER = dict(robot='medmpd_liver.yaml', beta=[-0.15, -0.23, -0.29], target='tumour')


def lung_start(patient, start):
    """An example lung environment (in the checkout) from another of its bronchoscope poses."""
    return dict(name='unseen_lung_patient%d_%s' % (patient, start),
                what='lung patient %d, bronchoscope pose %s (examples: start1)' % (patient, start),
                env=os.path.join(EXAMPLES, 'environments', 'medmpd_lung_patient%d.yaml' % patient),
                base_start=start, **LUNG)


def brain(patient):
    """Another brain patient: vessels and ventricles as obstacles, the burr-hole pose, the globus pallidus target.
    Two variants: as brain patient 1 (10 mm out), else as patient 2 (2 mm out, first 5 mm excluded)."""
    d = '${CTR_DATA}/med-mpd/Brain/Patient%d/' % patient
    env = dict(obstacles=[d + 'vessels.nii.gz', d + 'ventricles.nii.gz'], mask=d + 'brain.nii.gz', margin=0.0145,
               starts={'start1': d + 'start1.txt'}, targets={'globus_pallidus': d + 'target1.txt'})
    return [dict(name='unseen_brain_patient%d' % patient, what='brain patient %d (not in the examples)' % patient,
                 gen_env=env, **BRAIN),
            dict(name='unseen_brain_patient%d' % patient, what='brain patient %d (not in the examples; 2 mm out, '
                 'first 5 mm excluded as brain patient 2)' % patient, gen_env=dict(env, exclude_proximal=0.005),
                 **BRAIN_NEAR)]


def liver(patient, vessels, start, target):
    """Another liver patient: hepatic veins, portal vein and hepatic artery as obstacles."""
    d = '${CTR_DATA}/med-mpd/Liver/Patient%d/' % patient
    env = dict(obstacles=[d + v for v in vessels], mask=d + 'liver.nii.gz', margin=0.02,
               starts={'start1': d + start}, targets={'tumour': d + target})
    return dict(name='unseen_liver_patient%d_%s' % (patient, target.split('.')[0]),
                what='liver patient %d, %s (not in the examples)' % (patient, target.split('.')[0]), gen_env=env,
                **LIVER)


LIVER_VESSELS = ['hepaticVein.nii.gz', 'portalVein.nii.gz', 'hepaticArtery.nii.gz']


def unseen_candidates():
    """In order of preference; the first 10 that `ctr plan` accepts are used. A list is alternatives of one query."""
    return [lung_start(2, 'start2'), lung_start(3, 'start2'), lung_start(4, 'start2'), brain(3),
            liver(2, LIVER_VESSELS, 'target1_start1.txt', 'target1.txt'),
            lung_start(2, 'start3'), lung_start(3, 'start3'), lung_start(4, 'start3'), brain(4),
            liver(4, LIVER_VESSELS, 'start1.txt', 'target.txt'),
            # replacements
            brain(5), liver(5, LIVER_VESSELS, 'target1_start1.txt', 'target1.txt'),
            lung_start(2, 'start4'), lung_start(3, 'start4'), lung_start(4, 'start4'),
            liver(2, LIVER_VESSELS, 'target2_start1.txt', 'target2.txt'), lung_start(1, 'start2'),
            lung_start(5, 'start2')]


def read_medmpd(path, rows):
    with open(path.replace('${CTR_DATA}', DATA)) as f:
        vals = [float(x) for x in f.read().split()]
    return [vals[i * (len(vals) // rows):(i + 1) * (len(vals) // rows)] for i in range(rows)]


def mask_bounds(ctr, mask, workdir):
    """Bounds (m) of a NIfTI mask image's map, as `ctr env info` gives them (the image's extent)."""
    probe = os.path.join(workdir, 'mask_probe.yaml')
    with open(probe, 'w') as f:
        f.write('name: mask_probe\nresolution: 0.001\nobstacles:\n  - nifti: "%s"\n    label: 1\n' % mask)
    r = subprocess.run([ctr, 'env', 'info', probe, '--json', '-'], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError('ctr env info %s: %s' % (probe, r.stderr.strip()))
    b = json.loads(r.stdout)['bounds']
    return b['min'], b['max']


def write_environment(ctr, name, spec, out):
    """An environment description like examples/environments/medmpd_*.yaml, for a patient the examples lack."""
    lo, hi = mask_bounds(ctr, spec['mask'], out)
    lo = [v - spec['margin'] for v in lo]
    hi = [v + spec['margin'] for v in hi]
    for f in spec['starts'].values():                      # the start pose inside the map too
        m = read_medmpd(f, 4)
        p = [m[i][3] / 1000 for i in range(3)]
        lo = [min(a, b - 0.01) for a, b in zip(lo, p)]
        hi = [max(a, b + 0.01) for a, b in zip(hi, p)]
    r = lambda v: '[%s]' % ', '.join('%.4f' % x for x in v)
    lines = ['# Generated by scripts/robust_vs_exact.py (Med-MPD, CC BY-NC-SA 4.0: read from the data folder).',
             'name: %s' % name, 'resolution: 0.001', 'bounds: {min: %s, max: %s}' % (r(lo), r(hi)), 'obstacles:']
    for o in spec['obstacles']:
        lines += ['  - nifti: "%s"' % o, '    label: 1']
    lines.append('starts:')
    lines += ['  %s: {medmpd_start: "%s"}' % kv for kv in spec['starts'].items()]
    lines.append('base_pose: {start: %s}' % next(iter(spec['starts'])))
    lines.append('targets:')
    lines += ['  %s: {medmpd_target: "%s"}' % kv for kv in spec['targets'].items()]
    if spec.get('exclude_proximal'):
        lines += ['collision:', '  exclude_proximal: %g' % spec['exclude_proximal']]
    path = os.path.join(out, 'environments', name + '.yaml')
    with open(path, 'w') as f:
        f.write('\n'.join(lines) + '\n')
    return path


def write_query(c, env, out):
    lines = ['# Generated by scripts/robust_vs_exact.py: %s.' % c['what'], 'name: %s' % c['name'],
             'robot: %s' % os.path.join(ROBOTS, c['robot']), 'environment: %s' % env]
    if c.get('base_start'):
        lines.append('base_start: %s' % c['base_start'])
    lines += ['friction: {boundary: 0.1}', 'start:', '  alpha: [0.0, 0.0, 0.0]',
              '  beta: [%s]' % ', '.join('%g' % b for b in c['beta']), '  history: positive', 'goal:',
              '  target: %s' % c['target'], '  tolerance: 0.003', 'mode: exact', 'planner: portfolio',
              'time_limit: 30', 'seed: 1']
    path = os.path.join(out, 'queries', c['name'] + '.yaml')
    with open(path, 'w') as f:
        f.write('\n'.join(lines) + '\n')
    return path


def screen(ctr, query, out):
    """None if `ctr plan` accepts the query (solved or not), else its one-line refusal."""
    js = os.path.join(out, 'screen', os.path.basename(query)[:-5] + '.json')
    if os.path.exists(js):             # screened before (a resumed run)
        return None
    r = subprocess.run([ctr, 'plan', query, '--mode', 'frictionless', '--seed', '1', '--cpu-time', '--time', '1',
                        '--json', js], capture_output=True, text=True, timeout=600)
    return None if r.returncode in (0, 1) else (r.stderr.strip().splitlines() or ['exit %d' % r.returncode])[-1]


def make_unseen(ctr, out, wanted, jobs):
    """Writes the unseen queries into OUT_DIR/unseen and returns [(name, path, what)] of the accepted ones."""
    u = os.path.join(out, 'unseen')
    for sub in ('environments', 'queries', 'screen'):
        os.makedirs(os.path.join(u, sub), exist_ok=True)
    cands = []
    for c in unseen_candidates():
        alts = c if isinstance(c, list) else [c]
        written = []
        for i, a in enumerate(alts):
            env = a['env'] if 'env' in a else write_environment(ctr, a['name'] + ('' if i == 0 else '_v%d' % i),
                                                                  a['gen_env'], u)
            a = dict(a, name=a['name'] + ('' if i == 0 else '_v%d' % i))
            written.append((a, write_query(a, env, u)))
        cands.append(written)

    def first_accepted(alts):
        """The first alternative `ctr plan` accepts (or None), and the screening's lines."""
        lines = []
        for a, q in alts:
            why = screen(ctr, q, u)
            lines.append('%s: %s' % (a['name'], 'accepted' if why is None else 'refused: ' + why))
            if why is None:
                return (a['name'], q, a['what']), lines
        return None, lines

    accepted, log = [], []
    with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
        for i in range(0, len(cands), jobs):       # a few at a time, in order, until enough are accepted
            for found, lines in pool.map(first_accepted, cands[i:i + jobs]):
                log += lines
                if found and len(accepted) < wanted:
                    accepted.append(found)
            if len(accepted) >= wanted:
                break
    with open(os.path.join(u, 'screening.txt'), 'w') as f:
        f.write('\n'.join(log) + '\n')
    for line in log:
        print('unseen: ' + line, file=sys.stderr)
    return accepted


def plan(ctr, query, mode, seed, limit, out):
    """One `ctr plan` run; its record (the JSON's content plus the command's exit code and wall time)."""
    base = os.path.join(out, 'runs', '%s__%s__seed-%d' % (os.path.basename(query)[:-5], mode, seed))
    if os.path.exists(base + '.record.json'):
        with open(base + '.record.json') as f:
            return json.load(f)
    # The replayed path is kept (--path) so that a run whose replay fails can be examined: a seed of the portfolio
    # planner does not repeat its path (its threads race).
    cmd = [ctr, 'plan', query, '--mode', mode, '--seed', str(seed), '--cpu-time', '--time', '%g' % limit,
           '--json', base + '.json', '--path', base + '.path.csv']
    t0 = time.time()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=max(600, 20 * limit))
        code, err = r.returncode, r.stderr
    except subprocess.TimeoutExpired:
        code, err = 'timeout', 'no answer within %g s of wall time' % max(600, 20 * limit)
    rec = dict(exit_code=code, wall_seconds=time.time() - t0, command=' '.join(cmd), stderr_tail=err[-1000:])
    if code in (0, 1) and os.path.exists(base + '.json'):
        with open(base + '.json') as f:
            rec['result'] = json.load(f)
    with open(base + '.record.json', 'w') as f:
        json.dump(rec, f)
    return rec


def reason(msg):
    """A short name for why a run was not solved (from the JSON's one-line message)."""
    m = msg or ''
    if 'no friction band reaches' in m:
        return 'no band within tolerance'
    if 'whole friction band' in m and 'but none is valid' in m:
        return 'band goals all invalid'
    if 'no valid goal configuration' in m:
        return 'no valid goal'
    if 'no configuration found by inverse kinematics' in m:
        return 'target out of reach'
    if m.startswith('planner:'):
        return 'no path in time'
    if m.startswith('replay'):
        return 'replay failed'
    return m[:60] or 'unknown'


def median(xs):
    return statistics.median(xs) if xs else None


def fmt_t(x):
    return '–' if x is None else ('%.1f' % x if x >= 0.95 else '%.2f' % x)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('build_dir')
    ap.add_argument('out_dir')
    ap.add_argument('--seeds', type=int, default=3)
    ap.add_argument('--time', type=float, default=30.0, help='CPU s per run (default 30)')
    ap.add_argument('--jobs', type=int, default=2, help='runs at a time (default 2)')
    ap.add_argument('--quick', action='store_true', help='2 example + 2 unseen queries, 1 seed, 5 CPU s')
    a = ap.parse_args()
    require_data('med-mpd')
    seeds, limit, n_unseen = (1, 5.0, 2) if a.quick else (a.seeds, a.time, 10)
    src = os.path.join(a.build_dir, 'apps', 'ctr')
    if not os.access(src, os.X_OK):
        sys.exit('%s not found: build first (cmake --build BUILD_DIR)' % src)
    out = os.path.abspath(a.out_dir)
    os.makedirs(os.path.join(out, 'runs'), exist_ok=True)
    ctr = os.path.join(out, 'ctr')
    if not os.path.exists(ctr):        # a resumed run keeps the binary it started with
        shutil.copy2(src, ctr)
    os.environ.setdefault('CTR_DATA', DATA)
    t_start = time.time()

    qdir = os.path.join(EXAMPLES, 'queries')
    examples = sorted(f for f in os.listdir(qdir) if f.endswith('.yaml'))
    if a.quick:
        examples = ['medmpd_lung_patient2.yaml', 'proc_intracardiac.yaml']
    queries = [(f[:-5], os.path.join(qdir, f), 'example', 'examples/queries/' + f) for f in examples]
    queries += [(n, p, 'unseen', w) for n, p, w in make_unseen(ctr, out, n_unseen, a.jobs)]

    units = [(q, m, s) for s in range(1, seeds + 1) for q in queries for m in MODES]
    records = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        futs = {pool.submit(plan, ctr, q[1], m, s, limit, out): (q, m, s) for q, m, s in units}
        for i, f in enumerate(concurrent.futures.as_completed(futs), 1):
            q, m, s = futs[f]
            rec = f.result()
            records[(q[0], m, s)] = rec
            res = rec.get('result', {})
            print('[%d/%d %4.0f s] %s %s seed %d: %s %s' % (
                i, len(units), time.time() - t_start, q[0], m, s,
                'solved' if res.get('solved') else 'not solved', '%.2f CPU s' % res['planning_time']
                if res.get('solved') else (res.get('message') or rec['stderr_tail'].strip()[-200:])),
                file=sys.stderr, flush=True)

    # --- per-run table ----------------------------------------------------------------------------------------
    rows = []
    for q, m, s in units:
        rec = records[(q[0], m, s)]
        res = rec.get('result', {})
        rp = res.get('replay', {})
        rr = res.get('range_replay')
        rows.append(dict(
            query=q[0], kind=q[2], what=q[3], mode=m, seed=s, exit_code=rec['exit_code'],
            solved=bool(res.get('solved')), planner_solved=bool(res.get('planner_solved')),
            planning_time=res.get('planning_time'), planning_wall_time=res.get('planning_wall_time'),
            run_wall_seconds=round(rec['wall_seconds'], 2), goal_pool=res.get('goal_pool'),
            message=res.get('message', '' if res else rec['stderr_tail'].strip()[-300:]),
            reason='' if res.get('solved') else reason(res.get('message') if res else rec['stderr_tail']),
            replay_collision_free=rp.get('collision_free'), replay_stable=rp.get('stable'),
            replay_goal_reached=rp.get('goal_reached'), replay_tip_error=rp.get('tip_error'),
            replay_min_clearance=rp.get('min_clearance'), replay_snaps=rp.get('snaps'),
            replay_collisions=rp.get('collisions'), replay_failure=rp.get('failure'),
            range_replay_points=(rr['corners'] + rr['samples']) if rr else None,
            range_replay_clean=rr['clean'] if rr else None,
            range_replay_worst_clearance=rr.get('worst_clearance') if rr else None,
            command=rec['command']))
    with open(os.path.join(out, 'runs.json'), 'w') as f:
        json.dump(dict(seeds=seeds, time_limit_cpu_s=limit, ctr=ctr, runs=rows), f, indent=1)
    with open(os.path.join(out, 'runs.csv'), 'w', newline='') as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)

    # --- summary table ----------------------------------------------------------------------------------------
    by = {(r['query'], r['mode'], r['seed']): r for r in rows}
    md = ['| query | kind | exact solved | exact median CPU s | robust solved | robust median CPU s | robust / exact '
          'median time | robust replays clean (min clearance, mm) | robust not solved: why (runs) | exact not solved: '
          'why (runs) |',
          '|---|---|---|---|---|---|---|---|---|---|']

    def stats(qs):
        """Totals over the queries qs: successes, pairs, times."""
        e = [by[(q, 'exact', s)] for q in qs for s in range(1, seeds + 1)]
        r = [by[(q, 'robust', s)] for q in qs for s in range(1, seeds + 1)]
        pairs = [(x, y) for x, y in zip(e, r) if x['solved']]
        both = [(x, y) for x, y in pairs if y['solved']]
        within = [(x, y) for x, y in both if y['planning_time'] <= 3 * x['planning_time']]
        te = median([x['planning_time'] for x in e if x['solved']])
        tr = median([y['planning_time'] for y in r if y['solved']])
        return dict(n=len(e), es=sum(x['solved'] for x in e), rs=sum(y['solved'] for y in r), pairs=len(pairs),
                    both=len(both), within=len(within), te=te, tr=tr,
                    ratio=(tr / te) if te and tr else None,
                    pair_ratio=median([y['planning_time'] / x['planning_time'] for x, y in both]),
                    clean=sum(1 for y in r if y['solved'] and y['replay_collision_free'] and y['replay_stable']
                              and y['replay_goal_reached'] and y['range_replay_clean'] in (None, y['range_replay_points'])))

    for name, _, kind, what in queries:
        st = stats([name])
        rr = [by[(name, 'robust', s)] for s in range(1, seeds + 1)]
        clear = [y['replay_min_clearance'] * 1e3 for y in rr if y['solved'] and y['replay_min_clearance'] is not None]
        why = collections.Counter(y['reason'] for y in rr if not y['solved'])
        why_e = collections.Counter(by[(name, 'exact', s)]['reason'] for s in range(1, seeds + 1)
                                    if not by[(name, 'exact', s)]['solved'])
        md.append('| %s | %s | %d/%d | %s | %d/%d | %s | %s | %s | %s | %s |' % (
            name, kind, st['es'], st['n'], fmt_t(st['te']), st['rs'], st['n'], fmt_t(st['tr']),
            '–' if st['ratio'] is None else '%.1f' % st['ratio'],
            ('%d/%d (%s)' % (st['clean'], st['rs'], ', '.join('%.2f' % c for c in clear))) if st['rs'] else '–',
            ', '.join('%s (%d)' % kv for kv in sorted(why.items())) or '–',
            ', '.join('%s (%d)' % kv for kv in sorted(why_e.items())) or '–'))

    def total(label, qs):
        st = stats(qs)
        return ('| %s | %d/%d | **%d/%d** (%s) | %d/%d | **%d/%d** | %s | %s | %s | %s | %d/%d |' % (
            label, st['es'], st['n'], st['rs'], st['es'], '%.0f %%' % (100.0 * st['rs'] / st['es']) if st['es'] else '–',
            st['both'], st['pairs'], st['within'], st['pairs'], fmt_t(st['te']), fmt_t(st['tr']),
            '–' if st['ratio'] is None else '%.1f' % st['ratio'],
            '–' if st['pair_ratio'] is None else '%.1f' % st['pair_ratio'], st['clean'], st['rs']))

    md += ['', '| queries | exact solved | robust solved / exact solved | robust solved on the runs exact solved '
           '(same query + seed) | ... and within 3x exact\'s time on that run | exact median CPU s | robust median '
           'CPU s | ratio of medians | median of per-run ratios | robust replays clean |',
           '|---|---|---|---|---|---|---|---|---|---|']
    for label, kind in (('example', 'example'), ('unseen', 'unseen'), ('all', None)):
        qs = [q[0] for q in queries if kind in (None, q[2])]
        if qs:
            md.append(total('%s (%d)' % (label, len(qs)), qs))
    md += ['', 'Unseen queries:', ''] + ['- `%s`: %s' % (q[0], q[3]) for q in queries if q[2] == 'unseen']
    md += ['', '%d seeds, %g CPU s per run, %d runs; their wall times add up to %.0f min (%d at a time).' % (
        seeds, limit, len(units), sum(r['run_wall_seconds'] for r in rows) / 60, a.jobs)]
    text = '\n'.join(md) + '\n'
    with open(os.path.join(out, 'table.md'), 'w') as f:
        f.write(text)
    print(text)


if __name__ == '__main__':
    main()
