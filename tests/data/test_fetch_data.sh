#!/usr/bin/env bash
# Tests scripts/fetch-data.sh offline, against local file:// git mirrors of the two upstream repositories.
#
# Usage: tests/data/test_fetch_data.sh [SCRIPT [DATA_DIR [CTR_EXE]]]
#   SCRIPT    scripts/fetch-data.sh (default: the one of this checkout)
#   DATA_DIR  a data folder that has the data sets (default: $CTR_DATA, else ../shared/data beside the checkout, else
#             data/ in the checkout); its files are committed into the mirrors
#   CTR_EXE   the `ctr` command: then the README's commands also run, in an empty folder that has only the checkout's
#             examples/ and build/apps/ctr, against the data fetched from the mirrors (CTR_DATA) and nothing else
# Exit status: 0 passed, 1 failed, 77 skipped (no git, or no data to build the mirrors from).
#
# How: the mirrors are bare repositories in a temporary folder, laid out as the upstream ones (Med-MPD: Data/... and
# README.md; ConcentricTubes: files at the root; the paths come from `fetch-data.sh --list`) and reached as
# CTR_DATA_MIRROR=file://TMP/mirrors. Their commits are new (not the pinned ones), so the test points the script at
# them with CTR_DATA_MEDMPD_COMMIT / CTR_DATA_DUPONT_COMMIT; the files must still match the pinned sums. Each mirror
# gets a second commit with a broken file (Med-MPD: one byte appended; ConcentricTubes: one file removed) for the
# failure cases. CTR_DATA is always set, so only temporary folders are read and written; everything is removed at
# the end.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
SCRIPT=${1:-$ROOT/scripts/fetch-data.sh}
SRC=${2:-}
EXE=${3:-}
if [[ -z "$SRC" ]]; then
  if [[ -n "${CTR_DATA:-}" ]]; then SRC=$CTR_DATA
  elif [[ -d "$ROOT/../shared/data" ]]; then SRC=$ROOT/../shared/data
  else SRC=$ROOT/data
  fi
fi
SUMS="$(cd "$(dirname "$SCRIPT")" && pwd)/fetch-data.sha256"

command -v git > /dev/null || { echo "SKIP: git is not installed"; exit 77; }
for s in med-mpd dupont-lab-ctr-trajectory-hjhdog1; do
  [[ -d "$SRC/$s" ]] || { echo "SKIP: no $SRC/$s to build the mirrors from (run scripts/fetch-data.sh)"; exit 77; }
done

T=$(mktemp -d "${TMPDIR:-/tmp}/ctr-test-fetch-data.XXXXXX")
trap 'rm -rf -- "$T"' EXIT
mkdir -p "$T/tmp" "$T/home"
# A clean git and temporary folder: no user or system configuration, and the script's own temporaries land in $T/tmp.
export HOME="$T/home" GIT_CONFIG_NOSYSTEM=1 TMPDIR="$T/tmp" LC_ALL=C
export GIT_AUTHOR_NAME=ctr-test GIT_AUTHOR_EMAIL=ctr-test@example.invalid
export GIT_COMMITTER_NAME=ctr-test GIT_COMMITTER_EMAIL=ctr-test@example.invalid
unset CTR_DATA CTR_DATA_MIRROR CTR_DATA_MEDMPD_COMMIT CTR_DATA_DUPONT_COMMIT GIT_DIR GIT_WORK_TREE GIT_INDEX_FILE

FAILS=0
pass() { echo "ok   - $*"; }
fail() { echo "FAIL - $*"; FAILS=$((FAILS + 1)); }
# run NAME [ENV=VALUE...] -- ARGS...: runs the script; status in $RC, output in $T/NAME.out / $T/NAME.err.
run() {
  local name=$1; shift
  local envs=()
  while [[ "$1" != -- ]]; do envs+=("$1"); shift; done
  shift
  RC=0
  env "${envs[@]}" bash "$SCRIPT" "$@" > "$T/$name.out" 2> "$T/$name.err" || RC=$?
}
show() { sed 's/^/    | /' "$T/$1.out" "$T/$1.err"; }
expect_rc() {  # NAME WANT(0 | nonzero) WHAT
  if [[ "$2" == 0 && "$RC" == 0 ]] || [[ "$2" == nonzero && "$RC" != 0 ]]; then pass "$3 (exit $RC)"
  else fail "$3: exit $RC, expected $2"; show "$1"; fi
}
expect_text() {  # NAME TEXT WHAT
  if grep -qF -- "$2" "$T/$1.out" "$T/$1.err"; then pass "$3"; else fail "$3: no '$2' in the output"; show "$1"; fi
}
expect_gone() {  # PATH WHAT
  if [[ ! -e "$1" ]]; then pass "$2"; else fail "$2: $1 exists"; find "$1" -maxdepth 2 | sed 's/^/    | /'; fi
}
tmp_empty() {  # WHAT: the script left no temporary folder behind
  if [[ -z "$(ls -A "$T/tmp")" ]]; then pass "$1"; else fail "$1: left $(ls -A "$T/tmp")"; fi
}
# The files of a folder with their inodes, sizes and times (any rewrite shows), and its sub-folders.
state() { find "$1" \( -type f -printf '%p %i %s %T@\n' \) -o \( -type d -printf '%p/\n' \) | sort; }

