#!/usr/bin/env python3
"""Forward prediction of the real Dupont-lab log: the robot description written from its first part predicts the rest.

    python3 scripts/forward_prediction.py BUILD_DIR OUT_DIR [--fraction 0.6]

1. The log (../shared/data/dupont-lab-ctr-trajectory-hjhdog1, imported with `ctr recording import`) is split in
   the order taken: the first FRACTION of its rows are the training part, the rest is held out.
2. `ctr diagnose --frame unknown --noise <EM tracker> --robot-out found.yaml` on the training part writes the robot
   the diagnosis found; the same diagnosis with `--max-effects 0` gives the nominal description's own registration.
3. `ctr simulate` replays the whole log's commands (its first part included: the friction memory and the plays are
   where the commands put them) with the nominal and the found description.
4. On the held-out rows only, each prediction is mapped into the tracker's frame with the registration fitted on the
   training part (sensor point = R (tip + tip_offset t) + p) and compared with the measured tip: RMS, median and 95th
   percentile of the tip-position error. The recording's own effects (a sensor latency) are not part of a robot
   description; the found robot is scored without them and, separately, with the latency fitted on the training part
   applied to the held-out commands (the measurement at t shows the command at t - delay).

Prints a Markdown table; writes OUT_DIR/forward_prediction.json.
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from known_answer_cases import DATA, DUPONT_ROBOT, DUPONT_TXT, EM_NOISE, require_data  # noqa: E402


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(' '.join(cmd) + '\n' + r.stderr[-2000:])
    return r


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def write_csv(path, header, rows):
    with open(path, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def delayed(commands, time, delay):
    """The commands at t - delay (linear in time between logged rows; held at the ends)."""
    out, j = [], 0
    for t in time:
        t -= delay
        if t <= time[0]:
            out.append(commands[0])
            continue
        if t >= time[-1]:
            out.append(commands[-1])
            continue
        while j + 1 < len(time) and time[j + 1] < t:
            j += 1
        while j > 0 and time[j] > t:
            j -= 1
        t0, t1 = time[j], time[j + 1]
        w = (t - t0) / (t1 - t0) if t1 > t0 else 0.0
        out.append([a + w * (b - a) for a, b in zip(commands[j], commands[j + 1])])
    return out


def registered(reg, row, col):
    tip = [float(row[col['tip_' + a]]) for a in 'xyz']
    tan = [float(row[col['tip_t' + a]]) for a in 'xyz']
    s = [tip[i] + reg['tip_offset'] * tan[i] for i in range(3)]
    return [sum(reg['rotation'][i][k] * s[k] for k in range(3)) + reg['translation'][i] for i in range(3)]


def errors(sim_path, measured, col_m, held_out, reg):
    h, rows = read_csv(sim_path)
    col = {c: i for i, c in enumerate(h)}
    out = []
    for k in held_out:
        if rows[k][col['tip_x']] == '':
            return None  # a row the model could not reach: no prediction
        p = registered(reg, rows[k], col)
        m = [float(measured[k][col_m['tip_' + a]]) for a in 'xyz']
        out.append(math.dist(p, m))
    return out


def stats(e):
    s = sorted(e)
    return {'rms_mm': 1e3 * math.sqrt(sum(x * x for x in e) / len(e)), 'median_mm': 1e3 * s[len(s) // 2],
            'p95_mm': 1e3 * s[min(len(s) - 1, int(0.95 * len(s)))], 'max_mm': 1e3 * s[-1]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('build')
    ap.add_argument('out')
    ap.add_argument('--fraction', type=float, default=0.6)
    a = ap.parse_args()
    require_data('dupont-lab-ctr-trajectory-hjhdog1')
    ctr = os.path.join(a.build, 'apps', 'ctr')
    os.makedirs(a.out, exist_ok=True)
    log = os.path.join(a.out, 'dupont.csv')
    run([ctr, 'recording', 'import', '--format', 'dupont-lab', '--input', DUPONT_TXT, '--out', log])
    header, rows = read_csv(log)
    col = {c: i for i, c in enumerate(header)}
    n_train = int(round(a.fraction * len(rows)))
    train = os.path.join(a.out, 'train.csv')
    write_csv(train, header, rows[:n_train])
    held_out = list(range(n_train, len(rows)))

    found_yaml = os.path.join(a.out, 'found.yaml')
    found_json, nominal_json = os.path.join(a.out, 'found.json'), os.path.join(a.out, 'nominal.json')
    common = ['--robot', DUPONT_ROBOT, '--recording', train, '--frame', 'unknown', '--quiet'] + EM_NOISE
    run([ctr, 'diagnose'] + common + ['--json', found_json, '--robot-out', found_yaml])
    run([ctr, 'diagnose'] + common + ['--json', nominal_json, '--max-effects', '0'])
    found, nominal = json.load(open(found_json)), json.load(open(nominal_json))

    joints = [c for c in header if c.startswith('alpha_') or c.startswith('beta_')]
    commands = [[float(r[col[c]]) for c in joints] for r in rows]
    time = [float(r[col['time']]) for r in rows]
    act = os.path.join(a.out, 'commands.csv')
    write_csv(act, joints + ['time'], [c + [t] for c, t in zip(commands, time)])
    latency = [e for e in found['final'].get('effects', []) if e['effect'] == 'sensor_latency']
    act_delayed = os.path.join(a.out, 'commands_delayed.csv')
    if latency:
        write_csv(act_delayed, joints + ['time'],
                  [c + [t] for c, t in zip(delayed(commands, time, latency[0]['delay']), time)])

    result = {'log_rows': len(rows), 'training_rows': n_train, 'held_out_rows': len(held_out),
              'found_effects': found['final'].get('effects', []), 'models': {}}
    cases = [('nominal description', DUPONT_ROBOT, act, nominal['registration']),
             ('found description (robot only)', found_yaml, act, found['registration'])]
    if latency:
        cases.append(('found description + the log\'s latency (%.3f s)' % latency[0]['delay'], found_yaml,
                      act_delayed, found['registration']))
    for name, robot, actuation, reg in cases:
        sim = os.path.join(a.out, 'sim_%d.csv' % len(result['models']))
        run([ctr, 'simulate', '--robot', robot, '--actuation', actuation, '--out', sim, '--allow-failures'])
        e = errors(sim, rows, col, held_out, reg)
        result['models'][name] = stats(e) if e else None
    with open(os.path.join(a.out, 'forward_prediction.json'), 'w') as f:
        json.dump(result, f, indent=1)
    print('Held-out rows %d-%d of %d (the last %.0f %%), trained on rows 1-%d\n'
          % (n_train + 1, len(rows), len(rows), 100 * (1 - a.fraction), n_train))
    print('| description | RMS (mm) | median (mm) | 95th pct (mm) | max (mm) |')
    print('|---|---|---|---|---|')
    for name, s in result['models'].items():
        if s is None:
            print('| %s | not every held-out row reached | | | |' % name)
        else:
            print('| %s | %.2f | %.2f | %.2f | %.2f |' % (name, s['rms_mm'], s['median_mm'], s['p95_mm'], s['max_mm']))
    print('\nFound on the training part: ' + '; '.join(
        '%s%s' % (e['effect'], '[%d]' % e['tube'] if 'tube' in e else '') for e in result['found_effects']))


if __name__ == '__main__':
    main()
