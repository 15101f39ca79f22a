#!/usr/bin/env bash
# The loop of the diagnosed robot, end to end through the command line: a recording of tube pair B with concealed
# drive play, drive offset and boundary friction (ctr recording inject, 0.3 mm / 0.3 deg tracker noise) -> ctr
# diagnose --robot-out -> ctr ik --targets on the robot it found -> the commands replayed (ctr simulate) on the true
# robot. The tip must land within 2x the tracker noise of every target and >= 10x closer (RMS) than with the commands
# of the nominal description. Usage: diagnose_ik_loop.sh CTR SOURCE_DIR WORK_DIR
set -euo pipefail
CTR=$1
SRC=$2
WORK=$3
rm -rf "$WORK"
mkdir -p "$WORK"
cd "$WORK"
R="$SRC/examples/robots/tube_pair_B.yaml"

"$CTR" recording inject --robot "$R" --pattern random-walk --rows 150 --dt 0.1 --effect boundary_friction:mu=0.1 \
  --effect actuator_backlash:tube=2,width=10deg --effect actuator_offset:tube=2,offset=6deg --noise-position 0.0003 \
  --noise-tangent 0.3deg --measure tip_position,tip_tangent --seed 3 --out rec.csv --truth truth.json > /dev/null
"$CTR" diagnose --robot "$R" --recording rec.csv --json d.json --robot-out found.yaml --quiet > /dev/null

# The true robot: the nominal description with the injected effects as its drives and friction.
python3 - "$R" <<'PY'
import sys
text = open(sys.argv[1]).read()
text = text.replace("    inner_diameter: 1.97e-3\n", "    inner_diameter: 1.97e-3\n    actuation:\n"
                    "      rotation: {offset: 0.10471975511965977, play: 0.17453292519943295}\n", 1)
text = text.replace("  boundary: 0.0\n", "  boundary: 0.1\n", 1)
open("true.yaml", "w").write(text)
rows = ["alpha_1,alpha_2,beta_1,beta_2"]
for k in range(13):  # the inner tube turned up, then back (a reversal); the outer one slowly
    a2 = 0.5 + 0.08 * k if k <= 7 else 0.5 + 0.08 * 7 - 0.08 * (k - 7)
    rows.append(f"{0.02 * k},{a2},-0.018,-0.018")
open("path.csv", "w").write("\n".join(rows) + "\n")
PY
"$CTR" simulate --robot true.yaml --actuation path.csv --out true_path.csv > /dev/null
python3 - <<'PY'
import csv
rows = list(csv.DictReader(open("true_path.csv")))[1:]  # the targets: where the true robot's tip went
open("targets.csv", "w").write("tip_x,tip_y,tip_z\n" + "".join(f'{r["tip_x"]},{r["tip_y"]},{r["tip_z"]}\n' for r in rows))
PY
for robot in found.yaml "$R"; do
  name=$(basename "$robot" .yaml)
  # Exit 1 when a target is not reached exactly (e.g. at a fold): the commands are still written and judged below.
  "$CTR" ik --robot "$robot" --targets targets.csv --from-alpha 0,0.5 --from-beta -0.018,-0.018 \
    --out "cmd_$name.csv" --json "ik_$name.json" > /dev/null 2> "ik_$name.err" || [ $? -eq 1 ]
  "$CTR" simulate --robot true.yaml --actuation "cmd_$name.csv" --out "sim_$name.csv" > /dev/null
done

python3 - <<'PY'
import csv, json, math, sys
verdict = json.load(open("d.json"))["verdict"]
ok = set(verdict) == {"boundary_friction", "actuator_backlash", "actuator_offset"}
targets = [tuple(float(r[c]) for c in ("tip_x", "tip_y", "tip_z")) for r in csv.DictReader(open("targets.csv"))]
errors = {}
for name in ("found", "tube_pair_B"):
    sim = list(csv.DictReader(open(f"sim_{name}.csv")))[-len(targets):]  # after the rows that reach the start
    e = [math.dist(t, tuple(float(r[c]) for c in ("tip_x", "tip_y", "tip_z"))) for t, r in zip(targets, sim)]
    errors[name] = (max(e), math.sqrt(sum(x * x for x in e) / len(e)))
    print(f"{name}: worst {1e3 * max(e):.3f} mm, rms {1e3 * errors[name][1]:.3f} mm")
noise = 0.3e-3
if not ok:
    print(f"FAIL: verdict {verdict}")
if errors["found"][0] > 2 * noise:
    print(f"FAIL: the diagnosed robot's commands leave the tip {1e3 * errors['found'][0]:.3f} mm off (> 2 x noise)")
    ok = False
if errors["tube_pair_B"][1] < 10 * errors["found"][1]:
    print("FAIL: the nominal description's commands are not 10x farther (RMS)")
    ok = False
sys.exit(0 if ok else 1)
PY