# --- The mirrors ----------------------------------------------------------------------------------------------------
bash "$SCRIPT" --list > "$T/list.tsv"
[[ -s "$T/list.tsv" ]] || { echo "FAIL - fetch-data.sh --list printed nothing"; exit 1; }

# make_mirror SET: a bare repository at mirrors/OWNER/NAME.git with the files of SET at their upstream paths, plus a
# file of its own (so its commit is not the pinned one); prints the commit.
make_mirror() {
  local set=$1 repo git idx blobs
  repo=$(awk -F'\t' -v s="$set" '$1 == s { print $2; exit }' "$T/list.tsv")
  git="$T/mirrors/$repo.git"
  idx="$T/index.$set"
  git init -q --bare "$git"
  # Speed: the files are compressed already; no zlib and no delta search when the script fetches from the mirror.
  git --git-dir="$git" config core.looseCompression 0
  git --git-dir="$git" config pack.compression 0
  git --git-dir="$git" config pack.window 0
  awk -F'\t' -v s="$set" -v d="$SRC/$set/" '$1 == s { print d $5 }' "$T/list.tsv" > "$T/paths.$set"
  blobs=$(git --git-dir="$git" hash-object -w --stdin-paths < "$T/paths.$set")
  paste <(printf '%s\n' "$blobs") <(awk -F'\t' -v s="$set" '$1 == s { print $4 }' "$T/list.tsv") |
    awk -F'\t' '{ printf "100644 %s\t%s\n", $1, $2 }' > "$T/index-info.$set"
  printf 'Test mirror of %s, built by tests/data/test_fetch_data.sh\n' "$repo" |
    git --git-dir="$git" hash-object -w --stdin |
    awk '{ printf "100644 %s\tTEST-MIRROR.md\n", $1 }' >> "$T/index-info.$set"
  GIT_INDEX_FILE=$idx git --git-dir="$git" update-index --index-info < "$T/index-info.$set"
  local tree commit
  tree=$(GIT_INDEX_FILE=$idx git --git-dir="$git" write-tree)
  commit=$(git --git-dir="$git" commit-tree "$tree" -m "test mirror of $repo")
  git --git-dir="$git" update-ref refs/heads/main "$commit"
  git --git-dir="$git" symbolic-ref HEAD refs/heads/main
  echo "$commit"
}
# broken_commit SET UPSTREAM_PATH corrupt|remove: a second commit on the mirror of SET that breaks one file.
broken_commit() {
  local set=$1 path=$2 how=$3 repo git idx blob tree commit
  repo=$(awk -F'\t' -v s="$set" '$1 == s { print $2; exit }' "$T/list.tsv")
  git="$T/mirrors/$repo.git"
  idx="$T/index.$set"
  if [[ "$how" == corrupt ]]; then
    blob=$({ git --git-dir="$git" cat-file blob "HEAD:$path"; printf 'x'; } | git --git-dir="$git" hash-object -w --stdin)
    GIT_INDEX_FILE=$idx git --git-dir="$git" update-index --cacheinfo "100644,$blob,$path"
  else
    printf '0 0000000000000000000000000000000000000000\t%s\n' "$path" |
      GIT_INDEX_FILE=$idx git --git-dir="$git" update-index --index-info
  fi
  tree=$(GIT_INDEX_FILE=$idx git --git-dir="$git" write-tree)
  commit=$(git --git-dir="$git" commit-tree "$tree" -p HEAD -m "broken: $how $path")
  git --git-dir="$git" update-ref refs/heads/broken "$commit"
  echo "$commit"
}

