#!/usr/bin/env python3
"""Cases with a known answer for `ctr diagnose`, generated through the `ctr` command and plain CSV edits:

  real-log injections  known effects written into the real Dupont-lab log itself (the robot "did" something the
                       log hides): backlash / offset on one joint column, offset on one translation column, two drive
                       errors at once;
  real joint path      the real joint path simulated through the model with one effect at a time (friction,
                       latency, backlash) to show which ones this trajectory can tell apart, and null recordings
                       (one measured like the real log: 1 mm, 1.5 deg, unknown frame);
  pose sets            random poses without a time column: the lung robot moved straight between poses (rows on
                       other branches than the one reached from rest), a tube pair with repeated frames and returns;
  coincident ends      a 3-tube null recording whose inner tubes often end exactly together, logged with rounding;
  outside the library  effects no candidate models (tracker drift, a gear-ratio error, a periodic drive error):
                       right only when nothing is named, `unexplained` is flagged and a generic model describes it;
  coarse motions       continuous random walks logged at 10 Hz, 10-35 deg per tube between rows (relative moves up
                       to ~70 deg): friction, friction + latency, friction in an unknown tracker frame, a 3-tube
                       precurvature change (positions only, no time), friction with tracker glitches (8 of 160
                       samples off by 6-15 mm, which must be listed in outlier_rows);
  public recordings    the nine recordings of ../shared/data/recordings (an independent simulator), with their truth.

Usage: scripts/known_answer_cases.py BUILD_DIR OUT_DIR [--only NAME,...] [--quick] [--diagnose-args 'ARGS']
(--diagnose-args: more options for every `ctr diagnose`, e.g. '--calibrate'). The real-log cases are diagnosed against
the EM tracker's noise (EM_NOISE), as a lab gives it; real_log_noise_unknown shows the log without it.
Writes OUT_DIR/NAME.{csv,json} and prints a Markdown table (docs/diagnosis.md). Needs the data sets
dupont-lab-ctr-trajectory-hjhdog1 (scripts/fetch-data.sh fetches it) and recordings (only in ../shared/data) in the
data folder: $CTR_DATA, else ../shared/data beside the checkout, else data/ in the checkout.
"""
import csv, json, math, os, random, subprocess, sys, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def data_dir():
    """The folder of the public data sets, looked up as CMake does: CTR_DATA, else ../shared/data beside the
    checkout, else data/ in the checkout (filled by scripts/fetch-data.sh)."""
    if os.environ.get('CTR_DATA'):
        return os.path.abspath(os.environ['CTR_DATA'])
    beside = os.path.join(os.path.dirname(ROOT), 'shared', 'data')
    return beside if os.path.isdir(beside) else os.path.join(ROOT, 'data')


DATA = data_dir()


def require_data(data_set):
    """Exits with the one message for a missing data set."""
    if not os.path.isdir(os.path.join(DATA, data_set)):
        how = ('run scripts/fetch-data.sh to fetch it' if data_set != 'recordings'
               else 'it is only in ../shared/data beside the checkout')
        sys.exit("data set '%s' not found in %s: %s (or set CTR_DATA to the folder of the data sets)"
                 % (data_set, DATA, how))


DUPONT_TXT = os.path.join(DATA, 'dupont-lab-ctr-trajectory-hjhdog1', 'jointTipTrajectory_measured_short.txt')
DUPONT_ROBOT = os.path.join(ROOT, 'examples', 'robots', 'dupont_lab_3tube.yaml')
LUNG_ROBOT = os.path.join(ROOT, 'examples', 'robots', 'medmpd_lung.yaml')
PAIR_B_ROBOT = os.path.join(ROOT, 'examples', 'robots', 'tube_pair_B.yaml')
PAIR_A_ROBOT = os.path.join(ROOT, 'examples', 'robots', 'tube_pair_A.yaml')
THREE_TUBE_ROBOT = os.path.join(ROOT, 'examples', 'robots', 'three_tube_generic.yaml')
PUBLIC = os.path.join(DATA, 'recordings')
DEG = math.pi / 180
# The real log's EM tracker noise, given as a lab gives it: the log's own neighbouring differences are serially
# correlated, so its noise cannot be estimated from it (without --noise nothing is established: real_log_noise_unknown).
EM_NOISE = ['--noise', 'tip_position=0.5mm,tip_tangent=0.3deg']


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(' '.join(cmd) + '\n' + r.stderr[-2000:])
    return r


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], [[float(x) if x != '' else None for x in r] for r in rows[1:]]


