#!/usr/bin/env bash
# Fetches the public data sets that tests, examples and benchmarks read (Med-MPD planning environments, the
# Dupont-lab CTR trajectory) from their upstream git repositories at pinned commits into one data folder, and checks
# the SHA-256 of every file against scripts/fetch-data.sha256. Run with --help for the details.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
SUMS="$ROOT/scripts/fetch-data.sha256"
SHARED_DATA="$ROOT/../shared/data"   # beside the checkout (developer machines, CI); read-only, never written

# --- Pinned upstream commits (the sums in scripts/fetch-data.sha256 are those of the files at these commits) -------
# UNC-Robotics/Med-MPD: commit of 2023-10-24 ("Update README.md"), as recorded in ../shared/data/med-mpd/PROVENANCE.md.
PINNED_MEDMPD_COMMIT=6ae6237480c83fe1be4b01f688f4370568d588cb
# hjhdog1/ConcentricTubes: commit of 2018-07-03 ("number of tubes was hard coded").
PINNED_DUPONT_COMMIT=0f18402ad98c667ae447c4f696f8b7a768183ee3

DATA_SETS=(med-mpd dupont-lab-ctr-trajectory-hjhdog1)

usage() {
  cat <<EOF
Usage: scripts/fetch-data.sh [--check | --list | --help]

Fetches the public data sets into one data folder and verifies every file against the pinned SHA-256 sums of
scripts/fetch-data.sha256:
  med-mpd/                            github.com/UNC-Robotics/Med-MPD at $PINNED_MEDMPD_COMMIT
                                      (folder Data/ and README.md, kept as README.upstream.md); CC BY-NC-SA 4.0
  dupont-lab-ctr-trajectory-hjhdog1/  github.com/hjhdog1/ConcentricTubes at $PINNED_DUPONT_COMMIT
                                      (jointTipTrajectory_measured_{short,permuted}.txt); no licence file upstream
Each data set folder also gets a PROVENANCE.md and a SHA256SUMS written by this script.

The data folder (CMake, the Python tests and scripts/*.py look it up the same way):
  \$CTR_DATA if set (then only that folder counts), else ../shared/data beside the checkout if it exists (read
  only: CI and the developer machines have it), else data/ at the repository root (ignored by git).
Without CTR_DATA: nothing is done when ../shared/data has every data set with the right sums; otherwise the data
sets that are not already in data/ with the right sums are fetched into data/ (set CTR_DATA to that folder if
../shared/data exists, since it is looked at first).
Nothing is written unless every file of every fetched data set checks: the files are fetched into a temporary
folder inside the data folder and moved into place at the end (a data set folder that failed its check is then
replaced; the others are left alone). A data folder created by a failed run is removed.

Options:
  --check   verify only, in the data folder the project reads: every file of every data set present with the
            right SHA-256; exit 0 if so, 1 if not (naming each file that does not check)
  --list    print the files fetched, tab-separated: data set, repository, commit, upstream path, local path, SHA-256
  --help    this text

Environment:
  CTR_DATA                 the data folder (see above)
  CTR_DATA_MIRROR          base URL of the git repositories (default https://github.com): they are fetched from
                           \$CTR_DATA_MIRROR/UNC-Robotics/Med-MPD.git and \$CTR_DATA_MIRROR/hjhdog1/ConcentricTubes.git,
                           e.g. CTR_DATA_MIRROR=file:///srv/mirrors for an offline mirror
  CTR_DATA_MEDMPD_COMMIT   commit id (or branch or tag) to take Med-MPD from instead of the pinned commit
  CTR_DATA_DUPONT_COMMIT   the same for ConcentricTubes. For mirrors whose history differs from upstream (the test
                           tests/data/test_fetch_data.sh builds such mirrors): the files must still have the pinned
                           sums, which are never overridden

Exit status: 0 data present and verified; 1 a check failed, or the source could not be reached; 2 usage error.
EOF
}

say() { printf 'fetch-data: %s\n' "$*"; }
err() { printf 'fetch-data: error: %s\n' "$*" >&2; }
die() { err "$@"; exit 1; }

# --- Arguments ------------------------------------------------------------------------------------------------------
MODE=fetch
for arg in "$@"; do
  case "$arg" in
    -h|--help) usage; exit 0 ;;
    --check) MODE=check ;;
    --list) MODE=list ;;
    *) err "unknown argument '$arg' (see --help)"; exit 2 ;;
  esac
done

# --- The data sets: upstream repository, commit, licence, and where each local file comes from --------------------
repo_of() {
  case "$1" in
    med-mpd) echo "UNC-Robotics/Med-MPD" ;;
    dupont-lab-ctr-trajectory-hjhdog1) echo "hjhdog1/ConcentricTubes" ;;
  esac
}
pinned_of() {
  case "$1" in
    med-mpd) echo "$PINNED_MEDMPD_COMMIT" ;;
    dupont-lab-ctr-trajectory-hjhdog1) echo "$PINNED_DUPONT_COMMIT" ;;
  esac
}
# The commit fetched: the pinned one unless CTR_DATA_MEDMPD_COMMIT / CTR_DATA_DUPONT_COMMIT override it.
commit_of() {
  case "$1" in
    med-mpd) echo "${CTR_DATA_MEDMPD_COMMIT:-$(pinned_of "$1")}" ;;
    dupont-lab-ctr-trajectory-hjhdog1) echo "${CTR_DATA_DUPONT_COMMIT:-$(pinned_of "$1")}" ;;
  esac
}
licence_of() {
  case "$1" in
    med-mpd)
      echo "CC BY-NC-SA 4.0 (non-commercial, share-alike; see README.upstream.md; also the TCIA data usage terms)" ;;
    dupont-lab-ctr-trajectory-hjhdog1)
      echo "none: the upstream repository has no licence file (default copyright); reference use only, do not redistribute" ;;
  esac
}
# Sets UP to the path in the upstream repository of a local file (relative to its data set folder).
upstream_path() {
  case "$1" in
    med-mpd)
      case "$2" in
        README.upstream.md) UP="README.md" ;;
        # the upstream name has a space: 'brainStructures.DKTatlas+aseg. deep.mgz'
        Brain/Patient2/brainStructures.DKTatlas+aseg.deep.mgz)
          UP="Data/Brain/Patient2/brainStructures.DKTatlas+aseg. deep.mgz" ;;
        *) UP="Data/$2" ;;
      esac ;;
    dupont-lab-ctr-trajectory-hjhdog1) UP="$2" ;;  # the repository root
  esac
}

# --- The pinned sums ----------------------------------------------------------------------------------------------
[[ -r "$SUMS" ]] || die "the sums file $SUMS is missing"
SUM_SET=() SUM_HASH=() SUM_PATH=()
while IFS= read -r line || [[ -n "$line" ]]; do
  [[ -z "$line" || "$line" == \#* ]] && continue
  if [[ ! "$line" =~ ^([0-9a-f]{64})\ \ ([^/]+)/(.+)$ ]]; then
    die "$SUMS: bad line '$line' (expected: SHA256, two spaces, DATA_SET/PATH)"
  fi
  SUM_HASH+=("${BASH_REMATCH[1]}") SUM_SET+=("${BASH_REMATCH[2]}") SUM_PATH+=("${BASH_REMATCH[3]}")
done < "$SUMS"
count_of() { local n=0 x; for x in "${SUM_SET[@]}"; do [[ "$x" == "$1" ]] && n=$((n + 1)); done; echo "$n"; }
for s in "${DATA_SETS[@]}"; do
  (($(count_of "$s") > 0)) || die "$SUMS lists no file of the data set $s"
done

if [[ "$MODE" == list ]]; then
  for i in "${!SUM_PATH[@]}"; do
    s=${SUM_SET[$i]}
    upstream_path "$s" "${SUM_PATH[$i]}"
    printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$s" "$(repo_of "$s")" "$(commit_of "$s")" "$UP" "${SUM_PATH[$i]}" \
      "${SUM_HASH[$i]}"
  done
  exit 0
fi

if command -v sha256sum > /dev/null 2>&1; then
  SHA256=(sha256sum --)
elif command -v shasum > /dev/null 2>&1; then
  SHA256=(shasum -a 256 --)
else
  die "neither sha256sum (GNU coreutils) nor shasum is installed: cannot check the data"
fi
# Sets GOT to the SHA-256 of each of the files given (in one run of the tool; the files must exist).
sha256_many() {
  local line
  GOT=()
  (($# > 0)) || return 0
  while IFS= read -r line; do
    line=${line#\\}   # a name with a backslash or a newline: the line starts with a backslash
    GOT+=("${line:0:64}")
  done < <("${SHA256[@]}" "$@")
  (($# == ${#GOT[@]})) || die "${SHA256[0]} gave ${#GOT[@]} sums for $# files"
}

# Checks the data set SET in the folder DIR: prints one line per problem (naming the file and the data set) to
# stderr unless QUIET=1; returns 0 when every file is there with its pinned sum.
check_set() {
  local dir=$1 set=$2 quiet=${3:-0} bad=0 i k f files=() idx=()
  if [[ ! -d "$dir/$set" ]]; then
    ((quiet)) || err "data set $set: missing folder $dir/$set"
    return 1
  fi
  report() {  # at most 10 lines per data set
    bad=$((bad + 1))
    if ((quiet)); then return 0; fi
    if ((bad <= 10)); then err "$1"; elif ((bad == 11)); then err "data set $set: (more files do not check)"; fi
  }
  for i in "${!SUM_PATH[@]}"; do
    [[ "${SUM_SET[$i]}" == "$set" ]] || continue
    f="$dir/$set/${SUM_PATH[$i]}"
    if [[ -f "$f" ]]; then
      files+=("$f") idx+=("$i")
    else
      report "data set $set: missing file $f"
    fi
  done
  sha256_many "${files[@]}"
  for k in "${!files[@]}"; do
    i=${idx[$k]}
    if [[ "${GOT[$k]}" != "${SUM_HASH[$i]}" ]]; then
      report "data set $set: SHA-256 mismatch for ${files[$k]} (expected ${SUM_HASH[$i]}, got ${GOT[$k]})"
    fi
  done
  ((bad == 0))
}

abs_path() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }

# --- The data folder ------------------------------------------------------------------------------------------------
if [[ -n "${CTR_DATA:-}" ]]; then
  DEST=${CTR_DATA%/}
  DEST=$(abs_path "${DEST:-/}")
  WHERE="CTR_DATA"
elif [[ -d "$SHARED_DATA" ]]; then
  DEST=$(cd "$SHARED_DATA" && pwd)
  WHERE="../shared/data beside the checkout"
else
  DEST="$ROOT/data"
  WHERE="data/ in the repository"
fi

if [[ "$MODE" == check ]]; then
  status=0
  for s in "${DATA_SETS[@]}"; do
    if check_set "$DEST" "$s"; then
      say "ok: $s ($(count_of "$s") files) in $DEST"
    else
      status=1
    fi
  done
  if ((status)); then
    if [[ -z "${CTR_DATA:-}" && -d "$SHARED_DATA" ]]; then
      err "the data in $DEST ($WHERE) do not check; for a copy of your own: export CTR_DATA=$ROOT/data; scripts/fetch-data.sh"
    else
      err "the data in $DEST ($WHERE) do not check; run scripts/fetch-data.sh to fetch them"
    fi
  else
    say "all data sets verified in $DEST ($WHERE)"
  fi
  exit $status
fi

# --- Fetch mode: what is already there -----------------------------------------------------------------------------
if [[ -z "${CTR_DATA:-}" ]]; then
  if [[ -d "$SHARED_DATA" ]]; then
    all=1
    for s in "${DATA_SETS[@]}"; do check_set "$SHARED_DATA" "$s" 1 || all=0; done
    if ((all)); then
      say "the data sets are present and verified in $(cd "$SHARED_DATA" && pwd) (../shared/data beside the checkout): nothing to do"
      exit 0
    fi
  fi
  DEST="$ROOT/data"
fi
if [[ -e "$DEST" && ! -d "$DEST" ]]; then
  die "the data folder $DEST exists and is not a folder"
fi

TODO=()
for s in "${DATA_SETS[@]}"; do
  if [[ -d "$DEST" ]] && check_set "$DEST" "$s" 1; then
    say "present and verified: $s in $DEST"
  else
    TODO+=("$s")
  fi
done
shared_note() {
  if [[ -z "${CTR_DATA:-}" && -d "$SHARED_DATA" ]]; then
    say "note: ../shared/data exists beside the checkout and is looked at before data/ (its data do not all check);"
    say "      export CTR_DATA=$DEST (and re-run cmake) to use the data in $DEST"
  fi
}
if ((${#TODO[@]} == 0)); then
  say "the data sets are present and verified in $DEST: nothing to do"
  shared_note
  exit 0
fi

# --- Fetch mode: fetching -------------------------------------------------------------------------------------------
command -v git > /dev/null 2>&1 ||
  die "git is not installed: it is needed to fetch ${TODO[*]} (Debian/Ubuntu: apt-get install git)"

# The user's environment must not redirect the git commands below to another repository.
unset GIT_DIR GIT_WORK_TREE GIT_INDEX_FILE GIT_OBJECT_DIRECTORY GIT_ALTERNATE_OBJECT_DIRECTORIES GIT_NAMESPACE \
  GIT_CEILING_DIRECTORIES GIT_COMMON_DIR
export GIT_TERMINAL_PROMPT=0   # a missing repository must fail, not ask for a password
MIRROR=${CTR_DATA_MIRROR:-https://github.com}
MIRROR=${MIRROR%/}

CREATED_DEST=0 DONE=0 WORK="" STAGE=""
cleanup() {
  [[ -n "$WORK" ]] && rm -rf -- "$WORK"
  [[ -n "$STAGE" ]] && rm -rf -- "$STAGE"
  if ((CREATED_DEST && !DONE)); then rm -rf -- "$DEST"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

WORK=$(mktemp -d "${TMPDIR:-/tmp}/ctr-fetch-data.XXXXXX") || die "cannot create a temporary folder"
if [[ ! -d "$DEST" ]]; then
  mkdir -p -- "$DEST" || die "cannot create the data folder $DEST"
  CREATED_DEST=1
fi
# Staged inside the data folder: the final moves are renames on one file system, and a failure leaves nothing
# outside it (the folder itself is removed when this run created it).
STAGE=$(mktemp -d "$DEST/.fetch-data.XXXXXX") || die "cannot write to the data folder $DEST"

GIT=(git -c http.lowSpeedLimit=1000 -c http.lowSpeedTime=60 -c advice.detachedHead=false)

fetch_set() {
  local set=$1 repo url commit gitdir rev i k p rel tree problems=0 ups=() rels=() idx=() files=() dirs=()
  local -A have=()
  repo=$(repo_of "$set")
  url="$MIRROR/$repo.git"
  commit=$(commit_of "$set")
  gitdir="$WORK/$set.git"
  say "fetching $set from $url at $commit"
  "${GIT[@]}" init -q --bare "$gitdir"
  if "${GIT[@]}" --git-dir="$gitdir" fetch -q --no-tags --depth 1 "$url" "$commit" 2> "$WORK/fetch.err"; then
    rev=$("${GIT[@]}" --git-dir="$gitdir" rev-parse --verify -q 'FETCH_HEAD^{commit}') ||
      die "data set $set: $url gave no commit for $commit"
  else
    # Some servers refuse a fetch by commit id or a shallow fetch: fetch all branches and tags, then look for it.
    if ! "${GIT[@]}" --git-dir="$gitdir" fetch -q "$url" '+refs/heads/*:refs/remotes/src/*' '+refs/tags/*:refs/tags/*' \
        2> "$WORK/fetch2.err"; then
      err "data set $set: cannot fetch from $url:"
      cat "$WORK/fetch.err" "$WORK/fetch2.err" | awk 'NF && !seen[$0]++ { print "  " $0 }' >&2
      die "check the network connection, or set CTR_DATA_MIRROR to a reachable mirror (see --help)"
    fi
    rev=$("${GIT[@]}" --git-dir="$gitdir" rev-parse --verify -q "$commit^{commit}" ||
          "${GIT[@]}" --git-dir="$gitdir" rev-parse --verify -q "refs/remotes/src/$commit^{commit}") ||
      die "data set $set: commit $commit not found in $url"
  fi
  # The files of the commit, then the ones wanted: each must be there.
  while IFS= read -r -d '' p; do have["$p"]=1; done < <("${GIT[@]}" --git-dir="$gitdir" ls-tree -r -z --name-only "$rev")
  for i in "${!SUM_PATH[@]}"; do
    [[ "${SUM_SET[$i]}" == "$set" ]] || continue
    upstream_path "$set" "${SUM_PATH[$i]}"
    if [[ -n "${have["$UP"]:-}" ]]; then
      ups+=("$UP") rels+=("${SUM_PATH[$i]}") idx+=("$i")
    else
      err "data set $set: missing file ${SUM_PATH[$i]} ('$UP' is not in $repo at commit $rev)"
      problems=1
    fi
  done
  # Written out in one go (a temporary index; no work tree), then checked in one go.
  tree="$WORK/$set.tree"
  if ((${#ups[@]})); then
    GIT_INDEX_FILE="$WORK/$set.index" "${GIT[@]}" --git-dir="$gitdir" read-tree "$rev" ||
      die "data set $set: cannot read commit $rev"
    mkdir -p -- "$tree"
    printf '%s\0' "${ups[@]}" |
      GIT_INDEX_FILE="$WORK/$set.index" "${GIT[@]}" --git-dir="$gitdir" --work-tree="$tree" checkout-index -z --stdin ||
      die "data set $set: cannot write the files of commit $rev to $tree"
  fi
  for k in "${!ups[@]}"; do files+=("$tree/${ups[$k]}"); done
  sha256_many "${files[@]}"
  for k in "${!ups[@]}"; do
    i=${idx[$k]}
    if [[ "${GOT[$k]}" != "${SUM_HASH[$i]}" ]]; then
      err "data set $set: SHA-256 mismatch for ${rels[$k]} ('${ups[$k]}' in $repo at commit $rev): expected ${SUM_HASH[$i]}, got ${GOT[$k]}"
      problems=1
    fi
  done
  ((problems == 0)) || die "data set $set from $url does not check: nothing was written to $DEST"
  # Into the local layout.
  for rel in "${rels[@]}"; do
    if [[ "$rel" == */* ]]; then dirs+=("$STAGE/$set/${rel%/*}"); fi
  done
  mkdir -p -- "$STAGE/$set" "${dirs[@]}"
  for k in "${!ups[@]}"; do mv -- "${files[$k]}" "$STAGE/$set/${rels[$k]}"; done
  {
    echo "# $set (fetched by scripts/fetch-data.sh)"
    echo
    echo "Source: github.com/$repo, commit $rev (pinned: $(pinned_of "$set"); fetched from $url)."
    echo "Licence: $(licence_of "$set")."
    case "$set" in
      med-mpd)
        echo "Files: the repository's folder Data/ (here without the Data/ prefix) and README.md, kept as"
        echo "README.upstream.md. Renamed: Brain/Patient2/'brainStructures.DKTatlas+aseg. deep.mgz' (space in the"
        echo "upstream name) to brainStructures.DKTatlas+aseg.deep.mgz."
        echo "Reference: Fried, Akulian, Alterovitz, \"A Clinical Dataset for the Evaluation of Motion Planners in"
        echo "Medical Applications\", IROS 2022 workshop, arXiv 2210.10834." ;;
      dupont-lab-ctr-trajectory-hjhdog1)
        echo "Files: copied byte-for-byte from the repository root. Format (19 whitespace-separated columns): time,"
        echo "alpha1..3, beta1..3, tip x y z, tip rotation (Simulation/SyntheticDataGenerator.cpp upstream)." ;;
    esac
    echo "Not part of the ctr repository: never copy these files into it."
  } > "$STAGE/$set/PROVENANCE.md"
  for i in "${!SUM_PATH[@]}"; do
    if [[ "${SUM_SET[$i]}" == "$set" ]]; then printf '%s  ./%s\n' "${SUM_HASH[$i]}" "${SUM_PATH[$i]}"; fi
  done > "$STAGE/$set/SHA256SUMS"
  say "verified: $set ($(count_of "$set") files)"
}

for s in "${TODO[@]}"; do fetch_set "$s"; done

# Everything checks: move the data sets into place (renames), replacing folders that failed their check.
for s in "${TODO[@]}"; do
  if [[ -e "$DEST/$s" || -L "$DEST/$s" ]]; then mv -- "$DEST/$s" "$STAGE/.replaced.$s"; fi
  mv -- "$STAGE/$s" "$DEST/$s"
done
DONE=1
say "fetched and verified in $DEST: ${TODO[*]}"
for s in "${TODO[@]}"; do say "licence of $s: $(licence_of "$s")"; done
shared_note