MED_GOOD=$(make_mirror med-mpd)
DUP_GOOD=$(make_mirror dupont-lab-ctr-trajectory-hjhdog1)
MED_BAD=$(broken_commit med-mpd Data/Lungs/Patient1/target.txt corrupt)
DUP_BAD=$(broken_commit dupont-lab-ctr-trajectory-hjhdog1 jointTipTrajectory_measured_short.txt remove)
MIRROR="file://$T/mirrors"
GOOD=(CTR_DATA_MIRROR="$MIRROR" CTR_DATA_MEDMPD_COMMIT="$MED_GOOD" CTR_DATA_DUPONT_COMMIT="$DUP_GOOD")
echo "mirrors: Med-MPD $MED_GOOD (broken $MED_BAD), ConcentricTubes $DUP_GOOD (broken $DUP_BAD)"
repo_data_before=$([[ -e "$ROOT/data" ]] && echo yes || echo no)

# --- 1. --help --------------------------------------------------------------------------------------------------------
run help -- --help
expect_rc help 0 "--help"
expect_text help CTR_DATA_MIRROR "--help documents CTR_DATA_MIRROR"

# --- 2. A fetch into an empty CTR_DATA ------------------------------------------------------------------------------
D="$T/data"
run fetch1 CTR_DATA="$D" "${GOOD[@]}" --
expect_rc fetch1 0 "fetch from the local mirrors"
if (cd "$D" 2> /dev/null && sha256sum -c --quiet "$SUMS" > "$T/sums.out" 2>&1); then
  pass "every file present with its pinned SHA-256 ($(grep -cv '^#' "$SUMS") files)"
else
  fail "files missing or with a wrong SHA-256 after the fetch"; sed -n 's/^/    | /; 1,10p' "$T/sums.out"
fi
for s in med-mpd dupont-lab-ctr-trajectory-hjhdog1; do
  if [[ -f "$D/$s/PROVENANCE.md" ]] && (cd "$D/$s" && sha256sum -c --quiet SHA256SUMS > /dev/null 2>&1); then
    pass "$s has PROVENANCE.md and a SHA256SUMS that checks"
  else fail "$s lacks PROVENANCE.md or a good SHA256SUMS"; fi
done
extra=$(find "$D" -mindepth 1 -name '.*' -print -quit)
if [[ -z "$extra" ]]; then pass "no temporary folder left in the data folder"; else fail "left in $D: $extra"; fi
tmp_empty "no temporary folder left in TMPDIR after a fetch"

# --- 3. A second run does nothing (the mirror is not even reachable) ---------------------------------------------
before=$(state "$D")
run fetch2 CTR_DATA="$D" CTR_DATA_MIRROR="file://$T/nowhere" --
expect_rc fetch2 0 "second run"
expect_text fetch2 "nothing to do" "second run says there is nothing to do"
if [[ "$(state "$D")" == "$before" ]]; then pass "second run left every file untouched"; else fail "second run changed the data folder"; fi

# --- 4. --check ---------------------------------------------------------------------------------------------------
run check1 CTR_DATA="$D" -- --check
expect_rc check1 0 "--check on good data"
run check0 CTR_DATA="$T/empty" -- --check
expect_rc check0 nonzero "--check on a folder without data"
expect_gone "$T/empty" "--check creates nothing"

# --- 5. A corrupted file in the mirror ----------------------------------------------------------------------------
B="$T/data-bad"
run corrupt CTR_DATA="$B" CTR_DATA_MIRROR="$MIRROR" CTR_DATA_MEDMPD_COMMIT="$MED_BAD" CTR_DATA_DUPONT_COMMIT="$DUP_GOOD" --
expect_rc corrupt nonzero "corrupted mirror file"
expect_text corrupt "Lungs/Patient1/target.txt" "the error names the corrupted file"
expect_text corrupt "data set med-mpd" "the error names the data set"
expect_gone "$B" "no data folder left behind after a SHA-256 mismatch"
tmp_empty "no temporary folder left in TMPDIR after a mismatch"

# --- 6. A file missing in the mirror ------------------------------------------------------------------------------
run missing CTR_DATA="$B" CTR_DATA_MIRROR="$MIRROR" CTR_DATA_MEDMPD_COMMIT="$MED_GOOD" CTR_DATA_DUPONT_COMMIT="$DUP_BAD" --
expect_rc missing nonzero "file missing in the mirror"
expect_text missing "jointTipTrajectory_measured_short.txt" "the error names the missing file"
expect_text missing "data set dupont-lab-ctr-trajectory-hjhdog1" "the error names its data set"
expect_gone "$B" "no data folder left behind after a missing file"