def write_csv(path, header, rows):
    with open(path, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows:
            w.writerow(['' if v is None else repr(v) for v in r])


def direction_series(x, eps):
    """Direction of motion of a logged joint, ignoring changes smaller than eps (encoder noise)."""
    d, out, ref = 0.0, [], x[0]
    for v in x:
        if v - ref > eps:
            d, ref = 1.0, v
        elif ref - v > eps:
            d, ref = -1.0, v
        elif d > 0:
            ref = max(ref, v)
        elif d < 0:
            ref = min(ref, v)
        out.append(d)
    return out


class Cases:
    def __init__(self, build, out, quick):
        self.ctr = os.path.join(build, 'apps', 'ctr')
        self.out = out
        self.quick = quick
        os.makedirs(out, exist_ok=True)
        self.dupont = os.path.join(out, 'dupont.csv')
        if not os.path.exists(self.dupont):
            run([self.ctr, 'recording', 'import', '--format', 'dupont-lab', '--input', DUPONT_TXT, '--out', self.dupont])
        self.actuation = os.path.join(out, 'dupont_actuation.csv')
        if not os.path.exists(self.actuation):
            h, rows = read_csv(self.dupont)
            keep = [i for i, n in enumerate(h) if n.startswith(('alpha_', 'beta_')) or n == 'time']
            write_csv(self.actuation, [h[i] for i in keep], [[r[i] for i in keep] for r in rows])

    # --- real-log injections -------------------------------------------------------------------------------
    def real_joint_edit(self, name, column, edit):
        h, rows = read_csv(self.dupont)
        c = h.index(column)
        x = [r[c] for r in rows]
        y = edit(x)
        for r, v in zip(rows, y):
            r[c] = v
        path = os.path.join(self.out, name + '.csv')
        write_csv(path, h, rows)
        return path

    def real_backlash(self, tube, width):
        # The tube really was at the logged angle; with play of full width w in its drive the command had to travel
        # w/2 ahead of it in the direction of motion: log the command, hide the play.
        def edit(x):
            d = direction_series(x, 1e-4)
            return [v + 0.5 * width * s for v, s in zip(x, d)]
        return self.real_joint_edit('real_backlash_t%d' % tube, 'alpha_%d' % tube, edit)

    def real_two_drives(self, offset_deg=6):
        # Two drive errors the log hides: an 8 deg play on the tube-2 drive and an offset of tube 1 (of either sign).
        h, rows = read_csv(self.dupont)
        c2, c1 = h.index('alpha_2'), h.index('alpha_1')
        x = [r[c2] for r in rows]
        d = direction_series(x, 1e-4)
        for r, s in zip(rows, d):
            r[c2] += 0.5 * 8 * DEG * s
            r[c1] -= offset_deg * DEG
        path = os.path.join(self.out, 'real_two_drives%s.csv' % ('' if offset_deg == 6 else '_%+d' % offset_deg))
        write_csv(path, h, rows)
        return path

    def poses(self, name, robot, extra, pos_noise=3e-4, tan_noise='0.3deg'):
        # A pose set: random poses (no time column), optionally with returns and repeated frames.
        path = os.path.join(self.out, name + '.csv')
        run([self.ctr, 'recording', 'inject', '--robot', robot, '--pattern', 'random', '--dt', '0',
             '--noise-position', str(pos_noise), '--noise-tangent', tan_noise, '--measure', 'tip_position,tip_tangent',
             '--seed', '12', '--out', path] + extra)
        return path

    def real_offset(self, tube, offset, translation=False):
        col = ('beta_%d' if translation else 'alpha_%d') % tube
        return self.real_joint_edit('real_%soffset_t%d' % ('translation_' if translation else '', tube), col,
                                    lambda x: [v - offset for v in x])

    # --- simulated on the real joint path ------------------------------------------------------------------
    def inject(self, name, effects, robot=DUPONT_ROBOT, actuation=None, pos_noise=3e-4, tan_noise='0.5deg', seed=1,
               measure='tip_position,tip_tangent', sensor_frame=True):
        path = os.path.join(self.out, name + '.csv')
        cmd = [self.ctr, 'recording', 'inject', '--robot', robot, '--actuation', actuation or self.actuation,
               '--noise-position', str(pos_noise), '--noise-tangent', tan_noise, '--measure', measure,
               '--seed', str(seed), '--out', path]
        if sensor_frame:
            cmd.append('--sensor-frame')
        for e in effects:
            cmd += ['--effect', e]
        run(cmd)
        return path

    # --- coincident ends, rounded --------------------------------------------------------------------------
    def coincident_actuation(self, rows=140, seed=3):
        # Dupont robot: tubes 1 and 2 end together at beta_2 = beta_1 - 0.017; tube 3 often retracted so that it
        # ends exactly where tube 2 ends (beta_3 = beta_2 + L2 - L3), values logged with 6 significant digits.
        rnd = random.Random(seed)
        L = [0.150, 0.167, 0.27039]
        path = os.path.join(self.out, 'coincident_actuation.csv')
        out, a2, a3, b3 = [], 0.0, 0.0, None
        for k in range(rows):
            a2 += rnd.uniform(-8, 8) * DEG
            a3 += rnd.uniform(-8, 8) * DEG
            b1 = 0.0
            b2 = b1 + L[0] - L[1]
            coincident = b2 + L[1] - L[2]
            b3 = coincident if rnd.random() < 0.4 else coincident + rnd.uniform(0, 0.04)
            vals = [0.0, a2, a3, b1, b2, b3, 0.1 * k]
            out.append([float('%.6g' % v) for v in vals])
        write_csv(path, ['alpha_1', 'alpha_2', 'alpha_3', 'beta_1', 'beta_2', 'beta_3', 'time'], out)
        return path

    # --- outside the library -------------------------------------------------------------------------------
    def outside(self, name, kind, seed=5):
        robot = os.path.join(ROOT, 'examples', 'robots', 'tube_pair_B.yaml')
        act = os.path.join(self.out, name + '_act.csv')
        run([self.ctr, 'recording', 'inject', '--robot', robot, '--pattern', 'random-walk', '--rows', '150',
             '--dt', '0.1', '--seed', str(seed), '--out', act])
        h, rows = read_csv(act)
        ia = h.index('alpha_2')
        true_rows = [list(r) for r in rows]
        if kind == 'gear_ratio':      # drive turns 8 % more than commanded
            for r in true_rows:
                r[ia] *= 1.08
        elif kind == 'periodic':      # eccentric gear: 6 deg error with the drive angle
            for r in true_rows:
                r[ia] += 6 * DEG * math.sin(r[ia])
        keep = [i for i, n in enumerate(h) if n.startswith(('alpha_', 'beta_')) or n == 'time']
        true_act = os.path.join(self.out, name + '_true_act.csv')
        write_csv(true_act, [h[i] for i in keep], [[r[i] for i in keep] for r in true_rows])
        path = self.inject(name, [], robot=robot, actuation=true_act, pos_noise=1e-4, tan_noise='0.2deg', seed=seed,
                           measure='twist,tip_position,tip_tangent', sensor_frame=False)
        hh, rr = read_csv(path)
        # log the commands, not what the drive did
        for r, c in zip(rr, rows):
            for n in ('alpha_2',):
                r[hh.index(n)] = c[h.index(n)]
        if kind == 'tracker_drift':   # the tracker drifts 2 mm along x over the recording
            ix, it = hh.index('tip_x'), hh.index('time')
            tmax = max(r[it] for r in rr)
            for r in rr:
                r[ix] += 0.002 * r[it] / tmax
        write_csv(path, hh, rr)
        return path, robot

    # --- coarse motions ------------------------------------------------------------------------------------
    def coarse(self, name, robot, effects, seed, dt='0.1', measure='twist,tip_position,tip_tangent', sensor_frame=False,
               translate=False, glitches=0):
        # A continuous random walk logged coarsely: up to 6 rad/s per tube at 10 Hz (10-35 deg per tube between rows).
        path = os.path.join(self.out, name + '.csv')
        cmd = [self.ctr, 'recording', 'inject', '--robot', robot, '--pattern', 'random-walk', '--rows', '160',
               '--dt', dt, '--max-speed', '6', '--noise-twist', '2deg', '--noise-position', '5e-4',
               '--noise-tangent', '1deg', '--measure', measure, '--seed', str(seed), '--out', path]
        if sensor_frame:
            cmd.append('--sensor-frame')
        if translate:
            cmd.append('--translate')
        for e in effects:
            cmd += ['--effect', e]
        run(cmd)
        if glitches:
            # Tracker glitches: a few samples off by 6-15 mm in a random direction (as EM trackers do near metal).
            h, rows = read_csv(path)
            ix = h.index('tip_x')
            rnd = random.Random(seed)
            for k in rnd.sample(range(len(rows)), glitches):
                d = [rnd.gauss(0, 1) for _ in range(3)]
                n = math.sqrt(sum(x * x for x in d))
                size = rnd.uniform(0.006, 0.015)
                for a in range(3):
                    rows[k][ix + a] += size * d[a] / n
            write_csv(path, h, rows)
        return path, robot

    @staticmethod
    def curvature(robot, tube, factor):
        # The description's precurvature of a tube (1-based) times factor (the robot YAML's `curvature:` lines).
        with open(robot) as f:
            values = [float(l.split(':')[1].split('#')[0]) for l in f if l.strip().startswith('curvature:')]
        return values[tube - 1] * factor

    def public(self, name):
        return os.path.join(PUBLIC, name + '.csv'), os.path.join(PUBLIC, name + '.robot.yaml')

    def diagnose(self, name, recording, robot=DUPONT_ROBOT, frame='unknown', extra=()):
        js = os.path.join(self.out, name + '.json')
        t = time.time()
        run([self.ctr, 'diagnose', '--robot', robot, '--recording', recording, '--frame', frame, '--json', js,
             '--quiet'] + list(extra))
        wall = time.time() - t
        with open(js) as f:
            return json.load(f), wall


def fmt_params(j):
    def val(v):
        return '(%s)' % ', '.join('%.4g' % x for x in v) if isinstance(v, list) else '%.4g' % v
    out = []
    for e in j['final'].get('effects', []):
        ks = [x for x in e if x not in ('effect', 'tube', 'interval95')]   # gravity: direction, scale; tip_load: force
        out.append('%s%s %s' % (e['effect'], '[%d]' % e['tube'] if 'tube' in e else '',
                                ' '.join('%s=%s' % (k, val(e[k])) for k in ks)))
    return '; '.join(out)


def main():
    build, out = sys.argv[1], sys.argv[2]
    require_data('dupont-lab-ctr-trajectory-hjhdog1')
    require_data('recordings')
    only = None
    if '--only' in sys.argv:
        only = set(sys.argv[sys.argv.index('--only') + 1].split(','))
    C = Cases(build, out, '--quick' in sys.argv)
    extra = sys.argv[sys.argv.index('--diagnose-args') + 1].split() if '--diagnose-args' in sys.argv else []
    cases = [
        # name, builder, expected (must be named / must be absent), robot, frame
        ('real_log_noise_unknown', lambda: C.dupont, 'nothing established: noise not white, give --noise', DUPONT_ROBOT, 'unknown'),
        ('real_baseline', lambda: C.dupont, 'baseline verdict of the real log', DUPONT_ROBOT, 'unknown', EM_NOISE),
        ('real_backlash_t2', lambda: C.real_backlash(2, 12 * DEG), 'actuator_backlash[2] 0.2094 on top', DUPONT_ROBOT, 'unknown', EM_NOISE),
        ('real_offset_t3', lambda: C.real_offset(3, 10 * DEG), 'actuator_offset[3] 0.1745 on top', DUPONT_ROBOT, 'unknown', EM_NOISE),
        ('real_offset_t1', lambda: C.real_offset(1, 6 * DEG), 'actuator_offset[1] 0.105 on top', DUPONT_ROBOT, 'unknown', EM_NOISE),
        ('real_translation_offset_t3', lambda: C.real_offset(3, 0.003, True), 'translation_offset[3] 0.003 on top', DUPONT_ROBOT, 'unknown', EM_NOISE),
        ('path_friction', lambda: C.inject('path_friction', ['boundary_friction:mu=0.1']), 'boundary_friction', DUPONT_ROBOT, 'unknown'),
        ('path_latency', lambda: C.inject('path_latency', ['sensor_latency:delay=0.1']), 'sensor_latency', DUPONT_ROBOT, 'unknown'),
        ('path_backlash', lambda: C.inject('path_backlash', ['actuator_backlash:tube=2,width=12deg']), 'actuator_backlash', DUPONT_ROBOT, 'unknown'),
        ('path_latency_friction', lambda: C.inject('path_latency_friction', ['sensor_latency:delay=0.1', 'boundary_friction:mu=0.1']), 'boundary_friction+sensor_latency', DUPONT_ROBOT, 'unknown'),
        ('real_two_drives', lambda: C.real_two_drives(), 'actuator_backlash[2] 0.14 + actuator_offset[1] 0.105 on top', DUPONT_ROBOT, 'unknown', EM_NOISE),
        ('path_null', lambda: C.inject('path_null', []), 'none', DUPONT_ROBOT, 'unknown'),
        ('path_null_real_noise', lambda: C.inject('path_null_real_noise', [], pos_noise=1e-3, tan_noise='1.5deg'), 'none, no unexplained', DUPONT_ROBOT, 'unknown'),
        ('poses_lung_path_truth', lambda: (C.poses('poses_lung_path_truth', LUNG_ROBOT, ['--rows', '40', '--branch', 'path']), LUNG_ROBOT), 'none (followed along the path; rows on another branch than from rest listed)', None, 'base'),
        ('poses_frames_returns', lambda: (C.poses('poses_frames_returns', PAIR_B_ROBOT, ['--rows', '60', '--returns', '0.5', '--frames', '20', '--repeatability-position', '5e-4', '--repeatability-tangent', '0.3deg'], pos_noise=5e-5, tan_noise='0.02deg'), PAIR_B_ROBOT), 'none, noise from returns', None, 'base'),
        ('coincident_null', lambda: C.inject('coincident_null', [], actuation=C.coincident_actuation(), pos_noise=9e-4, tan_noise='0.5deg', sensor_frame=False), 'none, 0 failed rows', DUPONT_ROBOT, 'base'),
        ('outside_gear_ratio', lambda: C.outside('outside_gear_ratio', 'gear_ratio'), 'nothing named; described: drive ratio of tube 2', None, 'base'),
        ('outside_periodic', lambda: C.outside('outside_periodic', 'periodic'), 'nothing named; described: periodic drive error of tube 2', None, 'base'),
        ('outside_tracker_drift', lambda: C.outside('outside_tracker_drift', 'tracker_drift'), 'nothing named; described: tracker drift', None, 'base'),
        ('real_two_drives_-6', lambda: C.real_two_drives(-6), 'actuator_backlash[2] 0.14 named; actuator_offset[1] -0.105 on the log\'s +0.05 (-0.054): below its detection limit, not named', DUPONT_ROBOT, 'unknown', EM_NOISE),
        ('real_two_drives_-12', lambda: C.real_two_drives(-12), 'actuator_backlash[2] 0.14 + actuator_offset[1] -0.209 on top (-0.159)', DUPONT_ROBOT, 'unknown', EM_NOISE),
        ('coarse_friction_B', lambda: C.coarse('coarse_friction_B', PAIR_B_ROBOT, ['boundary_friction:mu=0.09'], 21), 'boundary_friction 0.09', None, 'base'),
        ('coarse_latency_friction_A', lambda: C.coarse('coarse_latency_friction_A', PAIR_A_ROBOT, ['boundary_friction:mu=0.07', 'sensor_latency:delay=0.18'], 22), 'boundary_friction 0.07 + sensor_latency 0.18', None, 'base'),
        ('coarse_friction_frame_B', lambda: C.coarse('coarse_friction_frame_B', PAIR_B_ROBOT, ['boundary_friction:mu=0.1'], 23, measure='tip_position,tip_tangent', sensor_frame=True), 'boundary_friction 0.1 (unknown frame)', None, 'unknown'),
        ('coarse_precurvature_3tube', lambda: C.coarse('coarse_precurvature_3tube', THREE_TUBE_ROBOT, ['precurvature:tube=2,curvature=%g' % C.curvature(THREE_TUBE_ROBOT, 2, 1.2)], 24, dt='0', measure='tip_position', translate=True), 'precurvature[2] x1.2', None, 'base'),
        ('coarse_glitches_friction_B', lambda: C.coarse('coarse_glitches_friction_B', PAIR_B_ROBOT, ['boundary_friction:mu=0.12'], 25, glitches=8), 'boundary_friction 0.12, 8 glitches listed', None, 'base'),
    ] + [(n, (lambda n=n: C.public(n)), 'truth: ' + (', '.join(json.load(open(os.path.join(PUBLIC, n + '.truth.json')))['verdict']) or 'none'), None, 'base')
         for n in sorted(f[:-len('.truth.json')] for f in os.listdir(PUBLIC) if f.endswith('.truth.json'))]
    print('| case | expected | verdict | fitted | unexplained (described by) | noise source | failed / off-branch / glitch rows | held-out tip error before -> after (mm) | wall s |')
    print('|---|---|---|---|---|---|---|---|---|')
    for name, build_case, expected, robot, frame, *case_extra in cases:
        if only and name not in only:
            continue
        rec = build_case()
        if isinstance(rec, tuple):
            rec, robot = rec
        j, wall = C.diagnose(name, rec, robot=robot, frame=frame, extra=(case_extra[0] if case_extra else []) + extra)
        un = j.get('unexplained')
        b = j['baseline']['heldout_rmse'].get('tip_position', float('nan')) * 1e3
        a = j['final']['heldout_rmse'].get('tip_position', float('nan')) * 1e3
        amb = []
        for f in j['findings']:
            for r in f.get('ambiguous_with', []):
                amb.append('%s~%s' % (f['effect'], r['effect']))
        described = ', '.join('%s%s' % (d['model'], '[%d]' % d['parameters']['tube'] if 'tube' in d['parameters'] else '')
                              for d in (un or {}).get('described', []))
        sources = ', '.join('%s %s%s' % (q, n['source'], '' if n['supported'] else
                                         (' (bound)' if n.get('white', True) else ' (not white)'))
                            for q, n in j['noise'].items())
        off = sum(1 for r in j.get('branch_ambiguous_rows', []) if r['excluded'])
        print('| %s | %s | %s%s | %s | %s%s | %s | %d / %d / %d | %.2f -> %.2f | %.0f |' % (
            name, expected, ', '.join(j['verdict']) or '[]', (' (ties: %s)' % ', '.join(amb)) if amb else '',
            fmt_params(j), ('%.0f %% explained' % (100 * un['fraction_explained'])) if un else '—',
            (' (%s)' % described) if described else '', sources, len(j['failed_rows']), off,
            len(j.get('outlier_rows', [])), b, a, wall), flush=True)


if __name__ == '__main__':
    main()