# --- 7. The source cannot be reached ------------------------------------------------------------------------------
run unreachable CTR_DATA="$B" CTR_DATA_MIRROR="file://$T/nowhere" --
expect_rc unreachable nonzero "unreachable source"
expect_text unreachable "cannot fetch from file://$T/nowhere/UNC-Robotics/Med-MPD.git" "the error names the source"
expect_gone "$B" "no data folder left behind when the source cannot be reached"

# --- 8. Damaged local data: --check fails, a failed re-fetch keeps what was there, a good one repairs -----------------
printf 'x' >> "$D/med-mpd/Brain/Patient1/target1.txt"
dupont_before=$(state "$D/dupont-lab-ctr-trajectory-hjhdog1")
run check2 CTR_DATA="$D" -- --check
expect_rc check2 nonzero "--check on a damaged file"
expect_text check2 "Brain/Patient1/target1.txt" "--check names the damaged file"
damaged=$(state "$D")
run refetch_bad CTR_DATA="$D" CTR_DATA_MIRROR="$MIRROR" CTR_DATA_MEDMPD_COMMIT="$MED_BAD" CTR_DATA_DUPONT_COMMIT="$DUP_GOOD" --
expect_rc refetch_bad nonzero "re-fetch from a corrupted mirror"
if [[ "$(state "$D")" == "$damaged" ]]; then pass "a failed re-fetch changes nothing"; else fail "a failed re-fetch changed $D"; fi
run refetch CTR_DATA="$D" "${GOOD[@]}" --
expect_rc refetch 0 "re-fetch repairs the damaged data set"
run check3 CTR_DATA="$D" -- --check
expect_rc check3 0 "--check after the repair"
if [[ "$(state "$D/dupont-lab-ctr-trajectory-hjhdog1")" == "$dupont_before" ]]; then
  pass "the intact data set was not fetched again"
else fail "the intact data set was rewritten"; fi
tmp_empty "no temporary folder left in TMPDIR at the end"

# --- 9. The README's commands, from a folder with the examples and the fetched data only ------------------------------
# Every command of the README's "Using the command" block except the benchmark campaigns and the design search (minutes;
# their own tests run them: Campaign.*, Cli.Bench*, DesignSearch.*), in the README's order (view reads plan's path).
if [[ -n "$EXE" ]]; then
  W="$T/clone"
  mkdir -p "$W/build/apps"
  ln -s "$ROOT/examples" "$W/examples"
  ln -s "$EXE" "$W/build/apps/ctr"
  awk '/^## Using the command/ { f = 1 } f && /^```sh/ { b = 1; next } b && /^```/ { exit } b' "$ROOT/README.md" |
    awk '{ if (sub(/\\$/, "")) { line = line $0; next } print line $0; line = "" }' |
    grep -v '^[[:space:]]*#' | grep -Ev 'ctr (bench|design) ' > "$T/readme.sh"
  n=0
  while IFS= read -r cmd; do
    [[ -n "${cmd// /}" ]] || continue
    n=$((n + 1))
    RC=0
    (cd "$W" && env CTR_DATA="$D" bash -c "$cmd") > "$T/readme$n.out" 2> "$T/readme$n.err" || RC=$?
    if [[ "$RC" == 0 ]]; then pass "README: ${cmd:0:100}"
    elif [[ "$RC" == 2 ]] && grep -q "built without HTML reports" "$T/readme$n.err"; then
      pass "README (skipped: this ctr was built without the HTML reports): ${cmd:0:80}"
    else fail "README (exit $RC): $cmd"; show "readme$n"; fi
  done < "$T/readme.sh"
  if ((n >= 10)); then pass "$n README commands run"; else fail "only $n README commands found"; fi
  # A missing data set: one message naming the script.
  RC=0
  (cd "$W" && env CTR_DATA="$T/empty" build/apps/ctr env info examples/environments/medmpd_lung_patient1.yaml) \
    > "$T/nodata.out" 2> "$T/nodata.err" || RC=$?
  if [[ "$RC" == 2 ]]; then pass "no Med-MPD data: exit 2"; else fail "no Med-MPD data: exit $RC"; show nodata; fi
  expect_text nodata "scripts/fetch-data.sh" "no Med-MPD data: the message names scripts/fetch-data.sh"
fi

repo_data_after=$([[ -e "$ROOT/data" ]] && echo yes || echo no)
if [[ "$repo_data_before" == "$repo_data_after" ]]; then pass "the checkout's data/ was not touched"
else fail "the checkout's data/ appeared or disappeared"; fi

if ((FAILS)); then echo "$FAILS check(s) failed"; exit 1; fi
echo "all checks passed"
